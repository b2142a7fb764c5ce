//! The vehicle's wheel odometry as the controller takes it: `controller_wire::OdometryFrame`s
//! read from the board's odometry port without blocking, and the motion between two scans
//! from the latest frames before each.
//!
//! The frames carry the vehicle's cumulative odometry pose, so the motion between scans is
//! the difference of two poses: frames lost on the line lose no motion. Odometry is used
//! for a scan only when a frame arrived within [`ODOMETRY_STALE_MS`] before it and one was at
//! hand at the previous scan; otherwise the controller predicts with constant velocity and
//! its pose frames say so (`MotionSource::ConstantVelocity`).
//!
//! Timing: the odometry at a scan is the latest frame received before the scan telegram.
//! A vehicle computer that sends one frame per scan, as the scan is taken (as `host-sim
//! hil` does), gives it exactly. One that streams frames at its own rate (seen once two or
//! more come between two scans) has the latest frame extrapolated to the telegram's
//! arrival, at the rate between the last two frames (by their own time stamps), for the
//! time since the latest arrived (board milliseconds; at most [`MAX_LEAD_PERIODS`] frame
//! periods). Taken as it is, each scan would sit up to one frame period of motion (3 cm at
//! 3 m/s and 100 Hz) from where the filter predicted it, and the next frame would add that
//! motion again: the along-tunnel error `host-sim replay` showed at 35 and 75 Hz scans with
//! 100 Hz odometry before it predicted to the scan's time (top-level README). The telegram
//! arrives a few milliseconds after its scan, about the same for every scan, so the delay
//! cancels in the motion between two scans. A frame that arrived while a scan was
//! processed is stamped when it is read, late by up to the processing time.
//!
//! On real silicon the port must not lose bytes while a scan is processed (≈ 9 ms at
//! 168 MHz, ≈ 100 bytes at 115200 baud): receive by DMA or interrupt into a ring buffer;
//! under QEMU the UART holds the line.

use controller_wire::{Assembled, FrameAssembler, OdometryFrame, MAX_ODOMETRY_FRAME_BYTES};
use embedded_io::{Read, ReadReady};
use loc_core::filter::OdometryIncrement;
use loc_core::geometry::Pose2;
use loc_core::scan::SweepMotion;

/// A frame older than this at a scan is stale, milliseconds (10 frames missed at 50 Hz).
pub const ODOMETRY_STALE_MS: u64 = 200;

/// Streamed frames are extrapolated to a scan by at most this many of their own periods
/// (the normal wait for the next frame, and some; a longer silence is not taken for steady
/// motion).
pub const MAX_LEAD_PERIODS: u64 = 2;

/// Counts of what arrived on the odometry port.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, defmt::Format)]
pub struct OdometryCounts {
    /// Frames decoded and used.
    pub frames: u32,
    /// Frames that did not decode, were too long, or held non-finite values (dropped).
    pub malformed: u32,
    /// Frames missing by the sender's sequence numbers.
    pub lost: u32,
}

/// The odometry input: frame assembly, the latest frame, and the frame at the last scan.
#[derive(Debug)]
pub struct OdometryInput {
    assembler: FrameAssembler<MAX_ODOMETRY_FRAME_BYTES>,
    /// The latest frame and when it first arrived (board milliseconds).
    latest: Option<(OdometryFrame, u64)>,
    /// When the latest frame, or a repeat of it, last arrived (board milliseconds): the
    /// odometry is alive while the vehicle repeats its reading.
    heard_ms: u64,
    /// The frame before the latest (the rate a streamed frame is extrapolated at).
    previous: Option<OdometryFrame>,
    /// Frames received since the last scan asked for its increment (from the first scan
    /// on).
    frames_since_scan: u16,
    /// Whether the vehicle streams odometry at its own rate rather than sending one frame
    /// per scan: set for good once two or more frames came between two scans (a vehicle
    /// streaming at the scan rate or slower is not told from one sending per scan).
    streamed: bool,
    /// The frame the previous scan was predicted to.
    at_last_scan: Option<OdometryFrame>,
    /// The first frame received before the first scan: the reading where the start pose
    /// holds (the vehicle's pose when the controller came up), so that the first scan is
    /// predicted by the motion since then rather than at constant velocity.
    start_reading: Option<OdometryFrame>,
    /// Whether a scan has asked for its increment (the start reading is then spent).
    scanned: bool,
    counts: OdometryCounts,
}

impl Default for OdometryInput {
    fn default() -> Self {
        Self::new()
    }
}

/// The cumulative odometry pose a frame carries (odometry frame).
pub(crate) fn pose(f: &OdometryFrame) -> Pose2 {
    Pose2::new(f.x_m, f.y_m, f.theta_rad)
}

impl OdometryInput {
    /// No odometry yet.
    pub const fn new() -> Self {
        Self {
            assembler: FrameAssembler::new(),
            latest: None,
            heard_ms: 0,
            previous: None,
            frames_since_scan: 0,
            streamed: false,
            at_last_scan: None,
            start_reading: None,
            scanned: false,
            counts: OdometryCounts {
                frames: 0,
                malformed: 0,
                lost: 0,
            },
        }
    }

    /// Reads every byte waiting on `port` (never blocks) at board time `now_ms`; a port
    /// error drops the frame in progress (its bytes are counted as malformed when the
    /// delimiter comes).
    pub fn poll<S: Read + ReadReady>(&mut self, port: &mut S, now_ms: u64) {
        let mut byte = [0u8; 1];
        while matches!(port.read_ready(), Ok(true)) {
            match port.read(&mut byte) {
                Ok(1) => self.push(byte[0], now_ms),
                _ => break,
            }
        }
    }

    /// Feeds one byte received at `now_ms`.
    pub fn push(&mut self, byte: u8, now_ms: u64) {
        match self.assembler.push(byte) {
            Assembled::Pending => {}
            Assembled::Overlong => self.counts.malformed += 1,
            Assembled::Frame(bytes) => match OdometryFrame::decode(bytes) {
                Ok(f) if f.is_finite() => {
                    self.heard_ms = now_ms;
                    let repeat = self
                        .latest
                        .is_some_and(|(l, _)| l.sequence == f.sequence && l.time_us == f.time_us);
                    if repeat {
                        // The same reading again (`host-sim hil` repeats it while the
                        // controller works): no new motion, no sign of streaming, and it
                        // keeps the time it first came.
                        self.counts.frames += 1;
                        return;
                    }
                    if let Some((prev, _)) = self.latest {
                        let gap = f.sequence.wrapping_sub(prev.sequence).wrapping_sub(1);
                        // A restart of the sender (sequence going back) is no loss.
                        if gap < u32::MAX / 2 {
                            self.counts.lost = self.counts.lost.saturating_add(gap);
                        }
                    }
                    self.counts.frames += 1;
                    self.previous = self.latest.map(|(p, _)| p);
                    self.latest = Some((f, now_ms));
                    // (Frames before the first scan lead up to it from the start reading:
                    // they say nothing of how the vehicle sends.)
                    if self.scanned {
                        self.frames_since_scan = self.frames_since_scan.saturating_add(1);
                    }
                    if !self.scanned && self.start_reading.is_none() {
                        self.start_reading = Some(f);
                    }
                }
                _ => self.counts.malformed += 1,
            },
        }
    }

    /// The motion since the previous scan (vehicle frame at the previous scan) when fresh
    /// odometry is at hand at `now_ms` and was at the previous scan; remembers the frame
    /// for the next scan either way. The first scan's motion is the one since the first
    /// frame received (the reading at the start pose; a reading kept across a reset, given
    /// by [`Self::resume_from`], comes first): a vehicle that is already moving when its
    /// first scan comes is predicted by its odometry, as every later scan.
    ///
    /// The frame the previous scan used is not fresh, however recent: no frame came in a
    /// whole scan period (a hiccup in the stream, or a frame still on the line when the
    /// telegram completed), and its zero increment would tell the filter the vehicle stood
    /// still (seen in the HIL under host load: a 210 Mahalanobis² rejection). That scan and
    /// the next are predicted at constant velocity instead.
    pub fn increment_for_scan(&mut self, now_ms: u64) -> Option<OdometryIncrement> {
        let reference = if self.scanned {
            self.at_last_scan
        } else {
            self.at_last_scan.or(self.start_reading)
        };
        self.scanned = true;
        self.streamed |= self.frames_since_scan >= 2;
        self.frames_since_scan = 0;
        let streamed = self.streamed;
        let used = self.at_last_scan.map(|f| f.sequence);
        let fresh = self
            .latest
            .filter(|(f, _)| {
                now_ms.saturating_sub(self.heard_ms) <= ODOMETRY_STALE_MS
                    && Some(f.sequence) != used
            })
            .map(|(f, at)| {
                if streamed {
                    self.extrapolated(f, now_ms.saturating_sub(at))
                } else {
                    f
                }
            });
        self.at_last_scan = fresh;
        let (reference, fresh) = (reference?, fresh?);
        // The start reading is all that came: no motion measured yet (the next scan's is
        // taken from it).
        (reference.sequence != fresh.sequence)
            .then(|| OdometryIncrement::between(&pose(&reference), &pose(&fresh)))
    }

    /// `latest`, received `age_ms` ago, carried on for that time at the rate between the
    /// frame before it and it (by their time stamps; at most [`MAX_LEAD_PERIODS`] of their
    /// period; as it is without a usable frame before it). Keeps its sequence number: it is
    /// still that frame's reading, moved to the scan.
    fn extrapolated(&self, latest: OdometryFrame, age_ms: u64) -> OdometryFrame {
        let Some((step, period_us)) = self.step_to(&latest) else {
            return latest;
        };
        let lead_us = age_ms
            .saturating_mul(1000)
            .min(period_us.saturating_mul(MAX_LEAD_PERIODS));
        let fraction = lead_us as f32 / period_us as f32;
        let lead = Pose2::new(
            step.x_m * fraction,
            step.y_m * fraction,
            step.theta_rad * fraction,
        );
        let at = pose(&latest).compose(&lead);
        OdometryFrame {
            time_us: latest.time_us.saturating_add(lead_us),
            x_m: at.x_m,
            y_m: at.y_m,
            theta_rad: at.theta_rad,
            ..latest
        }
    }

    /// The motion from the frame before `latest` to it (odometry frame at the earlier one)
    /// and the time between their stamps, µs: only for frames of the same run of the
    /// sender (a restarted one starts its sequence and its pose again: their difference is
    /// no motion) whose time moved on.
    fn step_to(&self, latest: &OdometryFrame) -> Option<(Pose2, u64)> {
        let previous = self.previous?;
        let period_us = latest.time_us.saturating_sub(previous.time_us);
        let after = latest.sequence.wrapping_sub(previous.sequence);
        (period_us > 0 && after != 0 && after < u32::MAX / 2)
            .then(|| (pose(&previous).between(&pose(latest)), period_us))
    }

    /// The vehicle's speed by its odometry: the motion between the last two frames over
    /// the time between their stamps (vehicle frame), for the sweep of a scan the
    /// localiser's own track does not reach yet ([`loc_core::localizer::Localizer::hint_sweep_speed`]).
    pub fn rate(&self) -> Option<SweepMotion> {
        let (latest, _) = self.latest?;
        let (step, period_us) = self.step_to(&latest)?;
        SweepMotion::from_motion(&step, period_us as f32 * 1e-6)
    }

    /// The reading the last scan was predicted to (`None`: it had no fresh odometry).
    pub fn at_last_scan(&self) -> Option<OdometryFrame> {
        self.at_last_scan
    }

    /// After a reset: takes `reading` (kept across the reset with the last tracked scan) as
    /// the previous scan's, so that the first scan's increment spans the outage.
    pub fn resume_from(&mut self, reading: OdometryFrame) {
        self.at_last_scan = Some(reading);
    }

    /// What arrived so far.
    pub fn counts(&self) -> OdometryCounts {
        self.counts
    }
}
