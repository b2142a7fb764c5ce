//! SICK LMS511 model: the five scan frequency / angular resolution pairs, a 190° field of
//! view, Gaussian range noise plus an optional systematic error, no echo beyond 80 m, and
//! ranges delivered as `u16` millimetres per beam, as in the `LMDscandata` DIST1 channel.
//!
//! Frames: beam angles are in the sensor frame as the telegram reports them, −5° to +185°
//! counter-clockwise with 90° straight out of the scanner's front; the mounting pose is the
//! sensor frame in the vehicle frame, so a forward-looking scanner has yaw −90° (the
//! convention of loc-core's `SensorSetup`). Beams are cast at the exact resolution
//! (1/6°, …); the telegram's 1/10000° step (1667) is a rounding of it.

use loc_core::rng::Pcg32;

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
}

/// Field of view, degrees.
pub const FIELD_OF_VIEW_DEG: f64 = 190.0;

/// Angle of the first beam in the sensor frame, 1/10000 degree (−5°), as in the telegram.
pub const FIRST_BEAM_1E4_DEG: i32 = -50_000;

/// Angle of the first beam in the sensor frame, radians (−5°).
pub fn first_beam_angle_rad() -> f64 {
    (f64::from(FIRST_BEAM_1E4_DEG) / 1e4).to_radians()
}

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

/// One simulated scan.
#[derive(Debug, Clone, PartialEq)]
pub struct LidarScan {
    /// Time of the scan, seconds since the start of the run.
    pub t_s: f64,
    /// Range of each beam, millimetres; 0 means no echo.
    pub ranges_mm: Vec<u16>,
    /// Angle of the first beam in the sensor frame, radians.
    pub start_angle_rad: f64,
    /// Angle between beams, radians.
    pub step_rad: f64,
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
        let start = first_beam_angle_rad();
        let step = self.spec.rate.step_rad();
        let n = self.spec.rate.beam_count();
        let mut ranges_mm = Vec::with_capacity(n);
        for i in 0..n {
            let beam = start + i as f64 * step;
            let r = grid
                .cast(origin, heading + beam, self.spec.max_range_m)
                .map_or(0.0, |h| {
                    h.range_m
                        + self.spec.systematic_error_m
                        + self.spec.range_noise_m * f64::from(self.rng.gaussian())
                });
            ranges_mm.push(range_to_mm(r, self.spec.max_range_m));
        }
        LidarScan {
            t_s,
            ranges_mm,
            start_angle_rad: start,
            step_rad: step,
        }
    }
}

/// Metres to the telegram's millimetres: 0 for no echo, for anything at or below zero, and
/// for anything beyond `max_range_m`.
fn range_to_mm(range_m: f64, max_range_m: f64) -> u16 {
    if !(range_m.is_finite() && range_m > 0.0 && range_m <= max_range_m) {
        return 0;
    }
    (range_m * 1000.0).round().clamp(1.0, f64::from(u16::MAX)) as u16
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

    #[test]
    fn corridor_scan_noise_mount_and_no_echo() {
        // Two walls at y = ±2 m from x = -1 to 50 m: beams ahead past 50 m see nothing.
        let walls = vec![
            WorldSegment {
                a: (-1.0, 2.0),
                b: (50.0, 2.0),
                surface: Surface::LeftWall,
            },
            WorldSegment {
                a: (-1.0, -2.0),
                b: (50.0, -2.0),
                surface: Surface::RightWall,
            },
        ];
        let grid = SegmentGrid::new(walls, 1.0);
        let spec = LidarSpec {
            range_noise_m: 0.01,
            ..LidarSpec::default()
        };
        let mut lidar = Lms511::new(spec, 1);
        let scan = lidar.scan(&grid, (0.0, 0.0, 0.0), 0.0);
        assert_eq!(scan.ranges_mm.len(), 1141);
        // Beam straight ahead (index 570) leaves the corridor: no echo.
        assert_eq!(scan.ranges_mm[570], 0);
        // Beam at +90° (index 570 + 540) sees the left wall at 2 m ± noise.
        let left = f64::from(scan.ranges_mm[1110]) / 1000.0;
        assert!((left - 2.0).abs() < 0.06, "{left}");
        // Noise statistics over the wall beams near ±90°.
        let errs: Vec<f64> = (0..1141)
            .filter_map(|i| {
                // Vehicle-frame angle: sensor angle plus the −90° mounting yaw.
                let a =
                    scan.start_angle_rad + i as f64 * scan.step_rad - std::f64::consts::FRAC_PI_2;
                let truth = 2.0 / a.sin().abs();
                let r = f64::from(scan.ranges_mm[i]) / 1000.0;
                (a.sin().abs() > 0.5 && r > 0.0).then_some(r - truth)
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
        assert_eq!(exact.ranges_mm[1110], 1500);
        // A systematic error shifts every echo by the same amount.
        let biased = LidarSpec {
            range_noise_m: 0.0,
            systematic_error_m: 0.025,
            ..LidarSpec::default()
        };
        let b = Lms511::new(biased, 1).scan(&grid, (0.0, 0.5, 0.0), 0.0);
        assert_eq!(b.ranges_mm[1110], 1525);
        assert_eq!(b.ranges_mm[570], 0, "no echo stays no echo");
        assert_eq!(range_to_mm(81.0, 80.0), 0);
        assert_eq!(range_to_mm(f64::NAN, 80.0), 0);
    }
}
