//! The receive side of one connection: the framer, and the time-out that drops a telegram
//! the client began and never finished ([`Limits::partial_frame_timeout`]).
//!
//! Without it a CoLa-B header whose length is longer than what follows would hold the
//! framer waiting for bytes that never come, and every request after it would be read as
//! that telegram's payload, unanswered. When the time-out passes, the framer is told the
//! stream ended ([`Framer::finish`]): it drops the incomplete telegram and scans the bytes
//! after its start marker again, so a request already sent behind it is answered then.
//!
//! [`Limits::partial_frame_timeout`]: crate::Limits::partial_frame_timeout

use std::time::{Duration, Instant};

use lidar_driver::frame::{Frame, FrameError};
use lidar_driver::framer::Framer;

/// Framer plus the age of the incomplete telegram at the head of its buffer.
pub(crate) struct Receiver {
    framer: Framer<Vec<u8>>,
    timeout: Duration,
    /// When the incomplete telegram at the head of the buffer began (the read that brought
    /// it, or the one that completed the telegram before it); `None` when nothing is held.
    pending_since: Option<Instant>,
}

impl Receiver {
    /// A receiver over a buffer of `capacity` bytes that drops a telegram still incomplete
    /// `timeout` after it began.
    pub(crate) fn new(capacity: usize, timeout: Duration) -> Self {
        Receiver {
            framer: Framer::new(vec![0u8; capacity]),
            timeout,
            pending_since: None,
        }
    }

    /// Frames `bytes`, received at `now`, handing every good frame to `on_frame`.
    pub(crate) fn feed(&mut self, bytes: &[u8], now: Instant, mut on_frame: impl FnMut(Frame<'_>)) {
        let mut head_moved = false;
        self.framer.feed(bytes, |r| {
            head_moved = true;
            if let Ok(frame) = r {
                on_frame(frame);
            }
        });
        // What the framer holds after a feed starts with a start marker: an incomplete
        // telegram. It began now unless it is the one that was already waiting.
        self.pending_since = match self.pending_since {
            _ if self.framer.buffered() == 0 => None,
            Some(t) if !head_moved => Some(t),
            _ => Some(now),
        };
    }

    /// When the incomplete telegram held times out, if one is held.
    pub(crate) fn deadline(&self) -> Option<Instant> {
        self.pending_since.map(|t| t + self.timeout)
    }

    /// At `now`, past the deadline: drops the incomplete telegram, hands the good frames
    /// found in the bytes after its start to `on_frame`, and returns how many incomplete
    /// telegrams were dropped (0 before the deadline).
    pub(crate) fn expire(&mut self, now: Instant, mut on_frame: impl FnMut(Frame<'_>)) -> u64 {
        if self.deadline().is_none_or(|d| now < d) {
            return 0;
        }
        self.pending_since = None;
        self.framer.finish();
        let mut dropped = 0;
        while let Some(r) = self.framer.next_frame() {
            match r {
                Ok(frame) => on_frame(frame),
                Err(FrameError::Truncated { .. }) => dropped += 1,
                Err(_) => {}
            }
        }
        dropped
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn colab(payload: &[u8]) -> Vec<u8> {
        let mut v = vec![2, 2, 2, 2];
        v.extend_from_slice(&(payload.len() as u32).to_be_bytes());
        v.extend_from_slice(payload);
        v.push(lidar_driver::frame::xor_checksum(payload));
        v
    }

    fn frames_of(rx: &mut Receiver, bytes: &[u8], now: Instant) -> Vec<Vec<u8>> {
        let mut got = Vec::new();
        rx.feed(bytes, now, |f| got.push(f.as_bytes().to_vec()));
        got
    }

    #[test]
    fn a_long_length_is_dropped_after_the_time_out_and_what_follows_is_read_again() {
        let t0 = Instant::now();
        let ms = Duration::from_millis;
        let mut rx = Receiver::new(4096, ms(100));
        let request = colab(b"sRN FirmwareVersion");
        // A header claiming 256 bytes, eight of them sent: nothing framed, a deadline set.
        let mut half = vec![2, 2, 2, 2, 0, 0, 1, 0];
        half.extend_from_slice(b"sRN Devi");
        assert!(frames_of(&mut rx, &half, t0).is_empty());
        assert_eq!(rx.deadline(), Some(t0 + ms(100)));
        // The next request is read as its payload; the deadline stays the first telegram's.
        assert!(frames_of(&mut rx, &request, t0 + ms(50)).is_empty());
        assert_eq!(rx.deadline(), Some(t0 + ms(100)));
        let mut got = Vec::new();
        assert_eq!(
            rx.expire(t0 + ms(99), |f| got.push(f.as_bytes().to_vec())),
            0
        );
        assert!(got.is_empty());
        // At the deadline the half telegram goes and the request behind it is found.
        assert_eq!(
            rx.expire(t0 + ms(100), |f| got.push(f.as_bytes().to_vec())),
            1
        );
        assert_eq!(got, vec![request.clone()]);
        assert_eq!(rx.deadline(), None);
        // And the stream goes on normally.
        assert_eq!(frames_of(&mut rx, &request, t0 + ms(200)), vec![request]);
        assert_eq!(rx.deadline(), None);
    }

    #[test]
    fn a_telegram_completed_in_time_is_not_dropped() {
        let t0 = Instant::now();
        let ms = Duration::from_millis;
        let mut rx = Receiver::new(4096, ms(100));
        let request = colab(b"sRN FirmwareVersion");
        let (a, b) = request.split_at(10);
        // The first request completes at 90 ms, and the start of the second arrives with
        // it: the second's deadline counts from then.
        assert!(frames_of(&mut rx, a, t0).is_empty());
        let mut tail = b.to_vec();
        tail.extend_from_slice(a);
        assert_eq!(
            frames_of(&mut rx, &tail, t0 + ms(90)),
            vec![request.clone()]
        );
        assert_eq!(rx.deadline(), Some(t0 + ms(190)));
        assert_eq!(rx.expire(t0 + ms(150), |_| panic!("nothing to frame")), 0);
        assert_eq!(frames_of(&mut rx, b, t0 + ms(180)), vec![request]);
        assert_eq!(rx.deadline(), None);
    }
}
