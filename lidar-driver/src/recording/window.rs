//! A sliding window over a byte source: the format readers look ahead as far as one record
//! and consume it, so memory stays at the largest record, whatever the file's size.

use std::io::{self, Read};

/// Bytes read from the source at a time.
const READ_CHUNK: usize = 64 * 1024;

/// A read-ahead buffer over `R`, with the file offset of what it holds.
pub(crate) struct Window<R> {
    source: R,
    buf: Vec<u8>,
    /// Start of the unconsumed bytes in `buf`.
    pos: usize,
    /// File offset of `buf[0]`.
    base: u64,
    eof: bool,
}

impl<R: Read> Window<R> {
    pub fn new(source: R) -> Self {
        Self {
            source,
            buf: Vec::new(),
            pos: 0,
            base: 0,
            eof: false,
        }
    }

    /// The next `n` unconsumed bytes, fewer only where the source ends.
    pub fn peek(&mut self, n: usize) -> io::Result<&[u8]> {
        while self.buf.len() - self.pos < n && !self.eof {
            if self.pos > 0 {
                // Drop what was consumed before growing.
                self.buf.drain(..self.pos);
                self.base += self.pos as u64;
                self.pos = 0;
            }
            let old = self.buf.len();
            let want = (n - old).max(READ_CHUNK);
            self.buf.resize(old + want, 0);
            let got = loop {
                match self.source.read(&mut self.buf[old..]) {
                    Ok(k) => break k,
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                    Err(e) => {
                        self.buf.truncate(old);
                        return Err(e);
                    }
                }
            };
            self.buf.truncate(old + got);
            self.eof = got == 0;
        }
        let end = (self.pos + n).min(self.buf.len());
        Ok(&self.buf[self.pos..end])
    }

    /// Consumes `n` bytes (at most what is buffered).
    pub fn consume(&mut self, n: usize) {
        self.pos = (self.pos + n).min(self.buf.len());
    }

    /// File offset of the next unconsumed byte.
    pub fn offset(&self) -> u64 {
        self.base + self.pos as u64
    }

    /// Whether the source is exhausted and everything consumed.
    pub fn at_end(&mut self) -> io::Result<bool> {
        Ok(self.peek(1)?.is_empty())
    }

    /// Consumes everything up to the end of the source; returns how many bytes that was.
    pub fn skip_to_end(&mut self) -> io::Result<u64> {
        let mut skipped = 0u64;
        loop {
            let n = self.peek(READ_CHUNK)?.len();
            if n == 0 {
                return Ok(skipped);
            }
            self.consume(n);
            skipped += n as u64;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A source that hands out at most 3 bytes per read.
    struct Trickle<'a>(&'a [u8]);

    impl Read for Trickle<'_> {
        fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
            let n = self.0.len().min(out.len()).min(3);
            out[..n].copy_from_slice(&self.0[..n]);
            self.0 = &self.0[n..];
            Ok(n)
        }
    }

    #[test]
    fn peeks_across_short_reads_and_keeps_offsets() {
        let data: Vec<u8> = (0..=255).collect();
        let mut w = Window::new(Trickle(&data));
        assert_eq!(w.peek(10).unwrap(), &data[..10]);
        w.consume(7);
        assert_eq!(w.offset(), 7);
        assert_eq!(w.peek(5).unwrap(), &data[7..12]);
        assert_eq!(w.peek(200).unwrap().len(), 200);
        w.consume(200);
        assert_eq!(w.peek(100).unwrap(), &data[207..]);
        assert_eq!(w.skip_to_end().unwrap(), 49);
        assert!(w.at_end().unwrap());
        assert_eq!(w.offset(), 256);
    }
}
