//! Streaming framer: bytes in any chunking become complete CoLa-A / CoLa-B frames.
//!
//! The caller owns the buffer (`[u8; N]`, `&mut [u8]`, `Vec<u8>`), so the framer runs without a
//! heap on the MCU. The dialect is detected per frame. Garbage between frames is skipped and
//! counted; a damaged frame (bad checksum, impossible length, CoLa-A frame without end) is
//! dropped alone: scanning resumes at the byte after its start marker, so good frames queued
//! behind it are kept even when its length field was the damaged part. A start marker split
//! across two pushes is kept, since incomplete frames stay in the buffer. The framer never stalls:
//! when the buffer is full, `next_frame` always consumes bytes.

use crate::frame::{
    is_cola_a_byte, Dialect, Frame, FrameError, COLA_B_HEADER_LEN, COLA_B_MAGIC, COLA_B_OVERHEAD,
    ETX, MIN_PAYLOAD_LEN, STX,
};

/// Smallest buffer a framer accepts, bytes: room for a CoLa-B header and a short telegram.
pub const MIN_BUFFER_LEN: usize = 16;

/// Counters of everything the framer saw, by outcome. All counts since creation or
/// [`Framer::reset_stats`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FramerStats {
    /// Bytes accepted by `push`.
    pub bytes_in: u64,
    /// Bytes skipped outside any frame (noise, partial frames from before a connect, bytes of
    /// dropped frames rescanned for a start marker).
    pub garbage_bytes: u64,
    /// Good CoLa-A frames returned.
    pub frames_cola_a: u64,
    /// Good CoLa-B frames returned.
    pub frames_cola_b: u64,
    /// CoLa-B frames dropped for a checksum mismatch.
    pub bad_checksum: u64,
    /// CoLa-B frames dropped for an impossible length field.
    pub bad_length: u64,
    /// CoLa-A frames dropped because no end marker came within the buffer.
    pub oversize: u64,
    /// Incomplete frames dropped at the end of the stream ([`Framer::finish`]).
    pub truncated: u64,
}

impl FramerStats {
    /// Good frames of both dialects.
    pub fn frames_good(&self) -> u64 {
        self.frames_cola_a + self.frames_cola_b
    }

    /// Frames dropped, all causes.
    pub fn frames_bad(&self) -> u64 {
        self.bad_checksum + self.bad_length + self.oversize + self.truncated
    }
}

/// Streaming framer over a caller-provided buffer `B`.
///
/// Use: `push` bytes (returns how many were taken; the rest must be pushed again after
/// draining), then call `next_frame` until it returns `None`. Or use [`Framer::feed`], which does
/// both. A returned [`Frame`] borrows the buffer until the next call.
///
/// Invariant: `start <= end <= buf.len()`; `buf[start..end]` holds bytes not yet framed.
#[derive(Debug)]
pub struct Framer<B> {
    buf: B,
    start: usize,
    end: usize,
    max_payload: usize,
    finished: bool,
    stats: FramerStats,
}

/// Outcome of examining the head of the buffer.
enum Head {
    /// Need more bytes.
    Wait,
    /// A good frame at `start..end`.
    Frame(Dialect, usize, usize),
    /// Drop the frame at `start`, resume scanning at `start + 1`.
    Drop(FrameError),
    /// `start` is not a frame start after all: skip one byte as garbage.
    Skip,
}

impl<B: AsRef<[u8]> + AsMut<[u8]>> Framer<B> {
    /// A framer over `buf`. The largest frame it can return is `buf.len()` bytes, so the largest
    /// CoLa-B payload is `buf.len() - 9`. An LMS511 scan at 1141 points needs 3553 bytes in
    /// CoLa-B and about 8.2 kB in CoLa-A: 16 KiB holds either with room to spare.
    ///
    /// Buffers shorter than [`MIN_BUFFER_LEN`] frame nothing (every byte is dropped).
    pub fn new(buf: B) -> Self {
        let cap = buf.as_ref().len();
        Framer {
            buf,
            start: 0,
            end: 0,
            max_payload: cap.saturating_sub(COLA_B_OVERHEAD),
            finished: false,
            stats: FramerStats::default(),
        }
    }

    /// A framer that also rejects CoLa-B length fields over `max_payload` bytes (clamped to
    /// what the buffer holds): a tighter limit finds damaged lengths sooner.
    pub fn with_max_payload(buf: B, max_payload: usize) -> Self {
        let mut f = Self::new(buf);
        f.max_payload = f.max_payload.min(max_payload);
        f
    }

    /// Buffer capacity, bytes.
    pub fn capacity(&self) -> usize {
        self.buf.as_ref().len()
    }

    /// Bytes held that are not framed yet.
    pub fn buffered(&self) -> usize {
        self.end - self.start
    }

    /// Counters since creation.
    pub fn stats(&self) -> &FramerStats {
        &self.stats
    }

    /// Zero the counters.
    pub fn reset_stats(&mut self) {
        self.stats = FramerStats::default();
    }

    /// Forget buffered bytes (after a reconnect); counters are kept.
    pub fn clear(&mut self) {
        self.start = 0;
        self.end = 0;
        self.finished = false;
    }

    /// Copies as many of `bytes` as fit into the buffer and returns that count. Returns less
    /// than `bytes.len()` only when the buffer is full: drain with `next_frame`, then push the
    /// rest. A push after [`Framer::finish`] re-opens the stream.
    pub fn push(&mut self, bytes: &[u8]) -> usize {
        let spare = self.spare_mut(bytes.len());
        let n = bytes.len().min(spare.len());
        if let (Some(dst), Some(src)) = (spare.get_mut(..n), bytes.get(..n)) {
            dst.copy_from_slice(src);
        }
        self.commit(n);
        n
    }

    /// The free space after the buffered bytes, for a transport to read into directly (no
    /// staging copy); [`Framer::commit`] then takes what was written. The unframed bytes
    /// are moved to the buffer's start first when fewer than `min_len` bytes are free after
    /// them, or none at all (so the move happens about once a frame, not on every read).
    /// Empty only when the buffer is full: drain with `next_frame` first.
    pub fn spare_mut(&mut self, min_len: usize) -> &mut [u8] {
        if self.start == self.end {
            // Nothing unframed: start over at the front, no bytes to move.
            self.start = 0;
            self.end = 0;
        } else if self.capacity() - self.end < min_len.max(1) && self.start > 0 {
            self.buf.as_mut().copy_within(self.start..self.end, 0);
            self.end -= self.start;
            self.start = 0;
        }
        let end = self.end;
        self.buf.as_mut().get_mut(end..).unwrap_or_default()
    }

    /// Takes the first `n` bytes of [`Framer::spare_mut`] as received (clamped to the free
    /// space). Like [`Framer::push`], it re-opens a finished stream.
    pub fn commit(&mut self, n: usize) {
        self.finished = false;
        let n = n.min(self.capacity() - self.end);
        self.end += n;
        self.stats.bytes_in += n as u64;
    }

    /// Marks the end of the stream: an incomplete frame at the head is then dropped (counted as
    /// truncated) and the bytes after its start marker are scanned again, so nothing waits for
    /// data that will not come.
    pub fn finish(&mut self) {
        self.finished = true;
    }

    /// The next complete frame, a dropped frame's error, or `None` when more bytes are needed.
    ///
    /// Errors are informational: the framer has already skipped the damaged frame, call again.
    pub fn next_frame(&mut self) -> Option<Result<Frame<'_>, FrameError>> {
        loop {
            // Skip to the next start marker.
            let (start, end) = (self.start, self.end);
            let hay = self.buf.as_ref().get(start..end).unwrap_or(&[]);
            match hay.iter().position(|&b| b == STX) {
                Some(i) => {
                    self.stats.garbage_bytes += i as u64;
                    self.start += i;
                }
                None => {
                    self.stats.garbage_bytes += hay.len() as u64;
                    self.start = 0;
                    self.end = 0;
                    return None;
                }
            }
            match self.examine_head() {
                Head::Wait => {
                    if self.finished && self.buffered() > 0 {
                        let have = self.buffered();
                        self.stats.truncated += 1;
                        self.start += 1;
                        return Some(Err(FrameError::Truncated { have }));
                    }
                    return None;
                }
                Head::Skip => {
                    self.stats.garbage_bytes += 1;
                    self.start += 1;
                }
                Head::Drop(e) => {
                    match e {
                        FrameError::BadChecksum { .. } => self.stats.bad_checksum += 1,
                        FrameError::BadLength { .. } => self.stats.bad_length += 1,
                        FrameError::Oversize { .. } => self.stats.oversize += 1,
                        FrameError::Truncated { .. } => self.stats.truncated += 1,
                        FrameError::NotAFrame => self.stats.garbage_bytes += 1,
                    }
                    self.start += 1;
                    return Some(Err(e));
                }
                Head::Frame(dialect, s, e) => {
                    self.start = e;
                    match dialect {
                        Dialect::ColaA => self.stats.frames_cola_a += 1,
                        Dialect::ColaB => self.stats.frames_cola_b += 1,
                    }
                    let bytes = self.buf.as_ref().get(s..e).unwrap_or(&[]);
                    return Some(Ok(Frame::from_checked(dialect, bytes)));
                }
            }
        }
    }

    /// Looks at the frame candidate starting at `self.start` (which holds an STX).
    fn examine_head(&self) -> Head {
        let cap = self.capacity();
        let s = self.start;
        let avail = self.buf.as_ref().get(s..self.end).unwrap_or(&[]);
        // CoLa-B if the magic is there (or may still be arriving).
        let magic_len = avail.len().min(COLA_B_MAGIC.len());
        let looks_b = avail.get(..magic_len) == COLA_B_MAGIC.get(..magic_len);
        if looks_b && avail.len() < COLA_B_MAGIC.len() {
            return Head::Wait;
        }
        if looks_b {
            let Some(len_bytes) = avail.get(4..COLA_B_HEADER_LEN) else {
                return Head::Wait;
            };
            let claimed =
                u32::from_be_bytes([len_bytes[0], len_bytes[1], len_bytes[2], len_bytes[3]]);
            let len = claimed as usize;
            if len < MIN_PAYLOAD_LEN || len > self.max_payload || len + COLA_B_OVERHEAD > cap {
                return Head::Drop(FrameError::BadLength {
                    claimed,
                    max: self.max_payload,
                });
            }
            let total = len + COLA_B_OVERHEAD;
            let Some(frame) = avail.get(..total) else {
                return Head::Wait;
            };
            let payload = frame.get(COLA_B_HEADER_LEN..total - 1).unwrap_or(&[]);
            let computed = crate::frame::xor_checksum(payload);
            let received = frame.get(total - 1).copied().unwrap_or(0);
            if computed != received {
                return Head::Drop(FrameError::BadChecksum { computed, received });
            }
            return Head::Frame(Dialect::ColaB, s, s + total);
        }
        // CoLa-A: printable ASCII up to ETX.
        for (i, &b) in avail.iter().enumerate().skip(1) {
            if b == ETX {
                return if i > MIN_PAYLOAD_LEN {
                    Head::Frame(Dialect::ColaA, s, s + i + 1)
                } else {
                    Head::Skip
                };
            }
            if !is_cola_a_byte(b) {
                // Not a CoLa-A frame (e.g. an STX inside binary data): rescan from the next byte.
                return Head::Skip;
            }
        }
        if avail.len() >= cap {
            return Head::Drop(FrameError::Oversize { max: cap });
        }
        Head::Wait
    }

    /// Pushes all of `bytes` and hands every frame (or drop) to `on_frame`, in order.
    pub fn feed(
        &mut self,
        mut bytes: &[u8],
        mut on_frame: impl FnMut(Result<Frame<'_>, FrameError>),
    ) {
        loop {
            let n = self.push(bytes);
            bytes = bytes.get(n..).unwrap_or(&[]);
            while let Some(r) = self.next_frame() {
                on_frame(r);
            }
            if bytes.is_empty() {
                return;
            }
            if n == 0 && self.buffered() == self.capacity() {
                // Cannot happen (a full buffer always frames or drops), but never spin.
                self.stats.garbage_bytes += self.buffered() as u64;
                self.clear();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::xor_checksum;

    fn colab(payload: &[u8]) -> Vec<u8> {
        let mut v = vec![2, 2, 2, 2];
        v.extend_from_slice(&(payload.len() as u32).to_be_bytes());
        v.extend_from_slice(payload);
        v.push(xor_checksum(payload));
        v
    }

    fn collect(
        f: &mut Framer<Vec<u8>>,
        bytes: &[u8],
        chunk: usize,
    ) -> Vec<Result<Vec<u8>, FrameError>> {
        let mut out = Vec::new();
        for c in bytes.chunks(chunk.max(1)) {
            f.feed(c, |r| out.push(r.map(|fr| fr.as_bytes().to_vec())));
        }
        f.finish();
        while let Some(r) = f.next_frame() {
            out.push(r.map(|fr| fr.as_bytes().to_vec()));
        }
        out
    }

    #[test]
    fn mixed_dialects_with_garbage_any_chunking() {
        let a = b"\x02sRN SCdevicestate\x03".to_vec();
        let b = colab(b"sEN LMDscandata \x01");
        let mut stream = b"xx\x03\x02\x02".to_vec();
        stream.extend_from_slice(&a);
        stream.extend_from_slice(b"garbage");
        stream.extend_from_slice(&b);
        stream.extend_from_slice(&a);
        for chunk in [1, 2, 3, 7, 1000] {
            let mut f = Framer::new(vec![0u8; 64]);
            let got = collect(&mut f, &stream, chunk);
            let good: Vec<_> = got
                .iter()
                .filter_map(|r| r.as_ref().ok())
                .cloned()
                .collect();
            assert_eq!(good, vec![a.clone(), b.clone(), a.clone()], "chunk {chunk}");
            assert_eq!(f.stats().frames_good(), 3);
        }
    }

    #[test]
    fn bogus_length_does_not_swallow_following_frames() {
        let good = colab(b"sRN ODoprh");
        let mut stream = vec![2, 2, 2, 2, 0, 0, 0, 40]; // claims 40 bytes, fits the buffer
        stream.extend_from_slice(&good);
        stream.extend_from_slice(&good);
        let mut f = Framer::new(vec![0u8; 128]);
        let got = collect(&mut f, &stream, 5);
        let good_n = got
            .iter()
            .filter(|r| r.as_ref().ok() == Some(&good))
            .count();
        assert_eq!(good_n, 2, "{got:?}");
        assert_eq!(f.stats().bad_checksum + f.stats().truncated, 1);
    }

    #[test]
    fn over_long_length_is_dropped_and_counted() {
        let good = colab(b"sRN ODoprh");
        let mut stream = vec![2, 2, 2, 2, 0xff, 0, 0, 0];
        stream.extend_from_slice(&good);
        let mut f = Framer::new([0u8; 64]);
        let mut out = Vec::new();
        f.feed(&stream, |r| out.push(r.map(|fr| fr.as_bytes().to_vec())));
        assert_eq!(out.len(), 2);
        assert!(matches!(out[0], Err(FrameError::BadLength { .. })));
        assert_eq!(out[1].as_ref().unwrap(), &good);
        assert_eq!(f.stats().bad_length, 1);
    }

    #[test]
    fn start_marker_split_across_pushes_is_kept() {
        let good = colab(b"sRN ODoprh");
        let mut f = Framer::new([0u8; 64]);
        let mut out = Vec::new();
        for piece in [&good[..2], &good[2..5], &good[5..]] {
            f.feed(piece, |r| out.push(r.map(|fr| fr.as_bytes().to_vec())));
        }
        assert_eq!(out, vec![Ok(good.clone())]);
        let mut f = Framer::new([0u8; 64]);
        f.feed(b"\x02", |_| panic!("incomplete"));
        f.feed(b"sRN x\x03", |r| {
            out.push(r.map(|fr| fr.as_bytes().to_vec()))
        });
        assert_eq!(out[1], Ok(b"\x02sRN x\x03".to_vec()));
    }

    #[test]
    fn configured_max_payload_rejects_long_frames() {
        let long = colab(&[b's'; 40]);
        let mut f = Framer::with_max_payload([0u8; 256], 32);
        let mut out = Vec::new();
        f.feed(&long, |r| out.push(r.map(|fr| fr.as_bytes().len())));
        assert_eq!(
            out[0],
            Err(FrameError::BadLength {
                claimed: 40,
                max: 32
            })
        );
        assert_eq!(f.stats().bad_length, 1);
        assert_eq!(f.stats().frames_good(), 0);
    }

    #[test]
    fn spare_space_moves_the_unframed_bytes_only_when_short() {
        let good = colab(b"sRN ODoprh"); // 19 bytes
        let mut f = Framer::new([0u8; 64]);
        let spare = f.spare_mut(1);
        assert_eq!(spare.len(), 64);
        spare[..19].copy_from_slice(&good);
        spare[19..24].copy_from_slice(&good[..5]);
        f.commit(24);
        assert_eq!(f.next_frame(), Some(Ok(Frame::new_checked(&good).unwrap())));
        assert_eq!(f.next_frame(), None);
        // Five unframed bytes at 19..24: 40 free after them, enough for a small read.
        assert_eq!(f.spare_mut(16).len(), 40);
        // Asked for more than that, the five move to the front.
        let spare = f.spare_mut(48);
        assert_eq!(spare.len(), 59);
        spare[..14].copy_from_slice(&good[5..]);
        f.commit(14);
        assert_eq!(f.next_frame(), Some(Ok(Frame::new_checked(&good).unwrap())));
        // Drained: the whole buffer again, and a commit past the end is clamped.
        assert_eq!(f.spare_mut(0).len(), 64);
        f.commit(1000);
        assert_eq!(f.buffered(), 64);
        assert!(f.spare_mut(1).is_empty());
        assert_eq!(f.stats().bytes_in, 24 + 14 + 64);
    }

    #[test]
    fn cola_a_without_end_never_stalls() {
        let mut f = Framer::new([0u8; 32]);
        let mut stream = vec![2u8];
        stream.extend(std::iter::repeat_n(b'a', 100));
        stream.extend_from_slice(b"\x02sRN x\x03");
        let mut out = Vec::new();
        f.feed(&stream, |r| out.push(r.map(|fr| fr.as_bytes().to_vec())));
        assert!(out
            .iter()
            .any(|r| r.as_ref().ok().map(|v| v.as_slice()) == Some(b"\x02sRN x\x03")));
        assert_eq!(f.stats().oversize, 1);
    }
}
