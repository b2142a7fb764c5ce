//! One lidar scan: beam ranges in the sensor frame turned into points in the vehicle frame.
//!
//! The LMS511 reports `n` ranges at angles `start + i · step` in its own (sensor) frame,
//! −5°…+185° with 90° straight ahead of the scanner. [`ScanGeometry`] holds that beam layout,
//! [`SensorSetup`] adds where the scanner sits on the vehicle, and [`Scan`] keeps the valid
//! beams as [`ScanPoint`]s: vehicle-frame coordinates plus the beam's own angle and range
//! (stripping and the range-noise covariance model want those).
//!
//! Beams are skipped, never fatal: a beam that reads 0 (no echo), a saturated raw reading
//! (`0xFFFF`: the echo lies beyond what the channel's scale can encode), a non-finite range,
//! a range outside `[min_range_m, max_range_m]`, or a beam beyond the fixed capacity
//! [`LMS511_MAX_BEAMS`] is counted in [`DroppedBeams`] and left out.
//!
//! A scan loaded from a telegram also knows when its beams were taken ([`ScanTiming`]);
//! [`Scan::deskew`] then places every echo where it lies at the scan's last beam, given the
//! vehicle's motion over the sweep ([`SweepMotion`], `scan/sweep.rs`).

mod sweep;

pub use sweep::{ScanTiming, SweepMotion, MAX_SWEEP_S, MAX_SWEEP_SPEED_MPS, MAX_SWEEP_TURN_RAD};

use core::f32::consts::PI;

use crate::geometry::{Point2, Pose2};

/// Most beams one LMS511 telegram carries (190° at 0.1667°), and the capacity of a [`Scan`].
pub const LMS511_MAX_BEAMS: usize = 1141;

/// Radians per 1/10000 degree (the telegram's angle unit).
const RAD_PER_1E4_DEG: f32 = PI / 180.0 / 10_000.0;

/// The beam layout of a scanner in the sensor frame.
///
/// Beam `i` points at `start_angle_rad + i · step_rad` (sensor frame, counter-clockwise
/// from the sensor's x axis). Ranges outside `[min_range_m, max_range_m]` are not trusted.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ScanGeometry {
    /// Angle of beam 0 in the sensor frame, radians.
    pub start_angle_rad: f32,
    /// Angle between consecutive beams, radians (positive: counter-clockwise order).
    pub step_rad: f32,
    /// Shortest range accepted, metres (closer echoes are the vehicle itself or dust).
    pub min_range_m: f32,
    /// Longest range accepted, metres.
    pub max_range_m: f32,
}

impl ScanGeometry {
    /// Shortest range accepted by [`ScanGeometry::lms511`], metres. The LMS511's own
    /// near limit is below this; closer echoes on a loader are its own body, buckets or dust.
    pub const LMS511_MIN_RANGE_M: f32 = 0.7;
    /// Longest range of the LMS511, metres.
    pub const LMS511_MAX_RANGE_M: f32 = 80.0;

    /// The LMS511 at 25 Hz: −5°…+185° at 0.1667° (1141 beams), 0.7–80 m. Built from the
    /// telegram units the scanner itself reports (−50000 and 1667 in 1/10000°).
    pub const fn lms511() -> Self {
        Self::from_telegram_units(
            -50_000,
            1_667,
            Self::LMS511_MIN_RANGE_M,
            Self::LMS511_MAX_RANGE_M,
        )
    }

    /// A geometry from the telegram's units: start angle and angular step in 1/10000 degree
    /// (`LMDscandata` gives the step as u16; `LMPoutputRange` as u32), ranges in metres.
    pub const fn from_telegram_units(
        start_angle_1e4_deg: i32,
        step_1e4_deg: u32,
        min_range_m: f32,
        max_range_m: f32,
    ) -> Self {
        Self {
            start_angle_rad: start_angle_1e4_deg as f32 * RAD_PER_1E4_DEG,
            step_rad: step_1e4_deg as f32 * RAD_PER_1E4_DEG,
            min_range_m,
            max_range_m,
        }
    }

    /// Sensor-frame angle of beam `index`, radians (not wrapped).
    #[inline]
    pub fn beam_angle_rad(&self, index: usize) -> f32 {
        self.start_angle_rad + index as f32 * self.step_rad
    }

    /// Number of beams covering `start_angle_rad` to `end_angle_rad` inclusive (rounded to
    /// the nearest whole beam), capped at [`LMS511_MAX_BEAMS`]; 0 for an invalid geometry.
    pub fn beam_count_to(&self, end_angle_rad: f32) -> usize {
        if !self.is_valid() || !end_angle_rad.is_finite() {
            return 0;
        }
        let n = (end_angle_rad - self.start_angle_rad) / self.step_rad;
        if n < 0.0 {
            return 0;
        }
        let beams = crate::math::floor(n + 0.5) as usize + 1;
        beams.min(LMS511_MAX_BEAMS)
    }

    /// True when every field is finite, the step is non-zero and
    /// `0 <= min_range_m < max_range_m`.
    pub fn is_valid(&self) -> bool {
        self.start_angle_rad.is_finite()
            && self.step_rad.is_finite()
            && self.step_rad != 0.0
            && self.min_range_m.is_finite()
            && self.max_range_m.is_finite()
            && self.min_range_m >= 0.0
            && self.min_range_m < self.max_range_m
    }

    /// True when `range_m` is finite and within `[min_range_m, max_range_m]`.
    #[inline]
    pub fn accepts_range(&self, range_m: f32) -> bool {
        range_m.is_finite() && range_m >= self.min_range_m && range_m <= self.max_range_m
    }
}

impl Default for ScanGeometry {
    /// The LMS511 at 0.1667° ([`ScanGeometry::lms511`]).
    fn default() -> Self {
        Self::lms511()
    }
}

/// A scanner's beam layout plus where it sits on the vehicle.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SensorSetup {
    /// Beam layout in the sensor frame.
    pub geometry: ScanGeometry,
    /// The sensor frame in the vehicle frame (x forward, y left): a scanner at the front
    /// centre whose 90° beam looks straight ahead has `theta_rad = −π/2`.
    pub mounting: Pose2,
}

impl SensorSetup {
    /// An LMS511 at `(x_m, y_m)` in the vehicle frame, its 90° beam looking forward
    /// (mounting heading −π/2), so the scan covers −95°…+95° about the vehicle's x axis.
    pub const fn lms511_forward(x_m: f32, y_m: f32) -> Self {
        Self {
            geometry: ScanGeometry::lms511(),
            // −π/2 is inside (−π, π]: no wrapping needed (`Pose2::new` wraps, and is not const).
            mounting: Pose2 {
                x_m,
                y_m,
                theta_rad: -PI / 2.0,
            },
        }
    }

    /// Vehicle-frame angle of beam `index` (sensor angle + mounting heading, not wrapped).
    #[inline]
    pub fn beam_angle_vehicle_rad(&self, index: usize) -> f32 {
        self.geometry.beam_angle_rad(index) + self.mounting.theta_rad
    }
}

impl SensorSetup {
    /// An LMS511 at the vehicle origin looking forward ([`SensorSetup::lms511_forward`]),
    /// usable in `const` and `static` items.
    pub const DEFAULT: Self = Self::lms511_forward(0.0, 0.0);
}

impl Default for SensorSetup {
    /// An LMS511 at the vehicle origin looking forward ([`SensorSetup::lms511_forward`]).
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// One valid beam of a scan.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ScanPoint {
    /// The echo in the vehicle frame, metres.
    pub vehicle: Point2,
    /// The beam's angle in the sensor frame, radians (`start + index · step`).
    pub angle_rad: f32,
    /// Measured range from the sensor's optical centre, metres.
    pub range_m: f32,
    /// Index of the beam in the telegram (0-based).
    pub beam_index: u16,
}

/// One beam as offered to a scan.
#[derive(Debug, Clone, Copy)]
enum Beam {
    /// A range, metres (still to be validated).
    Range(f32),
    /// No echo.
    NoEcho,
    /// A saturated raw reading.
    Saturated,
}

/// How many beams of a scan were left out, and why. Counts saturate at `u16::MAX`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DroppedBeams {
    /// Beams reading 0 (the scanner saw no echo).
    pub no_echo: u16,
    /// Raw readings of `0xFFFF`: the echo is beyond what the channel's scale factor can
    /// encode (a clamped value, not a range).
    pub saturated: u16,
    /// Beams whose range (or angle) is NaN or infinite.
    pub non_finite: u16,
    /// Beams closer than `min_range_m`.
    pub below_min_range: u16,
    /// Beams farther than `max_range_m`.
    pub above_max_range: u16,
    /// Beams beyond the scan's capacity of [`LMS511_MAX_BEAMS`].
    pub over_capacity: u16,
}

impl DroppedBeams {
    /// Total beams dropped.
    pub fn total(&self) -> u32 {
        u32::from(self.no_echo)
            + u32::from(self.saturated)
            + u32::from(self.non_finite)
            + u32::from(self.below_min_range)
            + u32::from(self.above_max_range)
            + u32::from(self.over_capacity)
    }
}

/// The valid beams of one scan as vehicle-frame points, in beam order, with the counts of
/// dropped beams. Fixed capacity [`LMS511_MAX_BEAMS`] (about 32 KiB with the beam-direction
/// table): build it once and refill it with the `load_*` methods rather than moving it
/// around on small stacks.
#[derive(Debug, Clone, Default)]
pub struct Scan {
    points: heapless::Vec<ScanPoint, LMS511_MAX_BEAMS>,
    dropped: DroppedBeams,
    beams_received: u16,
    /// When the beams were taken (`None`: unknown, as if at one instant).
    timing: Option<ScanTiming>,
    /// The motion the points were carried by ([`Scan::deskew`]), once.
    deskewed: Option<SweepMotion>,
    directions: BeamDirections,
}

/// Unit vectors of the beams in the sensor frame, `(cos, sin)` of `start + i · step`, kept
/// from one scan to the next while the beam layout stays the same: one `sin_cos` per beam
/// is about half of the conversion's cost on the Cortex-M4F. The same [`crate::math::sin_cos`]
/// gives them as a per-beam call would, so points are bit-identical either way.
#[derive(Debug, Clone)]
struct BeamDirections {
    /// Layout the table was computed for (`start_angle_rad`, `step_rad`), `None` when empty.
    layout: Option<(f32, f32)>,
    /// Beams computed so far (the table grows with the longest scan seen).
    len: usize,
    unit: [Point2; LMS511_MAX_BEAMS],
}

impl BeamDirections {
    const fn new() -> Self {
        Self {
            layout: None,
            len: 0,
            unit: [Point2::ORIGIN; LMS511_MAX_BEAMS],
        }
    }

    /// Makes beams `0..beams` of layout `g` available to [`BeamDirections::unit`]
    /// (computed once per layout; later scans of the same layout find them ready).
    fn prepare(&mut self, g: &ScanGeometry, beams: usize) {
        let layout = (g.start_angle_rad, g.step_rad);
        if self.layout != Some(layout) {
            self.layout = Some(layout);
            self.len = 0;
        }
        let beams = beams.min(LMS511_MAX_BEAMS);
        while self.len < beams {
            let Some(slot) = self.unit.get_mut(self.len) else {
                break;
            };
            *slot = Point2::from_polar(1.0, g.beam_angle_rad(self.len));
            self.len += 1;
        }
    }

    /// The unit vector of beam `index` of the prepared layout `g`.
    #[inline]
    fn unit(&self, g: &ScanGeometry, index: usize) -> Point2 {
        match self.unit.get(index) {
            Some(&u) if index < self.len => u,
            _ => Point2::from_polar(1.0, g.beam_angle_rad(index)),
        }
    }
}

impl Default for BeamDirections {
    fn default() -> Self {
        Self::new()
    }
}

impl Scan {
    /// An empty scan.
    pub const fn new() -> Self {
        Self {
            points: heapless::Vec::new(),
            dropped: DroppedBeams {
                no_echo: 0,
                saturated: 0,
                non_finite: 0,
                below_min_range: 0,
                above_max_range: 0,
                over_capacity: 0,
            },
            beams_received: 0,
            timing: None,
            deskewed: None,
            directions: BeamDirections::new(),
        }
    }

    /// A scan from ranges in metres, beam `i` at `setup.geometry.beam_angle_rad(i)`.
    /// A range of exactly 0 counts as no echo.
    pub fn from_ranges_m(setup: &SensorSetup, ranges_m: &[f32]) -> Self {
        let mut scan = Self::new();
        scan.load_ranges_m(setup, ranges_m);
        scan
    }

    /// A scan from the telegram's raw u16 values: range in mm = `raw · scale_factor +
    /// scale_offset_mm` (the `DIST1` channel's scale factor and offset); raw 0 is no echo,
    /// raw `0xFFFF` a saturated reading (dropped as [`DroppedBeams::saturated`]).
    pub fn from_raw_mm(
        setup: &SensorSetup,
        raw: &[u16],
        scale_factor: f32,
        scale_offset_mm: f32,
    ) -> Self {
        let mut scan = Self::new();
        scan.load_raw_mm(setup, raw, scale_factor, scale_offset_mm);
        scan
    }

    /// Replaces the contents with ranges in metres (see [`Scan::from_ranges_m`]).
    pub fn load_ranges_m(&mut self, setup: &SensorSetup, ranges_m: &[f32]) {
        self.load_beams(
            setup,
            ranges_m.len(),
            ranges_m.iter().map(|&r| {
                if r == 0.0 {
                    Beam::NoEcho
                } else {
                    Beam::Range(r)
                }
            }),
        );
    }

    /// Replaces the contents with raw telegram values (see [`Scan::from_raw_mm`]).
    pub fn load_raw_mm(
        &mut self,
        setup: &SensorSetup,
        raw: &[u16],
        scale_factor: f32,
        scale_offset_mm: f32,
    ) {
        self.load_raw_values(setup, raw.iter().copied(), scale_factor, scale_offset_mm);
    }

    /// [`Scan::load_raw_mm`] from an iterator of raw values (a telegram's channel read in
    /// place, without a copy).
    pub fn load_raw_values(
        &mut self,
        setup: &SensorSetup,
        raw: impl ExactSizeIterator<Item = u16>,
        scale_factor: f32,
        scale_offset_mm: f32,
    ) {
        self.load_beams(
            setup,
            raw.len(),
            raw.map(|v| match v {
                0 => Beam::NoEcho,
                u16::MAX => Beam::Saturated,
                _ => Beam::Range((f32::from(v) * scale_factor + scale_offset_mm) * 0.001),
            }),
        );
    }

    /// Replaces the contents with `beams` beams, beam `i` at
    /// `setup.geometry.beam_angle_rad(i)`, validated and turned into vehicle-frame points.
    fn load_beams(
        &mut self,
        setup: &SensorSetup,
        beams: usize,
        ranges: impl Iterator<Item = Beam>,
    ) {
        self.clear();
        let g = &setup.geometry;
        let mount = setup.mounting.transform();
        self.directions.prepare(g, beams);
        let Self {
            points,
            dropped,
            beams_received,
            directions,
            ..
        } = self;
        let count = |c: &mut u16| *c = c.saturating_add(1);
        // `for_each`, not `for`: it lets a telegram's value iterator dispatch on its wire
        // format once per scan instead of once per beam (a third of the conversion's cost
        // on the Cortex-M4F).
        ranges.enumerate().for_each(|(index, beam)| {
            count(beams_received);
            let range_m = match beam {
                Beam::Range(r) => r,
                Beam::NoEcho => return count(&mut dropped.no_echo),
                Beam::Saturated => return count(&mut dropped.saturated),
            };
            let angle_rad = g.beam_angle_rad(index);
            if !range_m.is_finite() || !angle_rad.is_finite() {
                count(&mut dropped.non_finite);
            } else if range_m < g.min_range_m {
                count(&mut dropped.below_min_range);
            } else if range_m > g.max_range_m {
                count(&mut dropped.above_max_range);
            } else {
                let unit = directions.unit(g, index);
                let point = ScanPoint {
                    vehicle: mount.apply(Point2::new(range_m * unit.x_m, range_m * unit.y_m)),
                    angle_rad,
                    range_m,
                    beam_index: crate::math::saturating_u16(index),
                };
                if points.push(point).is_err() {
                    count(&mut dropped.over_capacity);
                }
            }
        });
    }

    /// Computes the beam directions of layout `geometry` (sensor frame) for a full
    /// [`LMS511_MAX_BEAMS`]-beam scan now, so that the first scan of that layout costs what
    /// the others do (otherwise it computes them: 1141 `sin_cos`, about 85 000
    /// instructions on the Cortex-M4F). Scans of another layout recompute the table.
    pub fn prepare_directions(&mut self, geometry: &ScanGeometry) {
        self.directions.prepare(geometry, LMS511_MAX_BEAMS);
    }

    /// Empties the scan and resets the counts and the timing.
    pub fn clear(&mut self) {
        self.points.clear();
        self.dropped = DroppedBeams::default();
        self.beams_received = 0;
        self.timing = None;
        self.deskewed = None;
    }

    /// Says when the loaded beams were taken (the loader's job: `scan-input` takes it from
    /// the telegram's header). Loading a scan forgets it.
    pub fn set_timing(&mut self, timing: Option<ScanTiming>) {
        self.timing = timing;
    }

    /// When the beams were taken, if known.
    #[inline]
    pub fn timing(&self) -> Option<ScanTiming> {
        self.timing
    }

    /// Seconds from the first beam received to the last (0 without a timing).
    pub fn sweep_s(&self) -> f32 {
        self.timing.map_or(0.0, |t| {
            f32::from(self.beams_received.saturating_sub(1)) * t.beam_period_s
        })
    }

    /// The motion the points were carried by, when [`Scan::deskew`] has run.
    #[inline]
    pub fn deskewed(&self) -> Option<SweepMotion> {
        self.deskewed
    }

    /// Moves every point (vehicle frame) to where the echo lies in the vehicle frame at
    /// the scan's last beam, the vehicle moving by `motion` over the sweep: beam `i` was
    /// taken `(n − 1 − i) · beam_period_s` before it. The beams' own angle and range are
    /// kept as measured. Needs the scan's [`ScanTiming`]; does nothing (returns `false`)
    /// without one, when the scan was already carried, or for a motion no vehicle makes
    /// ([`SweepMotion::is_plausible`]: non-finite, over 30 m/s or 0.2 rad over the sweep,
    /// or a sweep the timing makes negative or over 0.1 s).
    pub fn deskew(&mut self, motion: &SweepMotion) -> bool {
        let Some(timing) = self.timing else {
            return false;
        };
        if self.deskewed.is_some() || !motion.is_plausible(self.sweep_s()) {
            return false;
        }
        let last = self.beams_received.saturating_sub(1);
        for p in self.points.iter_mut() {
            let before_s = f32::from(last.saturating_sub(p.beam_index)) * timing.beam_period_s;
            p.vehicle = motion.carry(p.vehicle, before_s);
        }
        self.deskewed = Some(*motion);
        true
    }

    /// Appends an already converted point (for tests and tools that build scans from
    /// vehicle-frame points). Returns the point back when the scan is full; the drop is
    /// counted as over capacity.
    pub fn try_push(&mut self, point: ScanPoint) -> Result<(), ScanPoint> {
        self.beams_received = self.beams_received.saturating_add(1);
        let pushed = self.points.push(point);
        if pushed.is_err() {
            self.dropped.over_capacity = self.dropped.over_capacity.saturating_add(1);
        }
        pushed
    }

    /// The valid points, in beam order.
    #[inline]
    pub fn points(&self) -> &[ScanPoint] {
        &self.points
    }

    /// Number of valid points.
    #[inline]
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when no beam was valid.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Beams offered to the scan (valid and dropped), saturating at `u16::MAX`.
    #[inline]
    pub fn beams_received(&self) -> u16 {
        self.beams_received
    }

    /// How many beams were dropped, by reason.
    #[inline]
    pub fn dropped(&self) -> DroppedBeams {
        self.dropped
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn lms511_geometry_spans_190_degrees_in_1141_beams() {
        let g = ScanGeometry::lms511();
        assert!(close(g.start_angle_rad, -5.0_f32.to_radians(), 1e-6));
        assert!(close(g.step_rad, 0.1667_f32.to_radians(), 1e-7));
        assert_eq!(g.beam_count_to(185.0_f32.to_radians()), LMS511_MAX_BEAMS);
        // 1667 is 0.1667°, not 1/6°: the last beam lands 0.04° past 185°.
        assert!(close(g.beam_angle_rad(1140), 185.0_f32.to_radians(), 1e-3));
        assert!(g.is_valid());
    }

    #[test]
    fn forward_mount_puts_beam_90_deg_ahead() {
        let setup = SensorSetup::lms511_forward(1.5, 0.0);
        // Beam at sensor 90° is index (95° / 0.1667°) ≈ 570.
        let mut ranges = [0.0_f32; 571];
        ranges[570] = 10.0;
        let scan = Scan::from_ranges_m(&setup, &ranges);
        assert_eq!(scan.len(), 1);
        let p = scan.points()[0];
        assert!(close(p.vehicle.x_m, 11.5, 1e-3), "{p:?}");
        assert!(close(p.vehicle.y_m, 0.0, 5e-3), "{p:?}");
        assert_eq!(p.beam_index, 570);
        assert_eq!(scan.dropped().no_echo, 570);
        // Beam 0 (sensor −5°) points to the vehicle's right and a little back.
        let s = Scan::from_ranges_m(&setup, &[2.0]);
        let q = s.points()[0].vehicle;
        assert!(q.y_m < -1.9 && q.x_m < 1.5, "{q:?}");
    }

    #[test]
    fn raw_values_use_scale_factor_and_offset() {
        let setup = SensorSetup {
            geometry: ScanGeometry::from_telegram_units(0, 10_000, 0.5, 80.0),
            mounting: Pose2::IDENTITY,
        };
        let scan = Scan::from_raw_mm(&setup, &[0, 1000, 2000, 100], 2.0, 10.0);
        assert_eq!(scan.len(), 2);
        assert!(close(scan.points()[0].range_m, 2.01, 1e-6));
        assert!(close(scan.points()[1].range_m, 4.01, 1e-6));
        assert!(close(
            scan.points()[1].angle_rad,
            2.0_f32.to_radians(),
            1e-6
        ));
        let d = scan.dropped();
        assert_eq!((d.no_echo, d.below_min_range), (1, 1));
        assert_eq!(scan.beams_received(), 4);
        // A saturated reading (0xFFFF) is not a range, whatever the scale.
        let sat = Scan::from_raw_mm(&setup, &[u16::MAX, 1000], 1.0, 0.0);
        assert_eq!(sat.len(), 1);
        assert_eq!(sat.dropped().saturated, 1);
        assert_eq!(sat.points()[0].beam_index, 1);
    }

    #[test]
    fn bad_beams_are_counted_not_kept() {
        let setup = SensorSetup::default();
        let ranges = [f32::NAN, f32::INFINITY, 0.1, 100.0, 0.0, 5.0, -3.0];
        let scan = Scan::from_ranges_m(&setup, &ranges);
        assert_eq!(scan.len(), 1);
        let d = scan.dropped();
        assert_eq!(d.non_finite, 2);
        assert_eq!(d.below_min_range, 2);
        assert_eq!(d.above_max_range, 1);
        assert_eq!(d.no_echo, 1);
        assert_eq!(d.total() as usize + scan.len(), ranges.len());
    }

    #[test]
    fn prepared_directions_give_the_same_points() {
        let setup = SensorSetup::default();
        let ranges: [f32; LMS511_MAX_BEAMS] = core::array::from_fn(|i| 2.0 + (i % 7) as f32);
        let fresh = Scan::from_ranges_m(&setup, &ranges);
        let mut prepared = Scan::new();
        prepared.prepare_directions(&setup.geometry);
        prepared.load_ranges_m(&setup, &ranges);
        assert_eq!(fresh.points(), prepared.points());
        // Another layout recomputes the table instead of using the prepared one.
        let other = SensorSetup {
            geometry: ScanGeometry {
                step_rad: setup.geometry.step_rad * 1.5,
                ..setup.geometry
            },
            ..setup
        };
        prepared.load_ranges_m(&other, &ranges[..761]);
        assert_eq!(
            prepared.points(),
            Scan::from_ranges_m(&other, &ranges[..761]).points()
        );
    }

    #[test]
    fn beams_beyond_capacity_are_dropped_and_counted() {
        let setup = SensorSetup::default();
        let ranges = [5.0_f32; LMS511_MAX_BEAMS + 59];
        let mut scan = Scan::new();
        scan.load_ranges_m(&setup, &ranges);
        assert_eq!(scan.len(), LMS511_MAX_BEAMS);
        assert_eq!(scan.dropped().over_capacity, 59);
        // Reloading resets everything.
        scan.load_ranges_m(&setup, &[5.0; 3]);
        assert_eq!(scan.len(), 3);
        assert_eq!(scan.dropped(), DroppedBeams::default());
    }

    #[test]
    fn invalid_geometry_drops_everything_without_panicking() {
        let setup = SensorSetup {
            geometry: ScanGeometry {
                start_angle_rad: f32::NAN,
                step_rad: 0.01,
                min_range_m: 0.5,
                max_range_m: 80.0,
            },
            mounting: Pose2::IDENTITY,
        };
        assert!(!setup.geometry.is_valid());
        assert_eq!(setup.geometry.beam_count_to(1.0), 0);
        let scan = Scan::from_ranges_m(&setup, &[1.0, 2.0]);
        assert!(scan.is_empty());
        assert_eq!(scan.dropped().non_finite, 2);
    }

    proptest::proptest! {
        #[test]
        fn arbitrary_raw_values_never_panic_and_are_all_accounted_for(
            raw in proptest::collection::vec(proptest::prelude::any::<u16>(), 0..1300),
            scale in proptest::prelude::any::<f32>(),
            offset in proptest::prelude::any::<f32>(),
            start in proptest::prelude::any::<i32>(),
            step in proptest::prelude::any::<u32>(),
        ) {
            let setup = SensorSetup {
                geometry: ScanGeometry::from_telegram_units(start, step, 0.5, 80.0),
                mounting: Pose2::new(0.3, -0.1, 0.2),
            };
            let scan = Scan::from_raw_mm(&setup, &raw, scale, offset);
            proptest::prop_assert!(scan.len() <= LMS511_MAX_BEAMS);
            proptest::prop_assert_eq!(scan.dropped().total() as usize + scan.len(), raw.len());
            for p in scan.points() {
                proptest::prop_assert!(p.vehicle.is_finite() && (0.5..=80.0).contains(&p.range_m));
            }
        }
    }
}
