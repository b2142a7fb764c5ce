//! The along-tunnel position from where a wall ends: a portal, the face, the edge of the
//! surveyed stretch. Walls alone fix the lateral position and the heading; where a stored
//! wall's polyline stops ([`MapQuery::wall_end`]) and the scan sees its wall stop, the
//! difference is a measurement of the position along the wall.
//!
//! Near each stored end within range, the beams whose rays meet the wall's line (extended
//! past the end) within a window around the end are classified, in order along the wall,
//! as *wall* (an echo within [`WallEndConfig::tolerance_m`] of the line), *beyond* (no echo,
//! or an echo behind the line: the beam went past the end) or *near* (an echo in front of
//! the line: something stands there). An end is seen when a run of wall beams is followed
//! by nothing but beyond beams (at least [`WallEndConfig::min_run_beams`] on each side of
//! the change): the wall stops between the last wall echo and the next beam's footprint, a
//! gap further. The middle is the measurement; its variance that of a uniform position
//! over the gap (`gap²/12`; the gap grows with range and with grazing incidence) plus two
//! errors every scan shares, which no number of fixes averages away: the stored end's own
//! ([`WallEndConfig::end_sd_m`]) and the wall's roughness over its last gap, which a beam
//! at grazing angle `g` turns into `1/tan g` times as much along it
//! ([`WallEndConfig::wall_roughness_m`]). Where the position along the wall is already
//! known better than those shared errors (landmarks in view) an end is not taken at all.
//! A change something stands in front of, a wall that comes back (a crosscut, dropouts),
//! a wall that runs on through the window, or beams past the scan's first or last echo
//! (the scanner may not cover them) give no measurement, and neither does an end with a
//! stored landmark near it (the landmark's profile ends there, not the wall).
//!
//! The result ([`WallEndFix`]) measures the position along the wall's outward direction;
//! the filter takes it with [`crate::filter::Ekf::update_position_along`] (position and
//! odometry scale, not the heading), at most once per quarter gap of travel for each end
//! ([`WallEndMemory`]: a standing vehicle sees the same end between the same beams).

use crate::geometry::{Point2, Pose2};
use crate::map::{MapQuery, WallEnd, WallEndAt, WallSide};
use crate::math;
use crate::scan::{ScanPoint, SensorSetup};

use super::PositionPrior;

/// Most wall ends one scan can measure (each wall's start and finish).
pub const MAX_WALL_END_FIXES: usize = 4;

/// Tuning of the wall-end observation. Distances in metres, angles in radians.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WallEndConfig {
    /// Whether wall ends are looked for at all.
    pub enabled: bool,
    /// Ends farther than this from the scanner are not looked for, metres (the gap between
    /// footprints grows with the square of the range at grazing incidence).
    pub max_range_m: f32,
    /// A beam's echo within this normal distance of the wall's line is the wall, metres
    /// (roughness, range noise at grazing incidence and the lateral uncertainty).
    pub tolerance_m: f32,
    /// Fewest wall beams before the change and beyond beams after it.
    pub min_run_beams: u8,
    /// The window searched along the wall: this many of the predicted position's σ along
    /// the wall either side of the stored end, plus [`WallEndConfig::window_margin_m`].
    pub window_sigmas: f32,
    /// Added to the window either side, metres.
    pub window_margin_m: f32,
    /// The window never reaches farther than this either side, metres (an end lost by more
    /// than this is left to the landmarks or a relocalisation).
    pub max_window_m: f32,
    /// Beams meeting the wall at a smaller angle than this are not used, radians.
    pub min_grazing_rad: f32,
    /// How far the real end may lie from the stored one (1σ), metres.
    pub end_sd_m: f32,
    /// How far the real wall strays across from a straight line over the last gap before
    /// its end (1σ), metres: at grazing incidence `g` the last beams meet it `1/tan g` times
    /// that farther or nearer along it.
    pub wall_roughness_m: f32,
    /// Gaps between the two footprints wider than this give no measurement, metres.
    pub max_gap_m: f32,
    /// An end is taken again once the vehicle has moved by this many of its gaps since it
    /// was last taken ([`WallEndMemory`]). On bare `paper-10m` (1 m/s, 25 Hz) a quarter
    /// lets every scan's fix in while the vehicle moves: 32 / 25 / 25 mm along RMS, within
    /// 1.7 σ; one per whole gap 60 / 43 / 38 mm.
    pub refix_gaps: f32,
    /// Ends with a stored landmark within this distance are not looked for, metres: the
    /// landmark's profile, not the wall's, then ends there.
    pub landmark_clearance_m: f32,
}

impl WallEndConfig {
    /// The defaults (what [`Default`] gives), usable in `const` and `static` items.
    pub const DEFAULT: Self = Self {
        enabled: true,
        max_range_m: 40.0,
        tolerance_m: 0.1,
        min_run_beams: 3,
        window_sigmas: 3.0,
        window_margin_m: 0.5,
        max_window_m: 5.0,
        min_grazing_rad: 0.035,
        end_sd_m: 0.02,
        wall_roughness_m: 0.005,
        max_gap_m: 1.5,
        landmark_clearance_m: 1.5,
        refix_gaps: 0.25,
    };

    /// Whether a localiser can run with it: every distance, angle and factor finite and
    /// not negative (what a configuration record must hold).
    pub fn is_usable(&self) -> bool {
        [
            self.max_range_m,
            self.tolerance_m,
            self.window_sigmas,
            self.window_margin_m,
            self.max_window_m,
            self.min_grazing_rad,
            self.end_sd_m,
            self.wall_roughness_m,
            self.max_gap_m,
            self.refix_gaps,
            self.landmark_clearance_m,
        ]
        .iter()
        .all(|v| v.is_finite() && *v >= 0.0)
    }
}

impl Default for WallEndConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// One wall end seen in a scan: a scalar measurement of the pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallEndFix {
    /// The wall.
    pub wall: WallSide,
    /// Which end.
    pub at: WallEndAt,
    /// Where the scan sees the wall stop, measured from the stored end along the wall's
    /// outward direction under the pose given, metres (positive: the scan's wall runs on
    /// past the stored end, so the pose is ahead of the truth along `direction`; it equals
    /// the pose's error along `direction` but for the measurement's own).
    pub offset_m: f32,
    /// The wall's outward direction at the end (world frame, unit): `offset_m` measures the
    /// position along it.
    pub direction: Point2,
    /// Variance of `offset_m`, m².
    pub variance_m2: f32,
    /// Distance between the two footprints the end lies between, metres.
    pub gap_m: f32,
}

impl WallEndFix {
    /// The innovation for the filter: the stored end (offset 0) minus what the pose says.
    pub fn innovation_m(&self) -> f32 {
        -self.offset_m
    }
}

/// When each wall end was last taken by the filter. Successive scans of a slow or standing
/// vehicle see an end between the same two beams, so their errors are one error, not
/// many: an end is due again once the vehicle has moved by a part of its gap
/// ([`WallEndConfig::refix_gaps`]; the end then falls elsewhere between the footprints).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallEndMemory {
    /// Odometer reading (metres driven) at each end's last fix: left start, left finish,
    /// right start, right finish.
    taken_at_m: [Option<f32>; MAX_WALL_END_FIXES],
}

impl WallEndMemory {
    /// Nothing taken yet.
    pub const NEW: Self = Self {
        taken_at_m: [None; MAX_WALL_END_FIXES],
    };

    fn slot(fix: &WallEndFix) -> usize {
        let wall = match fix.wall {
            WallSide::Left => 0,
            WallSide::Right => 2,
        };
        match fix.at {
            WallEndAt::Start => wall,
            WallEndAt::Finish => wall + 1,
        }
    }

    /// Whether `fix` tells something new at `odometer_m` metres driven: the vehicle has
    /// moved by `refix_gaps` of its gap since the end was last taken.
    pub fn is_due(&self, fix: &WallEndFix, odometer_m: f32, refix_gaps: f32) -> bool {
        match self.taken_at_m.get(Self::slot(fix)).copied().flatten() {
            None => true,
            // A non-finite odometer leaves the end due (the filter's gate judges the fix).
            Some(at_m) => {
                math::abs(odometer_m - at_m) >= refix_gaps * fix.gap_m || !odometer_m.is_finite()
            }
        }
    }

    /// Records that `fix` was taken at `odometer_m`.
    pub fn take(&mut self, fix: &WallEndFix, odometer_m: f32) {
        if let Some(slot) = self.taken_at_m.get_mut(Self::slot(fix)) {
            *slot = Some(odometer_m);
        }
    }
}

impl Default for WallEndMemory {
    fn default() -> Self {
        Self::NEW
    }
}

/// What a beam's echo says about the wall's line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum BeamClass {
    Wall,
    Beyond,
    Near,
}

/// The beams of a scan as rays from the scanner, vehicle frame.
struct Beams<'a> {
    points: &'a [ScanPoint],
    origin: Point2,
    /// Sensor-frame angle of beam 0 and the step between beams, radians.
    angle0_rad: f32,
    step_rad: f32,
    mount_rad: f32,
    first: u16,
    last: u16,
}

impl<'a> Beams<'a> {
    /// The layout from the scan's own points (its step is what the scanner sent, whatever
    /// the configured rate); `None` with fewer than two beams.
    fn new(points: &'a [ScanPoint], sensor: &SensorSetup) -> Option<Self> {
        let a = points.first()?;
        let b = points.last()?;
        let span = f32::from(b.beam_index) - f32::from(a.beam_index);
        if span < 1.0 {
            return None;
        }
        let step_rad = (b.angle_rad - a.angle_rad) / span;
        let angle0_rad = a.angle_rad - f32::from(a.beam_index) * step_rad;
        (step_rad.is_finite() && step_rad != 0.0 && angle0_rad.is_finite()).then_some(Self {
            points,
            origin: sensor.mounting.translation(),
            angle0_rad,
            step_rad,
            mount_rad: sensor.mounting.theta_rad,
            first: a.beam_index,
            last: b.beam_index,
        })
    }

    /// Vehicle-frame unit direction of beam `i`. Not inlined: `sin_cos` inlined at each of
    /// its callers cost the firmware kilobytes of flash.
    #[inline(never)]
    fn direction(&self, i: i32) -> Point2 {
        let (s, c) = math::sin_cos(self.angle0_rad + i as f32 * self.step_rad + self.mount_rad);
        Point2::new(c, s)
    }

    /// The (fractional) beam index looking at vehicle-frame point `p`.
    fn index_towards(&self, p: Point2) -> f32 {
        let d = p.sub(self.origin);
        let a = math::wrap_angle(math::atan2(d.y_m, d.x_m) - self.mount_rad - self.angle0_rad);
        // The sensor's angles run from about −5° to 185°: unwrap below −π/2.
        let a = if a < -core::f32::consts::FRAC_PI_2 {
            a + 2.0 * core::f32::consts::PI
        } else {
            a
        };
        a / self.step_rad
    }

    /// The echo of beam `i`, if it has one.
    fn echo(&self, i: i32) -> Option<&ScanPoint> {
        let i = u16::try_from(i).ok()?;
        let k = self
            .points
            .binary_search_by_key(&i, |p| p.beam_index)
            .ok()?;
        self.points.get(k)
    }
}

/// A wall's line near its end in the vehicle frame: `e + t·u` (`u` pointing out past the
/// end), inward normal `n`.
struct EndLine {
    e: Point2,
    u: Point2,
    n: Point2,
}

impl EndLine {
    /// Where beam direction `d` from `o` meets the line, as the distance along `u` from
    /// `e`; `None` when the ray runs away from the line or meets it at less than the
    /// angle whose sine is `min_sin`.
    fn footprint(&self, o: Point2, d: Point2, min_sin: f32) -> Option<f32> {
        let den = d.cross(self.u);
        if math::abs(den) < min_sin {
            return None;
        }
        let rel = self.e.sub(o);
        let range = rel.cross(self.u) / den;
        let t = rel.cross(d) / den;
        (range > 0.0 && range.is_finite() && t.is_finite()).then_some(t)
    }
}

/// Looks for every stored wall end near the pose in the scan and calls `found` with each
/// one seen (at most [`MAX_WALL_END_FIXES`]). `points` are the scan's valid beams in beam
/// order (vehicle frame), `pose` the estimate (world frame) and `prior` its position's
/// uncertainty (the one the matcher was given), which sets the search window and whether an
/// end still has something to say.
pub fn observe_wall_ends<M: MapQuery + ?Sized>(
    map: &M,
    points: &[ScanPoint],
    sensor: &SensorSetup,
    pose: Pose2,
    prior: &PositionPrior,
    config: &WallEndConfig,
    found: &mut dyn FnMut(WallEndFix),
) {
    if !config.enabled || !pose.is_finite() {
        return;
    }
    let Some(beams) = Beams::new(points, sensor) else {
        return;
    };
    for wall in [WallSide::Left, WallSide::Right] {
        for at in WallEndAt::BOTH {
            let Some(end) = map.wall_end(wall, at) else {
                continue;
            };
            if let Some(fix) = observe_one(map, &beams, &end, pose, prior, config) {
                found(fix);
            }
        }
    }
}

/// One stored end: `None` unless the scan sees the wall stop near it and that says
/// something the pose does not already know. The cheap tests come first (most scans of a
/// tracked vehicle stop at them).
#[inline(never)]
fn observe_one<M: MapQuery + ?Sized>(
    map: &M,
    beams: &Beams<'_>,
    end: &WallEnd,
    pose: Pose2,
    prior: &PositionPrior,
    config: &WallEndConfig,
) -> Option<WallEndFix> {
    let tf = pose.transform();
    let inward = end.inward_normal();
    let line = EndLine {
        e: tf.apply_inverse(end.point),
        u: tf.rotate_inverse(end.outward),
        n: tf.rotate_inverse(inward),
    };
    let range = line.e.dist(beams.origin);
    if !(range <= config.max_range_m && range.is_finite()) {
        return None;
    }
    let min_sin = math::sin(config.min_grazing_rad);
    let sd_along = prior.sd_along_m(end.outward);
    // The end's stored position and the wall's shape over its last gap are the same for
    // every scan: errors no number of fixes averages away (the roughness turned along by
    // the grazing sight line, `1/tan g`). Below them an end has nothing to add (with
    // landmarks in view the position along is known far better).
    let sight = line.e.sub(beams.origin).scale(1.0 / range);
    let cot_grazing =
        math::abs(sight.dot(line.u)) / math::max(math::abs(sight.cross(line.u)), min_sin);
    let systematic_m = math::hypot(config.end_sd_m, config.wall_roughness_m * cot_grazing);
    if sd_along <= systematic_m || !sd_along.is_finite() || !systematic_m.is_finite() {
        return None;
    }
    let mut landmark_near = false;
    map.for_each_landmark_segment_near(end.point, config.landmark_clearance_m, &mut |_, _| {
        landmark_near = true;
    });
    if landmark_near {
        return None;
    }
    let half_window = math::min(
        config.window_sigmas * sd_along + config.window_margin_m,
        config.max_window_m,
    );
    // The beam towards the stored end, and the way along the beams that leads past it.
    let centre = math::floor(beams.index_towards(line.e) + 0.5) as i32;
    let t_at = |i: i32| line.footprint(beams.origin, beams.direction(i), min_sin);
    let t_lo = t_at(centre - 1)?;
    let t_hi = t_at(centre + 1)?;
    let outward: i32 = if t_hi > t_lo { 1 } else { -1 };
    let max_beams = i32::from(beams.last) - i32::from(beams.first) + 1;
    let min_run = u32::from(config.min_run_beams.max(1));
    // Walk back into the wall past the window's inner edge and `min_run` beams more: the
    // wall run that confirms a change near the edge starts before it (at 20 m a beam's
    // footprint moves half a metre).
    let mut start = centre;
    let mut past_edge = 0u32;
    for _ in 0..max_beams {
        let Some(t) = t_at(start - outward) else {
            break;
        };
        if t < -half_window {
            past_edge += 1;
            if past_edge > min_run {
                break;
            }
        }
        start -= outward;
    }
    // Classify outwards from there: a run of wall beams, the change within the window, then
    // only beyond beams to the window's outer edge (and `min_run` at least).
    let mut wall_run = 0u32;
    let mut beyond_run = 0u32;
    // Where the last wall echo lies along the wall, and the gap to the next beam's footprint.
    let mut change: Option<(f32, f32)> = None;
    let mut prev: Option<(f32, f32, BeamClass)> = None; // the beam before: t, its echo's, class
    let mut i = start;
    for _ in 0..max_beams {
        let Some(t) = t_at(i) else {
            break;
        };
        if t > half_window {
            // No change within the window: the end is not where it could be. (The beam
            // whose footprint first passes the window's edge is still looked at: where the
            // footprints lie a metre apart, the end may lie between it and the one before,
            // and refusing it would keep only the cases with the last echo short of the
            // end, a bias of a quarter gap.)
            if change.is_none() && prev.is_some_and(|(t_prev, _, _)| t_prev > half_window) {
                return None;
            }
            if beyond_run >= min_run {
                break;
            }
        }
        // Beams outside the scan's covered sector may not exist: no verdict.
        if i < i32::from(beams.first) || i > i32::from(beams.last) {
            return None;
        }
        let echo = beams.echo(i).map(|p| p.vehicle.sub(line.e));
        let class = match echo {
            None => BeamClass::Beyond,
            Some(rel) => {
                let depth = rel.dot(line.n);
                if math::abs(depth) <= config.tolerance_m {
                    BeamClass::Wall
                } else if depth < 0.0 {
                    // Behind the wall's line: the beam went past the end.
                    BeamClass::Beyond
                } else {
                    BeamClass::Near
                }
            }
        };
        // Where the echo lies along the wall (for the last wall beam: where the wall is
        // known to reach).
        let along = echo.map_or(t, |rel| rel.dot(line.u));
        match (class, change) {
            // The wall comes back, or something stands in front of where it ended: not an
            // end that can be measured (a crosscut, dropouts, a person at the portal).
            (BeamClass::Wall | BeamClass::Near, Some(_)) => return None,
            (BeamClass::Wall, None) => wall_run += 1,
            (BeamClass::Near, None) => wall_run = 0,
            (BeamClass::Beyond, Some(_)) => beyond_run += 1,
            (BeamClass::Beyond, None) => match prev {
                Some((t_prev, along_prev, BeamClass::Wall)) if wall_run >= min_run => {
                    change = Some((along_prev, t - t_prev));
                    beyond_run = 1;
                }
                _ => wall_run = 0,
            },
        }
        prev = Some((t, along, class));
        i += outward;
    }
    if beyond_run < min_run {
        return None;
    }
    let (wall_reaches_m, gap_m) = change?;
    if !(gap_m > 0.0 && gap_m <= config.max_gap_m) {
        return None;
    }
    // The end lies between the last echo and the next beam's footprint, a gap further. The
    // echo's own position along the wall is taken, not its beam's footprint on the stored
    // line: at grazing incidence a wall a few millimetres off that line (roughness, the
    // lateral error) moves a footprint by centimetres, and the echo moves with the wall.
    let offset_m = wall_reaches_m + 0.5 * gap_m;
    let variance_m2 = gap_m * gap_m / 12.0 + systematic_m * systematic_m;
    (variance_m2.is_finite() && offset_m.is_finite()).then_some(WallEndFix {
        wall: end.wall,
        at: end.at,
        offset_m,
        direction: end.outward,
        variance_m2,
        gap_m,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::TunnelMap;
    use crate::scan::{Scan, LMS511_MAX_BEAMS};
    use crate::testkit::{LandmarkLayout, ScanSimulator, TunnelSpec};

    fn tunnel(spec: TunnelSpec) -> TunnelMap {
        let mut map = TunnelMap::new();
        spec.build_into(&mut map).unwrap();
        map
    }

    fn setup() -> SensorSetup {
        SensorSetup::lms511_forward(1.0, 0.0)
    }

    /// The prediction's position covariance the tests observe with: 10 cm along, 5 mm across.
    const COV: [[f32; 2]; 2] = [[0.1 * 0.1, 0.0], [0.0, 0.005 * 0.005]];

    /// A scan taken at `truth` in `world` with `noise_m` of range noise; `edit` may change
    /// its ranges first.
    fn scan_of(
        world: &TunnelMap,
        truth: Pose2,
        noise_m: f32,
        seed: u64,
        edit: impl Fn(&mut [f32]),
    ) -> Scan {
        let mut ranges = [0.0f32; LMS511_MAX_BEAMS];
        ScanSimulator::with_noise(seed, noise_m).simulate(world, &truth, &setup(), &mut ranges);
        edit(&mut ranges);
        Scan::from_ranges_m(&setup(), &ranges)
    }

    fn fixes_of(
        map: &TunnelMap,
        scan: &Scan,
        estimate: Pose2,
        cov: [[f32; 2]; 2],
        config: &WallEndConfig,
    ) -> heapless::Vec<WallEndFix, MAX_WALL_END_FIXES> {
        let [[a, b], [c, d]] = cov;
        let prior = &PositionPrior::from_covariance(&nalgebra::Matrix3::new(
            a, b, 0.0, c, d, 0.0, 0.0, 0.0, 0.0,
        ));
        let mut out = heapless::Vec::new();
        observe_wall_ends(
            map,
            scan.points(),
            &setup(),
            estimate,
            prior,
            config,
            &mut |f| {
                out.push(f).unwrap();
            },
        );
        out
    }

    #[test]
    fn an_end_ahead_is_found_where_the_map_puts_it() {
        let map = tunnel(TunnelSpec::straight(30.0));
        // Ends 9–21 m ahead with the window wider than the gaps, and 21–26 m ahead with
        // gaps of up to 0.8 m against a window of ±0.7 m.
        let narrow = [[0.07 * 0.07, 0.0], [0.0, COV[1][1]]];
        for (noise, x0, step, cov) in [
            (0.0, 8.0, 0.0317, COV),
            (0.01, 8.0, 0.0317, COV),
            (0.0, 3.0, 0.0127, narrow),
        ] {
            let mut sums = [(0.0f32, 0u32); 2];
            for k in 0..400 {
                let x = x0 + k as f32 * step;
                let pose = Pose2::new(x, 0.3, 0.0);
                let scan = scan_of(&map, pose, noise, k, |_| {});
                for f in fixes_of(&map, &scan, pose, cov, &WallEndConfig::DEFAULT) {
                    assert_eq!(f.at, WallEndAt::Finish);
                    assert_eq!(f.direction, Point2::new(1.0, 0.0));
                    // Between the last echo and the next beam's footprint (range noise
                    // moves the echo along a grazing beam).
                    assert!(
                        f.offset_m.abs() <= 0.5 * f.gap_m + 4.0 * noise + 0.001,
                        "{f:?} at {x}"
                    );
                    assert!(f.variance_m2 >= f.gap_m * f.gap_m / 12.0);
                    let s = &mut sums[f.wall as usize];
                    *s = (s.0 + f.offset_m / f.gap_m, s.1 + 1);
                }
            }
            for (sum, n) in sums {
                // Both walls' ends, in (nearly) every scan, and not biased either way.
                assert!(n > 390, "found {n} times of 400 ({x0} m)");
                let mean = sum / n as f32;
                assert!(mean.abs() < 0.05, "mean offset {mean} gaps ({x0} m)");
            }
        }
    }

    #[test]
    fn a_pose_behind_the_truth_sees_the_wall_stop_short_of_the_stored_end() {
        let map = tunnel(TunnelSpec::straight(30.0));
        let truth = Pose2::new(12.0, -0.4, 0.0);
        let scan = scan_of(&map, truth, 0.01, 3, |_| {});
        for (behind_m, cov_scale) in [(0.3, 2.0), (-0.2, 2.0), (1.0, 5.0)] {
            let estimate = Pose2::new(truth.x_m - behind_m, truth.y_m, 0.0);
            let cov = [[COV[0][0] * cov_scale * cov_scale, 0.0], [0.0, COV[1][1]]];
            let found = fixes_of(&map, &scan, estimate, cov, &WallEndConfig::DEFAULT);
            assert_eq!(found.len(), 2, "{behind_m}");
            for f in found {
                // The wall stops `behind_m` short of the stored end as the estimate puts
                // it; the filter's innovation takes the estimate forward by that much.
                assert!(
                    (f.offset_m + behind_m).abs() <= 0.5 * f.gap_m + 0.04,
                    "{f:?}"
                );
                assert!((f.innovation_m() - behind_m).abs() <= 0.5 * f.gap_m + 0.04);
            }
        }
    }

    #[test]
    fn a_wall_that_runs_on_past_the_stored_end_gives_nothing() {
        // The map stops at 30 m (the survey's edge), the tunnel goes on.
        let map = tunnel(TunnelSpec::straight(30.0));
        let world = tunnel(TunnelSpec::straight(60.0));
        for x in [10.0, 15.0, 22.0] {
            let pose = Pose2::new(x, 0.0, 0.0);
            let scan = scan_of(&world, pose, 0.01, 5, |_| {});
            assert!(
                fixes_of(&map, &scan, pose, COV, &WallEndConfig::DEFAULT).is_empty(),
                "{x}"
            );
        }
    }

    #[test]
    fn something_in_front_of_the_end_or_a_gap_in_the_wall_gives_nothing() {
        let map = tunnel(TunnelSpec::straight(30.0));
        let pose = Pose2::new(15.0, 0.0, 0.0);
        let clear = scan_of(&map, pose, 0.0, 1, |_| {});
        assert_eq!(
            fixes_of(&map, &clear, pose, COV, &WallEndConfig::DEFAULT).len(),
            2
        );
        // The beams just past each end (no echo) first: where they meet something 10 m out
        // (a person at the portal), the end is hidden.
        let past_end = |r: &mut [f32]| {
            let mut i = 1;
            while i < r.len() {
                if r[i - 1] > 0.0 && r[i] == 0.0 || r[i - 1] == 0.0 && r[i] > 0.0 {
                    let at = if r[i] == 0.0 { i } else { i - 1 };
                    for k in at.saturating_sub(1)..=(at + 1).min(r.len() - 1) {
                        if r[k] == 0.0 {
                            r[k] = 10.0;
                        }
                    }
                    i += 3;
                }
                i += 1;
            }
        };
        let hidden = scan_of(&map, pose, 0.0, 1, past_end);
        assert!(fixes_of(&map, &hidden, pose, COV, &WallEndConfig::DEFAULT).is_empty());
        // A dropout in the wall just before its end: the wall comes back after it.
        let gap = |r: &mut [f32]| {
            let last = (1..r.len())
                .find(|&i| r[i - 1] > 0.0 && r[i] == 0.0)
                .unwrap()
                - 1;
            r[last - 2] = 0.0;
        };
        let gapped = scan_of(&map, pose, 0.0, 1, gap);
        assert_eq!(
            fixes_of(&map, &gapped, pose, COV, &WallEndConfig::DEFAULT).len(),
            1
        );
    }

    #[test]
    fn no_end_is_looked_for_near_a_landmark_far_off_or_when_already_known() {
        let pose = Pose2::new(15.0, 0.0, 0.0);
        let lm = tunnel(
            TunnelSpec::straight(30.0).with_landmarks(LandmarkLayout::paper(
                crate::landmark::LandmarkModel::P1Triangle,
                1,
            )),
        );
        let scan = scan_of(&lm, pose, 0.0, 1, |_| {});
        let far_clearance = WallEndConfig {
            landmark_clearance_m: 100.0,
            ..WallEndConfig::DEFAULT
        };
        assert!(fixes_of(&lm, &scan, pose, COV, &far_clearance).is_empty());
        let map = tunnel(TunnelSpec::straight(30.0));
        let scan = scan_of(&map, pose, 0.0, 1, |_| {});
        let short = WallEndConfig {
            max_range_m: 10.0,
            ..WallEndConfig::DEFAULT
        };
        assert!(fixes_of(&map, &scan, pose, COV, &short).is_empty());
        let off = WallEndConfig {
            enabled: false,
            ..WallEndConfig::DEFAULT
        };
        assert!(fixes_of(&map, &scan, pose, COV, &off).is_empty());
        // The position along known to 1 cm: below what an end at 15 m can say.
        let known = [[1e-4, 0.0], [0.0, COV[1][1]]];
        assert!(fixes_of(&map, &scan, pose, known, &WallEndConfig::DEFAULT).is_empty());
    }

    #[test]
    fn nonsense_gives_nothing_and_never_panics() {
        let map = tunnel(TunnelSpec::straight(30.0));
        let pose = Pose2::new(15.0, 0.0, 0.0);
        let scan = scan_of(&map, pose, 0.01, 1, |_| {});
        for bad in [
            Pose2::new(f32::NAN, 0.0, 0.0),
            Pose2::new(1e30, 0.0, 0.0),
            Pose2::new(15.0, 0.0, 3.0),
        ] {
            assert!(fixes_of(&map, &scan, bad, COV, &WallEndConfig::DEFAULT).is_empty());
        }
        let nan_cov = [[f32::NAN, 0.0], [0.0, f32::NAN]];
        let _ = fixes_of(&map, &scan, pose, nan_cov, &WallEndConfig::DEFAULT);
        assert!(fixes_of(&map, &Scan::new(), pose, COV, &WallEndConfig::DEFAULT).is_empty());
    }

    #[test]
    fn an_end_is_due_again_once_the_vehicle_has_moved_by_part_of_its_gap() {
        let fix = WallEndFix {
            wall: WallSide::Right,
            at: WallEndAt::Finish,
            offset_m: 0.0,
            direction: Point2::new(1.0, 0.0),
            variance_m2: 0.01,
            gap_m: 0.4,
        };
        let mut memory = WallEndMemory::NEW;
        assert!(memory.is_due(&fix, 3.0, 0.5));
        memory.take(&fix, 3.0);
        assert!(!memory.is_due(&fix, 3.0, 0.5));
        assert!(!memory.is_due(&fix, 3.19, 0.5));
        assert!(memory.is_due(&fix, 3.21, 0.5));
        // The other ends are remembered apart.
        let left = WallEndFix {
            wall: WallSide::Left,
            ..fix
        };
        assert!(memory.is_due(&left, 3.0, 0.5));
    }
}
