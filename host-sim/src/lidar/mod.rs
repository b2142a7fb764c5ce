//! SICK LMS511 model: the five scan frequency / angular resolution pairs, a 190° field of
//! view, Gaussian range noise plus an optional systematic error, no echo beyond 80 m, up to
//! five echoes per beam, and ranges delivered as the `LMDscandata` distance channels
//! (`DIST1`…`DIST5`) carry them: raw `u16` values with a scale factor (1 mm; 2 mm for a scan
//! with an echo beyond 65.534 m, as the LMS5xx's long-range output encodes them, rather than
//! clamping it).
//!
//! Echoes: a beam ends on the first surface it meets, a wall, a landmark or a person or
//! vehicle moving through the tunnel ([`crate::traffic`]); dust or spray in front of it
//! ([`dust`]) adds an earlier echo (or, where it is dense, is the only one). Echo `n` of a
//! beam goes into channel `DISTn` in range order, 0 where the beam has fewer echoes, as the
//! scanner sends them with all five echoes enabled.
//!
//! Frames: beam angles are in the sensor frame as the telegram reports them, −5° to +185°
//! counter-clockwise with 90° straight out of the scanner's front; the mounting pose is the
//! sensor frame in the vehicle frame, so a forward-looking scanner has yaw −90° (the
//! convention of loc-core's `SensorSetup`). Beams are cast at the exact resolution
//! (1/6°, …), the step [`scan_input::BeamLayout`] recovers from the telegram (whose
//! 1/10000° step field, 1667, is a rounding of it).

pub mod dust;

use loc_core::rng::Pcg32;
use scan_input::BeamLayout;

use crate::raycast::SegmentGrid;
use crate::traffic::Obstacle;
use dust::{DustField, DustSpec};

/// Most echoes per beam the LMS511 reports (channels `DIST1`…`DIST5`).
pub const MAX_ECHOES: usize = 5;

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
    /// Dust and spray the beams pass through (scenario `[lidar.dust]`; default none).
    #[serde(skip_serializing_if = "DustSpec::is_clear")]
    pub dust: DustSpec,
    /// Whether the mirror's sweep is modelled (scenario `lidar.sweep`; default off: every
    /// beam from the pose at the scan's time). On, beam `i` of `n` is taken
    /// `(n − 1 − i)` beam times before the scan's time, from where the vehicle was then:
    /// the LMS511's mirror turns once per scan period, so its 190° take 21 ms at 25 Hz
    /// (6 cm of travel at 3 m/s) and the scan's time is its last beam's.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub sweep: bool,
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
            dust: DustSpec::default(),
            sweep: false,
        }
    }
}

/// One scan as its telegram's distance channels carry it (simulated, or decoded from a
/// recording).
#[derive(Debug, Clone, PartialEq)]
pub struct LidarScan {
    /// Time of the scan, seconds since the start of the run (or on the recording's clock).
    pub t_s: f64,
    /// The distance channels `DIST1`…`DISTn` (1 ≤ n ≤ [`MAX_ECHOES`], the channels after the
    /// last one with an echo left out): `echoes[k][i]` is the raw value of echo `k + 1` of
    /// beam `i`, echoes in range order. Range in mm = `value · scale_factor +
    /// scale_offset_mm`; 0 means no (further) echo, `0xFFFF` a saturated reading.
    pub echoes: Vec<Vec<u16>>,
    /// The channels' scale factor (1.0; 2.0 for long ranges).
    pub scale_factor: f32,
    /// The channels' scale offset, mm.
    pub scale_offset_mm: f32,
    /// Beam layout, sensor frame, as the telegram gives it.
    pub layout: BeamLayout,
}

impl LidarScan {
    /// The first echo of each beam (`DIST1`), raw; empty for a scan without channels.
    pub fn dist1(&self) -> &[u16] {
        self.echoes.first().map_or(&[], Vec::as_slice)
    }

    /// Number of beams (values per channel).
    pub fn beams(&self) -> usize {
        self.dist1().len()
    }

    /// The value of each beam that `selection` chooses among its echoes (scan-input's
    /// choice: what the localiser gets).
    pub fn selected(
        &self,
        selection: scan_input::EchoSelection,
    ) -> scan_input::SelectedEchoes<std::iter::Copied<std::slice::Iter<'_, u16>>> {
        let mut channels = self.echoes.iter();
        let columns = std::array::from_fn(|_| channels.next().map(|c| c.iter().copied()));
        scan_input::SelectedEchoes::new(columns, self.beams(), selection)
    }

    /// Range of the first echo of beam `index`, metres; `None` for no echo, a saturated
    /// reading, or no beam.
    pub fn range_m(&self, index: usize) -> Option<f64> {
        self.echo_range_m(0, index)
    }

    /// Range of echo `echo + 1` (0-based `echo`) of beam `index`, metres; `None` for no
    /// such echo, a saturated reading, or no beam.
    pub fn echo_range_m(&self, echo: usize, index: usize) -> Option<f64> {
        let v = *self.echoes.get(echo)?.get(index)?;
        (v != 0 && v != u16::MAX).then(|| {
            (f64::from(v) * f64::from(self.scale_factor) + f64::from(self.scale_offset_mm)) / 1e3
        })
    }
}

/// What the first echoes of the scans so far came from.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EchoCounts {
    /// Beams cast.
    pub beams: u64,
    /// Beams whose first echo was a dust cloud.
    pub dust_first: u64,
    /// Of those, beams the cloud blocked (its echo the only one).
    pub dust_blocked: u64,
    /// Beams whose first surface was a person or vehicle (behind any dust).
    pub obstacle: u64,
}

/// The simulated scanner.
#[derive(Debug, Clone)]
pub struct Lms511 {
    spec: LidarSpec,
    rng: Pcg32,
    /// The dust's clouds and the noise of their echoes (a stream of its own, so a run
    /// without dust draws exactly what it drew before there was dust).
    dust: Option<(DustField, Pcg32)>,
    counts: EchoCounts,
}

/// One beam's echoes, metres, in range order (at most two: a cloud, then the surface).
type BeamEchoes = ([f64; 2], usize);

impl Lms511 {
    /// A scanner with its own noise stream.
    pub fn new(spec: LidarSpec, seed: u64) -> Self {
        let dust = (spec.dust.fraction > 0.0)
            .then(|| (DustField::new(spec.dust, seed), Pcg32::new(seed, 0xd0e5)));
        Self {
            spec,
            rng: Pcg32::new(seed, 0x11d4),
            dust,
            counts: EchoCounts::default(),
        }
    }

    /// Parameters.
    pub fn spec(&self) -> &LidarSpec {
        &self.spec
    }

    /// What the first echoes of the scans so far came from.
    pub fn counts(&self) -> EchoCounts {
        self.counts
    }

    /// Scans the true geometry from a vehicle at world pose `(x_m, y_m, theta_rad)`.
    pub fn scan(&mut self, grid: &SegmentGrid, vehicle: (f64, f64, f64), t_s: f64) -> LidarScan {
        self.scan_among(grid, &[], vehicle, t_s)
    }

    /// Scans the true geometry with `obstacles` (people, vehicles) in it from a vehicle at
    /// world pose `(x_m, y_m, theta_rad)`, through the dust of the spec (every beam from
    /// that pose: see [`Lms511::scan_swept`] for the sweep).
    pub fn scan_among(
        &mut self,
        grid: &SegmentGrid,
        obstacles: &[Obstacle],
        vehicle: (f64, f64, f64),
        t_s: f64,
    ) -> LidarScan {
        self.scan_swept(grid, obstacles, |_| vehicle, t_s)
    }

    /// As [`Lms511::scan_among`], with the vehicle's world pose `vehicle_before(lag_s)` the
    /// given seconds before the scan's time `t_s`: with [`LidarSpec::sweep`] each beam is
    /// taken from where the vehicle was when the mirror passed it; otherwise every beam from
    /// `vehicle_before(0.0)`.
    pub fn scan_swept(
        &mut self,
        grid: &SegmentGrid,
        obstacles: &[Obstacle],
        vehicle_before: impl Fn(f64) -> (f64, f64, f64),
        t_s: f64,
    ) -> LidarScan {
        let (mx, my, myaw) = (
            self.spec.mount_x_m,
            self.spec.mount_y_m,
            self.spec.mount_yaw_rad,
        );
        let sensor = move |(vx, vy, vth): (f64, f64, f64)| {
            let (s, c) = vth.sin_cos();
            ((vx + c * mx - s * my, vy + s * mx + c * my), vth + myaw)
        };
        let at_scan = sensor(vehicle_before(0.0));
        let layout = self.spec.rate.layout();
        // The mirror turns 360° per scan period: its telegrams' own beam period.
        let beam_time_s = layout.beam_period_s().unwrap_or(0.0);
        let beams = usize::from(layout.beams);
        if let Some((field, _)) = &mut self.dust {
            field.advance(t_s, beams, self.spec.rate.step_deg());
        }
        let sweep = self.spec.sweep;
        let echoes_m: Vec<BeamEchoes> = (0..beams)
            .map(|i| {
                let (origin, heading) = if sweep {
                    sensor(vehicle_before((beams - 1 - i) as f64 * beam_time_s))
                } else {
                    at_scan
                };
                let angle = heading + layout.beam_angle_rad(i);
                self.beam(grid, obstacles, origin, angle, i)
            })
            .collect();
        let all_ranges = echoes_m.iter().flat_map(|(r, n)| r.iter().take(*n));
        let scale_factor = scale_factor_for(all_ranges.copied(), self.spec.max_range_m);
        let channels = echoes_m.iter().map(|(_, n)| *n).max().unwrap_or(0).max(1);
        let echoes = (0..channels)
            .map(|k| {
                echoes_m
                    .iter()
                    .map(|(r, n)| {
                        let range = if k < *n { r[k] } else { 0.0 };
                        raw_value(range, self.spec.max_range_m, scale_factor)
                    })
                    .collect()
            })
            .collect();
        LidarScan {
            t_s,
            echoes,
            scale_factor: scale_factor as f32,
            scale_offset_mm: 0.0,
            layout,
        }
    }

    /// The echoes of beam `index` at world angle `angle_rad` from `origin`, metres.
    fn beam(
        &mut self,
        grid: &SegmentGrid,
        obstacles: &[Obstacle],
        origin: (f64, f64),
        angle_rad: f64,
        index: usize,
    ) -> BeamEchoes {
        let max = self.spec.max_range_m;
        let wall = grid.cast(origin, angle_rad, max).map(|h| h.range_m);
        let (sin, cos) = angle_rad.sin_cos();
        let obstacle = Obstacle::nearest_hit(obstacles, origin, (cos, sin), max)
            .filter(|&o| wall.is_none_or(|w| o < w));
        let surface = obstacle.or(wall);
        // The surface's echo draws its noise as a clear-air scan always did.
        let measured = surface.map_or(0.0, |r| {
            r + self.spec.systematic_error_m
                + self.spec.range_noise_m * f64::from(self.rng.gaussian())
        });
        self.counts.beams += 1;
        self.counts.obstacle += u64::from(obstacle.is_some());
        let cloud = self.dust.as_mut().and_then(|(field, noise)| {
            let cloud = field.cloud(index)?;
            let r = cloud.range_m(field.spec(), surface, max)?;
            let e = self.spec.systematic_error_m
                + self.spec.range_noise_m * f64::from(noise.gaussian());
            Some((r + e, cloud.blocked))
        });
        match cloud {
            Some((r, blocked)) => {
                self.counts.dust_first += 1;
                self.counts.dust_blocked += u64::from(blocked);
                if blocked || surface.is_none() {
                    ([r, 0.0], 1)
                } else {
                    ([r, measured], 2)
                }
            }
            None => ([measured, 0.0], usize::from(surface.is_some())),
        }
    }
}

/// Largest raw value that is a range (`0xFFFF` reads as saturated).
const MAX_RANGE_VALUE: f64 = (u16::MAX - 1) as f64;

/// The scale factor of a scan: 1 (1 mm per unit) unless an echo lies beyond what that
/// encodes (65.534 m), then 2.
fn scale_factor_for(ranges_m: impl IntoIterator<Item = f64>, max_range_m: f64) -> f64 {
    let far = ranges_m
        .into_iter()
        .any(|r| r > 0.0 && r <= max_range_m && (r * 1000.0).round() > MAX_RANGE_VALUE);
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
    fn the_sweep_takes_each_beam_from_where_the_vehicle_was() {
        // Driving at 3 m/s towards an end wall 10 m ahead: the beam straight ahead (570 of
        // 1141) is taken 570 beam times (10.6 ms at 25 Hz) before the scan's time, 31.7 mm
        // farther back; without the sweep every beam is from the pose at the scan's time.
        let grid = corridor(10.0, true);
        let spec = LidarSpec {
            range_noise_m: 0.0,
            sweep: true,
            ..LidarSpec::default()
        };
        let beam_time_s = spec.rate.layout().beam_period_s().unwrap();
        assert!((beam_time_s * 1140.0 - 0.02111).abs() < 1e-5);
        let driving = |lag_s: f64| (-3.0 * lag_s, 0.0, 0.0);
        let swept = Lms511::new(spec, 1).scan_swept(&grid, &[], driving, 0.0);
        let still = LidarSpec {
            sweep: false,
            ..spec
        };
        let at_once = Lms511::new(still, 1).scan_swept(&grid, &[], driving, 0.0);
        let ahead_mm = |s: &LidarScan| f64::from(s.dist1()[570]) * f64::from(s.scale_factor);
        assert!((ahead_mm(&at_once) - 9000.0).abs() <= 1.0);
        let lag_mm = 3.0 * 570.0 * beam_time_s * 1000.0;
        assert!(
            (ahead_mm(&swept) - 9000.0 - lag_mm).abs() <= 1.0,
            "{} against {}",
            ahead_mm(&swept),
            9000.0 + lag_mm
        );
        // The last beam is the scan's time: the same either way.
        assert_eq!(swept.dist1()[1140], at_once.dist1()[1140]);
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
        assert_eq!(scan.dist1().len(), 1141);
        // Beam straight ahead (index 570) leaves the corridor: no echo.
        assert_eq!(scan.dist1()[570], 0);
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
        assert_eq!(exact.dist1()[1110], 1500);
        // A systematic error shifts every echo by the same amount.
        let biased = LidarSpec {
            range_noise_m: 0.0,
            systematic_error_m: 0.025,
            ..LidarSpec::default()
        };
        let b = Lms511::new(biased, 1).scan(&grid, (0.0, 0.5, 0.0), 0.0);
        assert_eq!(b.dist1()[1110], 1525);
        assert_eq!(b.dist1()[570], 0, "no echo stays no echo");
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
        assert!(scan.dist1().iter().all(|&v| v != u16::MAX));
        // Near beams keep their range within the 2 mm step.
        let side = scan.range_m(1110).unwrap();
        assert!((side - 2.0).abs() <= 0.001, "{side}");
        // Without far echoes the scale stays 1 mm.
        assert_eq!(scale_factor_for([2.0, 65.0, 0.0], 80.0), 1.0);
        assert_eq!(scale_factor_for([2.0, 65.6], 80.0), 2.0);
    }

    #[test]
    fn dust_adds_an_early_echo_and_leaves_the_wall_on_the_next() {
        let grid = corridor(50.0, true);
        let dusty = LidarSpec {
            dust: DustSpec {
                fraction: 0.2,
                ..DustSpec::default()
            },
            ..LidarSpec::default()
        };
        let mut clear = Lms511::new(LidarSpec::default(), 4);
        let mut dust = Lms511::new(dusty, 4);
        let (mut beams, mut two, mut one) = (0usize, 0usize, 0usize);
        for k in 0..50 {
            let t = f64::from(k) * 0.04;
            let a = clear.scan(&grid, (0.0, 0.0, 0.0), t);
            let b = dust.scan(&grid, (0.0, 0.0, 0.0), t);
            assert_eq!(b.echoes.len(), 2, "a cloud, then the wall");
            for i in 0..a.beams() {
                beams += 1;
                let wall = a.dist1()[i];
                match (b.echoes[0][i], b.echoes[1][i]) {
                    // No cloud: the same echo as in clear air (the same noise draws).
                    (first, 0) if first == wall => {}
                    // Blocked: the cloud alone, before the wall.
                    (first, 0) => {
                        one += 1;
                        assert!(first < wall, "beam {i}: {first} behind {wall}");
                    }
                    (first, second) => {
                        two += 1;
                        assert_eq!(second, wall, "beam {i}: the wall on the second echo");
                        assert!(
                            first >= 400 && f64::from(first) <= f64::from(wall) - 250.0,
                            "beam {i}: cloud at {first} mm, wall at {wall} mm"
                        );
                    }
                }
            }
        }
        let share = (one + two) as f64 / beams as f64;
        assert!(
            (share - 0.2).abs() < 0.05,
            "dust on {share} of the first echoes"
        );
        assert!(one > 0 && one < two / 5, "blocked {one} of {}", one + two);
        let c = dust.counts();
        assert_eq!(
            (c.beams as usize, (c.dust_first - c.dust_blocked) as usize),
            (beams, two)
        );
        assert_eq!(clear.counts().dust_first, 0);
    }

    #[test]
    fn people_and_vehicles_hide_the_wall_behind_them() {
        let grid = corridor(50.0, true);
        let spec = LidarSpec {
            range_noise_m: 0.0,
            mount_x_m: 0.0,
            ..LidarSpec::default()
        };
        let person = Obstacle::Circle {
            centre: (10.0, 0.0),
            radius_m: 0.25,
        };
        let mut lidar = Lms511::new(spec, 1);
        let scan = lidar.scan_among(&grid, &[person], (0.0, 0.0, 0.0), 0.0);
        // Straight ahead (beam 570): the person at 9.75 m, not the end wall at 50 m; one echo.
        assert_eq!(scan.dist1()[570], 9750);
        assert_eq!(scan.echoes.len(), 1);
        // The beams beside it still see the side walls.
        assert_eq!(scan.dist1()[1110], 2000);
        let hidden = scan
            .dist1()
            .iter()
            .filter(|&&v| v == 9750 || (9750..9800).contains(&v));
        assert!(hidden.count() >= 2, "the person covers a few beams");
        assert!(lidar.counts().obstacle >= 2);
        // Behind a wall it is not seen.
        let behind = Obstacle::Circle {
            centre: (0.0, 3.0),
            radius_m: 0.25,
        };
        let again = Lms511::new(spec, 1).scan_among(&grid, &[behind], (0.0, 0.0, 0.0), 0.0);
        let plain = Lms511::new(spec, 1).scan(&grid, (0.0, 0.0, 0.0), 0.0);
        assert_eq!(again, plain);
    }
}
