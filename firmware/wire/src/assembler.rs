//! Bytes from a serial port into whole `0x00`-delimited frames.
//!
//! A [`FrameAssembler`] collects bytes up to each `0x00` in a fixed buffer and hands the
//! frame (delimiter included) to the caller to decode. A frame longer than the buffer is
//! garbage (line noise, a wrong baud rate): its bytes are dropped up to the next `0x00` and
//! it is reported once as [`Assembled::Overlong`], so the stream never stalls and the good
//! frames around it are kept.

/// What one byte completed.
#[derive(Debug, PartialEq, Eq)]
pub enum Assembled<'a> {
    /// Nothing yet.
    Pending,
    /// A whole frame, delimiter included (decode it in place).
    Frame(&'a mut [u8]),
    /// A frame longer than the buffer ended here: dropped.
    Overlong,
}

/// Collects bytes into frames of at most `N` bytes (delimiter included).
#[derive(Debug)]
pub struct FrameAssembler<const N: usize> {
    buf: [u8; N],
    len: usize,
    overflowed: bool,
}

impl<const N: usize> Default for FrameAssembler<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> FrameAssembler<N> {
    /// An empty assembler.
    pub const fn new() -> Self {
        Self {
            buf: [0; N],
            len: 0,
            overflowed: false,
        }
    }

    /// Feeds one byte.
    pub fn push(&mut self, byte: u8) -> Assembled<'_> {
        if self.overflowed {
            if byte == 0 {
                self.overflowed = false;
                self.len = 0;
                return Assembled::Overlong;
            }
            return Assembled::Pending;
        }
        let Some(slot) = self.buf.get_mut(self.len) else {
            self.overflowed = byte != 0;
            self.len = 0;
            return if byte == 0 {
                Assembled::Overlong
            } else {
                Assembled::Pending
            };
        };
        *slot = byte;
        self.len += 1;
        if byte != 0 {
            return Assembled::Pending;
        }
        let n = core::mem::take(&mut self.len);
        match self.buf.get_mut(..n) {
            Some(frame) => Assembled::Frame(frame),
            None => Assembled::Pending,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{OdometryFrame, MAX_ODOMETRY_FRAME_BYTES};

    fn frame(sequence: u32) -> OdometryFrame {
        OdometryFrame {
            sequence,
            time_us: 1_000_000 + 20_000 * u64::from(sequence),
            x_m: 0.4 * sequence as f32,
            y_m: -0.01,
            theta_rad: 0.002,
        }
    }

    /// Two frames around line garbage and a frame too long for the buffer: both good frames
    /// come out whole, the garbage as one malformed frame, the long one as `Overlong`.
    #[test]
    fn good_frames_survive_garbage_and_an_overlong_frame_around_them() {
        let mut bytes = [0u8; 256];
        let mut n = 0;
        let mut put = |b: &[u8]| {
            bytes[n..n + b.len()].copy_from_slice(b);
            n += b.len();
        };
        let mut buf = [0u8; MAX_ODOMETRY_FRAME_BYTES];
        put(frame(1).encode(&mut buf).unwrap());
        put(&[0x13, 0x37, 0x00]);
        put(&[0x55; 90]);
        put(&[0x00]);
        put(frame(2).encode(&mut buf).unwrap());
        let mut a: FrameAssembler<MAX_ODOMETRY_FRAME_BYTES> = FrameAssembler::new();
        let (mut good, mut malformed, mut overlong) = (0, 0, 0);
        for &b in &bytes[..n] {
            match a.push(b) {
                Assembled::Pending => {}
                Assembled::Overlong => overlong += 1,
                Assembled::Frame(f) => match OdometryFrame::decode(f) {
                    Ok(o) => {
                        good += 1;
                        assert_eq!(o, frame(good));
                    }
                    Err(_) => malformed += 1,
                },
            }
        }
        assert_eq!((good, malformed, overlong), (2, 1, 1));
    }

    #[test]
    fn an_odometry_frame_round_trips_within_its_bound() {
        let f = OdometryFrame {
            sequence: u32::MAX,
            time_us: u64::MAX,
            x_m: -1.0e30,
            y_m: f32::MIN_POSITIVE,
            theta_rad: -3.0,
        };
        let mut buf = [0u8; MAX_ODOMETRY_FRAME_BYTES];
        let encoded = f.encode(&mut buf).unwrap();
        assert!(encoded.len() <= MAX_ODOMETRY_FRAME_BYTES);
        assert_eq!(OdometryFrame::decode(encoded).unwrap(), f);
    }
}
