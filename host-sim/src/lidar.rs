//! SICK LMS511 model: the five scan frequency / angular resolution pairs, a 190° field of
//! view, Gaussian range noise plus an optional systematic error, no echo beyond 80 m, and
//! ranges delivered as the `LMDscandata` DIST1 channel carries them: raw `u16` values with a
//! scale factor (1 mm; 2 mm for a scan with an echo beyond 65.534 m, as the LMS5xx's
//! long-range output encodes them, rather than clamping it).
//!
//! Frames: beam angles are in the sensor frame as the telegram reports them, −5° to +185°
//! counter-clockwise with 90° straight out of the scanner's front; the mounting pose is the
//! sensor frame in the vehicle frame, so a forward-looking scanner has yaw −90° (the
//! convention of loc-core's `SensorSetup`). Beams are cast at the exact resolution
//! (1/6°, …), the step [`scan_input::BeamLayout`] recovers from the telegram (whose
//! 1/10000° step field, 1667, is a rounding of it).

use loc_core::rng::Pcg32;
use scan_input::BeamLayout;

use crate::raycast::SegmentGrid;

/// The LMS511's scan frequency / angular resolution pairs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum ScanRate {
    /// 25 Hz at 0.1667° (1141 beams over 190°).
    #[default]
    #[serde(rename = "25hz")]
    Hz25,
    /// 35 Hz at 0.25° (761 beams).
    #[serde(rename = "35hz")]
    Hz35,
    /// 50 Hz at 0.3333° (571 beams).
    #[serde(rename = "50hz")]
    Hz50,
    /// 75 Hz at 0.5° (381 beams).
    #[serde(rename = "75hz")]
    Hz75,
    /// 100 Hz at 0.6667° (286 beams).
    #[serde(rename = "100hz")]
    Hz100,
}

impl ScanRate {
    /// Scan frequency, hertz.
    pub fn frequency_hz(self) -> f64 {
        match self {
            ScanRate::Hz25 => 25.0,
            ScanRate::Hz35 => 35.0,
            ScanRate::Hz50 => 50.0,
            ScanRate::Hz75 => 75.0,
            ScanRate::Hz100 => 100.0,
        }
    }

    /// Angular step between beams in 1/10000 degree, as the telegram gives it.
    pub fn step_1e4_deg(self) -> u32 {
        match self {
            ScanRate::Hz25 => 1667,
            ScanRate::Hz35 => 2500,
            ScanRate::Hz50 => 3333,
            ScanRate::Hz75 => 5000,
            ScanRate::Hz100 => 6667,
        }
    }

    /// Exact angular step between beams, degrees (1/6°, 1/4°, 1/3°, 1/2°, 2/3°; the
    /// telegram rounds it to 1/10000 degree).
    pub fn step_deg(self) -> f64 {
        match self {
            ScanRate::Hz25 => 1.0 / 6.0,
            ScanRate::Hz35 => 0.25,
            ScanRate::Hz50 => 1.0 / 3.0,
            ScanRate::Hz75 => 0.5,
            ScanRate::Hz100 => 2.0 / 3.0,
        }
    }

    /// Angular step between beams, radians.
    pub fn step_rad(self) -> f64 {
        self.step_deg().to_radians()
    }

    /// Number of beams over the 190° field of view (1141 at 25 Hz).
    pub fn beam_count(self) -> usize {
        (FIELD_OF_VIEW_DEG / self.step_deg()).round() as usize + 1
    }

    /// Shot (measurement) frequency, 100 Hz units: `f · 360° / step` (540 = 54 kHz at
    /// 25 Hz / 1/6°; 504 at 35 Hz / 0.25°).
    pub fn measurement_frequency_100hz(self) -> u32 {
        (self.frequency_hz() * 360.0 / self.step_deg() / 100.0).round() as u32
    }

    /// The beam layout the LMS511 reports in its telegrams at this rate: −5° … +185°, the
    /// rounded step, and the frequencies that give the exact one.
    pub fn layout(self) -> BeamLayout {
        BeamLayout {
            start_angle_1e4_deg: FIRST_BEAM_1E4_DEG,
            step_1e4_deg: self.step_1e4_deg() as u16,
            beams: self.beam_count() as u16,
            scan_frequency_1e2_hz: (self.frequency_hz() * 100.0).round() as u32,
            measurement_frequency_100hz: self.measurement_frequency_100hz(),
        }
    }
}

/// Field of view, degrees.
pub const FIELD_OF_VIEW_DEG: f64 = 190.0;

/// Angle of the first beam in the sensor frame, 1/10000 degree (−5°), as in the telegram.
pub const FIRST_BEAM_1E4_DEG: i32 = -50_000;

/// Lidar parameters.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LidarSpec {
    /// Frequency / resolution pair.
    pub rate: ScanRate,
    /// Range noise standard deviation, metres (the LMS511 datasheet: 6–14 mm).
    pub range_noise_m: f64,
    /// Systematic range error, metres, added to every beam of the run (datasheet: up to
    /// ±25 mm).
    pub systematic_error_m: f64,
    /// Maximum range, metres; beams that meet nothing closer read 0 (no echo).
    pub max_range_m: f64,
    /// Mounting pose in the vehicle frame: x forward, metres.
    pub mount_x_m: f64,
    /// Mounting pose in the vehicle frame: y left, metres.
    pub mount_y_m: f64,
    /// Mounting yaw of the sensor frame in the vehicle frame, radians (−π/2: the 90° beam
    /// looks straight ahead).
    pub mount_yaw_rad: f64,
}

impl Default for LidarSpec {
    fn default() -> Self {
        Self {
            rate: ScanRate::Hz25,
            range_noise_m: 0.010,
            systematic_error_m: 0.0,
            max_range_m: 80.0,
            mount_x_m: 1.0,
            mount_y_m: 0.0,
            mount_yaw_rad: -std::f64::consts::FRAC_PI_2,
        }
    }
}

/// One scan as its telegram's `DIST1` channel carries it (simulated, or decoded from a
/// recording).
#[derive(Debug, Clone, PartialEq)]
pub struct LidarScan {
    /// Time of the scan, seconds since the start of the run (or on the recording's clock).
    pub t_s: f64,
    /// Raw value of each beam: range in mm = `value · scale_factor + scale_offset_mm`;
    /// 0 means no echo, `0xFFFF` a saturated reading.
    pub dist1: Vec<u16>,
    /// The channel's scale factor (1.0; 2.0 for long ranges).
    pub scale_factor: f32,
    /// The channel's scale offset, mm.
    pub scale_offset_mm: f32,
    /// Beam layout, sensor frame, as the telegram gives it.
    pub layout: BeamLayout,
}

impl LidarScan {
    /// Range of beam `index`, metres; `None` for no echo, a saturated reading, or no beam.
    pub fn range_m(&self, index: usize) -> Option<f64> {
        let v = *self.dist1.get(index)?;
        (v != 0 && v != u16::MAX).then(|| {
            (f64::from(v) * f64::from(self.scale_factor) + f64::from(self.scale_offset_mm)) / 1e3
        })
    }
}

/// The simulated scanner.
#[derive(Debug, Clone)]
pub struct Lms511 {
    spec: LidarSpec,
    rng: Pcg32,
}

impl Lms511 {
    /// A scanner with its own noise stream.
    pub fn new(spec: LidarSpec, seed: u64) -> Self {
        Self {
            spec,
            rng: Pcg32::new(seed, 0x11d4),
        }
    }

    /// Parameters.
    pub fn spec(&self) -> &LidarSpec {
        &self.spec
    }

    /// Scans the true geometry from a vehicle at world pose `(x_m, y_m, theta_rad)`.
    pub fn scan(&mut self, grid: &SegmentGrid, vehicle: (f64, f64, f64), t_s: f64) -> LidarScan {
        let (vx, vy, vth) = vehicle;
        let (s, c) = vth.sin_cos();
        let origin = (
            vx + c * self.spec.mount_x_m - s * self.spec.mount_y_m,
            vy + s * self.spec.mount_x_m + c * self.spec.mount_y_m,
        );
        let heading = vth + self.spec.mount_yaw_rad;
        let layout = self.spec.rate.layout();
        let ranges_m: Vec<f64> = (0..usize::from(layout.beams))
            .map(|i| {
                let beam = layout.beam_angle_rad(i);
                grid.cast(origin, heading + beam, self.spec.max_range_m)
                    .map_or(0.0, |h| {
                        h.range_m
                            + self.spec.systematic_error_m
                            + self.spec.range_noise_m * f64::from(self.rng.gaussian())
                    })
            })
            .collect();
        let scale_factor = scale_factor_for(&ranges_m, self.spec.max_range_m);
        LidarScan {
            t_s,
            dist1: ranges_m
                .iter()
                .map(|&r| raw_value(r, self.spec.max_range_m, scale_factor))
                .collect(),
            scale_factor: scale_factor as f32,
            scale_offset_mm: 0.0,
            layout,
        }
    }
}

/// Largest raw value that is a range (`0xFFFF` reads as saturated).
const MAX_RANGE_VALUE: f64 = (u16::MAX - 1) as f64;

/// The scale factor of a scan: 1 (1 mm per unit) unless an echo lies beyond what that
/// encodes (65.534 m), then 2.
fn scale_factor_for(ranges_m: &[f64], max_range_m: f64) -> f64 {
    let far = ranges_m
        .iter()
        .any(|&r| r > 0.0 && r <= max_range_m && (r * 1000.0).round() > MAX_RANGE_VALUE);
    if far {
        2.0
    } else {
        1.0
    }
}

/// Metres to the telegram's raw value at `scale_factor` mm per unit: 0 for no echo, for
/// anything at or below zero, and for anything beyond `max_range_m`.
fn raw_value(range_m: f64, max_range_m: f64, scale_factor: f64) -> u16 {
    if !(range_m.is_finite() && range_m > 0.0 && range_m <= max_range_m) {
        return 0;
    }
    (range_m * 1000.0 / scale_factor)
        .round()
        .clamp(1.0, MAX_RANGE_VALUE) as u16
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raycast::{Surface, WorldSegment};

    #[test]
    fn beam_counts_match_the_datasheet() {
        assert_eq!(ScanRate::Hz25.beam_count(), 1141);
        assert_eq!(ScanRate::Hz35.beam_count(), 761);
        assert_eq!(ScanRate::Hz50.beam_count(), 571);
        assert_eq!(ScanRate::Hz75.beam_count(), 381);
        assert_eq!(ScanRate::Hz100.beam_count(), 286);
    }

    /// Walls at y = ±2 m from x = −1 m to `length_m`, closed at the far end if `closed`.
    fn corridor(length_m: f64, closed: bool) -> SegmentGrid {
        let wall = |a, b, surface| WorldSegment { a, b, surface };
        let mut walls = vec![
            wall((-1.0, 2.0), (length_m, 2.0), Surface::LeftWall),
            wall((-1.0, -2.0), (length_m, -2.0), Surface::RightWall),
        ];
        if closed {
            walls.push(wall((length_m, -2.0), (length_m, 2.0), Surface::LeftWall));
        }
        SegmentGrid::new(walls, 1.0)
    }

    #[test]
    fn corridor_scan_noise_mount_and_no_echo() {
        // Two walls at y = ±2 m from x = -1 to 50 m: beams ahead past 50 m see nothing.
        let grid = corridor(50.0, false);
        let spec = LidarSpec {
            range_noise_m: 0.01,
            ..LidarSpec::default()
        };
        let mut lidar = Lms511::new(spec, 1);
        let scan = lidar.scan(&grid, (0.0, 0.0, 0.0), 0.0);
        assert_eq!(scan.dist1.len(), 1141);
        // Beam straight ahead (index 570) leaves the corridor: no echo.
        assert_eq!(scan.dist1[570], 0);
        // Beam at +90° (index 570 + 540) sees the left wall at 2 m ± noise.
        let left = scan.range_m(1110).unwrap();
        assert!((left - 2.0).abs() < 0.06, "{left}");
        // Noise statistics over the wall beams near ±90°.
        let errs: Vec<f64> = (0..1141)
            .filter_map(|i| {
                // Vehicle-frame angle: sensor angle plus the −90° mounting yaw.
                let a = scan.layout.beam_angle_rad(i) - std::f64::consts::FRAC_PI_2;
                let truth = 2.0 / a.sin().abs();
                let r = scan.range_m(i)?;
                (a.sin().abs() > 0.5).then_some(r - truth)
            })
            .collect();
        let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt();
        assert!((rms - 0.01).abs() < 0.002, "noise rms {rms}");
        // The mount offset (1 m forward) moves the wall hits.
        let spec0 = LidarSpec {
            range_noise_m: 0.0,
            ..LidarSpec::default()
        };
        let exact = Lms511::new(spec0, 1).scan(&grid, (0.0, 0.5, 0.0), 0.0);
        assert_eq!(exact.dist1[1110], 1500);
        // A systematic error shifts every echo by the same amount.
        let biased = LidarSpec {
            range_noise_m: 0.0,
            systematic_error_m: 0.025,
            ..LidarSpec::default()
        };
        let b = Lms511::new(biased, 1).scan(&grid, (0.0, 0.5, 0.0), 0.0);
        assert_eq!(b.dist1[1110], 1525);
        assert_eq!(b.dist1[570], 0, "no echo stays no echo");
        assert_eq!(raw_value(81.0, 80.0, 1.0), 0);
        assert_eq!(raw_value(f64::NAN, 80.0, 1.0), 0);
    }

    #[test]
    fn echoes_beyond_65_m_are_encoded_at_scale_two_not_clamped() {
        // A corridor closed 75 m ahead: the beams along it see its end wall at ~75 m.
        let grid = corridor(75.0, true);
        let spec = LidarSpec {
            range_noise_m: 0.0,
            mount_x_m: 0.0,
            ..LidarSpec::default()
        };
        let scan = Lms511::new(spec, 1).scan(&grid, (0.0, 0.0, 0.0), 0.0);
        assert_eq!(scan.scale_factor, 2.0);
        let ahead = scan.range_m(570).unwrap();
        assert!((ahead - 75.0).abs() < 0.002, "{ahead}");
        assert!(scan.dist1.iter().all(|&v| v != u16::MAX));
        // Near beams keep their range within the 2 mm step.
        let side = scan.range_m(1110).unwrap();
        assert!((side - 2.0).abs() <= 0.001, "{side}");
        // Without far echoes the scale stays 1 mm.
        assert_eq!(scale_factor_for(&[2.0, 65.0, 0.0], 80.0), 1.0);
        assert_eq!(scale_factor_for(&[2.0, 65.6], 80.0), 2.0);
    }
}
