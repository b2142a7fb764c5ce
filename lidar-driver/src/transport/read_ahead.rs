//! A small receive buffer that turns a std stream with a short read time-out into an
//! `embedded-io` reader with [`embedded_io::ReadReady`]: `read_ready` waits at most the
//! stream's read time-out for the first bytes and keeps them for the next `read`.

use std::io;

/// Bytes read ahead of the caller. Invariant: `pos <= len <= buf.len()`.
#[derive(Debug)]
pub(crate) struct ReadAhead {
    buf: Box<[u8]>,
    pos: usize,
    len: usize,
    eof: bool,
}

impl ReadAhead {
    /// A buffer of `cap` bytes.
    pub(crate) fn new(cap: usize) -> Self {
        ReadAhead {
            buf: vec![0u8; cap.max(1)].into_boxed_slice(),
            pos: 0,
            len: 0,
            eof: false,
        }
    }

    /// Forgets buffered bytes and the end-of-stream mark (after a re-connect).
    pub(crate) fn clear(&mut self) {
        self.pos = 0;
        self.len = 0;
        self.eof = false;
    }

    /// True if bytes or the end of stream are waiting; else reads once from `src` (which waits
    /// at most its read time-out).
    pub(crate) fn ready(&mut self, src: &mut impl io::Read) -> io::Result<bool> {
        if self.pos < self.len || self.eof {
            return Ok(true);
        }
        match src.read(&mut self.buf) {
            Ok(0) => {
                self.eof = true;
                Ok(true)
            }
            Ok(n) => {
                self.pos = 0;
                self.len = n;
                Ok(true)
            }
            Err(e) if is_no_data(&e) => Ok(false),
            Err(e) => Err(e),
        }
    }

    /// Serves buffered bytes first, then reads `src` directly. "No data" time-outs come back as
    /// [`io::ErrorKind::TimedOut`] (Linux reports them as `WouldBlock`, which `embedded-io` has
    /// no kind for).
    pub(crate) fn read(&mut self, src: &mut impl io::Read, out: &mut [u8]) -> io::Result<usize> {
        if self.pos < self.len {
            let n = out.len().min(self.len - self.pos);
            out[..n].copy_from_slice(&self.buf[self.pos..self.pos + n]);
            self.pos += n;
            return Ok(n);
        }
        if self.eof {
            return Ok(0);
        }
        match src.read(out) {
            Err(e) if is_no_data(&e) => Err(io::Error::from(io::ErrorKind::TimedOut)),
            r => r,
        }
    }
}

/// A read time-out or an interrupted call: no data yet, try again later.
/// The open connection, or `NotConnected` (a link between `close` and `reconnect`).
pub(crate) fn connected<T>(link: &mut Option<T>) -> io::Result<&mut T> {
    link.as_mut()
        .ok_or_else(|| io::Error::from(io::ErrorKind::NotConnected))
}

pub(crate) fn is_no_data(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut | io::ErrorKind::Interrupted
    )
}

/// `embedded-io`'s `ErrorType`, `Read` and `ReadReady` for a link that reads its connection
/// (`Option<_>` field `$conn`, `None` while closed) through its `ahead: ReadAhead`.
macro_rules! read_through_ahead {
    ($link:ty, $conn:ident) => {
        impl embedded_io::ErrorType for $link {
            type Error = std::io::Error;
        }

        impl embedded_io::Read for $link {
            fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
                self.ahead.read(connected(&mut self.$conn)?, buf)
            }
        }

        impl embedded_io::ReadReady for $link {
            fn read_ready(&mut self) -> std::io::Result<bool> {
                self.ahead.ready(connected(&mut self.$conn)?)
            }
        }
    };
}
pub(crate) use read_through_ahead;

#[cfg(test)]
mod tests {
    use super::*;

    struct Chunks(Vec<io::Result<Vec<u8>>>);
    impl io::Read for Chunks {
        fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
            if self.0.is_empty() {
                return Ok(0);
            }
            match self.0.remove(0) {
                Ok(v) => {
                    out[..v.len()].copy_from_slice(&v);
                    Ok(v.len())
                }
                Err(e) => Err(e),
            }
        }
    }

    #[test]
    fn timeouts_are_not_ready_and_bytes_are_kept() {
        let mut src = Chunks(vec![
            Err(io::ErrorKind::WouldBlock.into()),
            Ok(b"abc".to_vec()),
            Err(io::ErrorKind::WouldBlock.into()),
        ]);
        let mut ra = ReadAhead::new(16);
        assert!(!ra.ready(&mut src).unwrap());
        assert!(ra.ready(&mut src).unwrap());
        let mut out = [0u8; 2];
        assert_eq!(ra.read(&mut src, &mut out).unwrap(), 2);
        assert_eq!(&out, b"ab");
        assert_eq!(ra.read(&mut src, &mut out).unwrap(), 1);
        let e = ra.read(&mut src, &mut out).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::TimedOut);
        // End of stream: ready, then read returns 0 until cleared.
        assert!(ra.ready(&mut src).unwrap());
        assert_eq!(ra.read(&mut src, &mut out).unwrap(), 0);
        assert_eq!(ra.read(&mut src, &mut out).unwrap(), 0);
        ra.clear();
        assert!(ra.ready(&mut src).unwrap());
    }
}
