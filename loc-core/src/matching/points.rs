//! Which scan points a match uses: the landmark points (up to a budget, spread evenly over
//! them) and a decimated subset of wall points,
//! each the mean of a short run of the wall's points (see the module docs of [`super`] for
//! why).

use super::MAX_MATCH_POINTS;
use crate::geometry::Point2;
use crate::strip::{PointLabel, VehiclePoint};

/// Length of wall (in vehicle x) whose points are averaged into one selected wall point,
/// metres. Near the sensor a wall point comes every few millimetres, and one point in
/// fifteen used to be kept: the run's mean keeps their information (its range noise is the
/// run's, divided by the square root of its length; a far run is a single point, as
/// before). The walls' lateral error fell by about a seventh (bare `paper-10m`, 200 m of
/// `tunnel-1km`, the S-bend; 0.05–0.5 m all gave most of it). Short, so that a run of a
/// curved wall stays on it: the chord's sagitta over 0.2 m of a 30 m radius is 0.17 mm.
pub const WALL_RUN_M: f32 = 0.2;

/// The vehicle-frame points handed to the matcher.
pub type MatchPoints = heapless::Vec<Point2, MAX_MATCH_POINTS>;

/// How many points of each kind were selected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SelectionCounts {
    /// Landmark points (all of them, up to the capacity).
    pub landmark: u16,
    /// Wall points kept after decimation.
    pub wall: u16,
    /// Unlabelled points used because no wall was found (fallback).
    pub unclassified: u16,
}

/// Fills `out` with at most `max_landmark_points` landmark points (all of them when there
/// are no more; otherwise spread evenly over them in scan order) and at most
/// `max_wall_points` wall points, spread
/// evenly in x along each wall (out to the farthest the stripper labelled) and chosen
/// independently of their own noise; each is the mean of the wall's points within
/// [`WALL_RUN_M`] of x from the chosen one on (in scan order). When the stripper found
/// neither walls nor landmarks, up to `max_wall_points` outliers are taken instead (evenly
/// by index), so an unusual scene still gets matched. `labels[i]` labels `points[i]`; extra
/// entries of either are ignored.
pub fn select_match_points<P: VehiclePoint>(
    points: &[P],
    labels: &[PointLabel],
    max_wall_points: u16,
    max_landmark_points: u16,
    out: &mut MatchPoints,
) -> SelectionCounts {
    out.clear();
    let mut counts = SelectionCounts::default();
    let pairs = || {
        points
            .iter()
            .map(VehiclePoint::vehicle_point)
            .zip(labels.iter().copied())
    };

    let (mut n_wall, mut n_landmark, mut n_outlier) = (0usize, 0usize, 0usize);
    let mut span = [(f32::INFINITY, f32::NEG_INFINITY); 2];
    for (p, l) in pairs() {
        match l {
            PointLabel::LeftWall | PointLabel::RightWall => {
                n_wall += 1;
                if let Some(s) = span.get_mut(wall_slot(l)) {
                    s.0 = crate::math::min(s.0, p.x_m);
                    s.1 = crate::math::max(s.1, p.x_m);
                }
            }
            PointLabel::Landmark => n_landmark += 1,
            PointLabel::Outlier => n_outlier += 1,
            PointLabel::OutOfRange => {}
        }
    }
    let wall_budget = usize::from(max_wall_points)
        .min(n_wall)
        .min(MAX_MATCH_POINTS);
    let landmark_budget = (MAX_MATCH_POINTS - wall_budget).min(usize::from(max_landmark_points));
    // One pass: every landmark point (up to its budget) and wall points spread in x, half
    // the wall budget per wall (far wall points pin the heading best). The point that
    // crosses the next x step only decides; the wall's next point is taken: whether a point
    // crosses depends on its own range noise (a point pushed along the sweep crosses
    // first), so taking it would keep noise of one sign ahead of the sensor and the other
    // behind, a lateral and heading bias of a fifth of the range noise.
    let per_wall = (wall_budget / 2).max(1) as f32;
    let mut cursors = span.map(|(lo, hi)| WallCursor {
        step_m: if hi > lo { (hi - lo) / per_wall } else { 0.0 },
        last_x_m: f32::NEG_INFINITY,
        pending: false,
        run: WallRun::NONE,
    });
    let (mut landmarks, mut walls) = (0usize, 0usize);
    // The i-th of the scan's landmark points is kept when the budget's share of the points
    // up to it passes an integer: evenly spread, every face of every landmark keeps its
    // share (the first `landmark_budget` would drop the far landmarks, the along-tunnel
    // lever).
    let mut landmark_seen = 0usize;
    for (p, l) in pairs() {
        if l == PointLabel::Landmark {
            let i = landmark_seen;
            landmark_seen += 1;
            let keep = n_landmark <= landmark_budget
                || (i + 1) * landmark_budget / n_landmark > i * landmark_budget / n_landmark;
            if keep && landmarks < landmark_budget && out.push(p).is_ok() {
                landmarks += 1;
            }
        } else if l.is_wall() {
            let Some(c) = cursors.get_mut(wall_slot(l)) else {
                continue;
            };
            if c.pending {
                if walls < wall_budget {
                    c.run.flush(out);
                    c.run = WallRun::start(p);
                    walls += 1;
                }
                c.pending = false;
            } else {
                // The run being averaged takes the point while it is within reach.
                if !c.run.take(p) {
                    c.run.flush(out);
                }
                if crate::math::abs(p.x_m - c.last_x_m) >= c.step_m {
                    c.last_x_m = p.x_m;
                    c.pending = true;
                }
            }
        }
    }
    for c in &mut cursors {
        c.run.flush(out);
    }
    counts.landmark = crate::math::saturating_u16(landmarks);
    counts.wall = crate::math::saturating_u16(walls);

    if wall_budget == 0 && n_landmark == 0 && n_outlier > 0 {
        let stride = n_outlier
            .div_ceil(usize::from(max_wall_points).max(1))
            .max(1);
        for (p, _) in pairs()
            .filter(|(_, l)| *l == PointLabel::Outlier)
            .step_by(stride)
        {
            if out.push(p).is_err() {
                break;
            }
            counts.unclassified += 1;
        }
    }
    counts
}

/// One wall's progress through the selection.
#[derive(Debug, Clone, Copy)]
struct WallCursor {
    /// x step between the wall's selected points, metres.
    step_m: f32,
    /// x of the point that crossed the last step, metres.
    last_x_m: f32,
    /// The wall's next point starts a run.
    pending: bool,
    run: WallRun,
}

/// Consecutive points of one wall being averaged into one selected point (vehicle frame).
#[derive(Debug, Clone, Copy)]
struct WallRun {
    /// Sum of the run's points, metres.
    sum: Point2,
    /// Points in the run (0: no run).
    count: u32,
    first_x_m: f32,
}

impl WallRun {
    const NONE: Self = Self {
        sum: Point2::ORIGIN,
        count: 0,
        first_x_m: 0.0,
    };

    fn start(p: Point2) -> Self {
        Self {
            sum: p,
            count: 1,
            first_x_m: p.x_m,
        }
    }

    /// Adds `p` if the run is open and `p` lies within [`WALL_RUN_M`] of its first point
    /// (in x); false otherwise (the run is over, or there is none).
    fn take(&mut self, p: Point2) -> bool {
        let within = self.count > 0 && crate::math::abs(p.x_m - self.first_x_m) <= WALL_RUN_M;
        if within {
            self.sum = self.sum.add(p);
            self.count = self.count.saturating_add(1);
        }
        within
    }

    /// Ends the run, if any, by adding its mean to `out` (never full: its capacity is the
    /// landmark and wall budgets' sum).
    fn flush(&mut self, out: &mut MatchPoints) {
        if self.count > 0 {
            let n = self.count as f32;
            let _ = out.push(Point2::new(self.sum.x_m / n, self.sum.y_m / n));
            *self = Self::NONE;
        }
    }
}

fn wall_slot(l: PointLabel) -> usize {
    usize::from(l == PointLabel::RightWall)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_landmarks_and_decimates_walls() {
        let mut pts = [Point2::ORIGIN; 300];
        let mut labels = [PointLabel::Outlier; 300];
        for i in 0..300 {
            let x = i as f32 * 0.1;
            pts[i] = Point2::new(x, if i % 2 == 0 { 2.5 } else { -2.5 });
            labels[i] = if i % 2 == 0 {
                PointLabel::LeftWall
            } else {
                PointLabel::RightWall
            };
        }
        for l in labels.iter_mut().skip(100).take(20) {
            *l = PointLabel::Landmark;
        }
        let mut out = MatchPoints::new();
        let c = select_match_points(&pts, &labels, 40, 512, &mut out);
        assert_eq!(c.landmark, 20);
        assert!(c.wall <= 40 && c.wall >= 30, "{c:?}");
        assert_eq!(out.len(), usize::from(c.landmark + c.wall));
        // Wall points reach the far end of the walls.
        assert!(out.iter().any(|p| p.x_m > 27.0));
    }

    /// The wall points a selection keeps must not depend on their own noise: choosing the
    /// first point past each x step kept the points that range noise had pushed along
    /// the sweep, i.e. away from the sensor ahead of it and toward it behind it, and biased
    /// the lateral position by a fifth of the range noise and turned the heading.
    #[test]
    fn selected_wall_points_carry_no_bias_from_their_noise() {
        let mut rng = crate::rng::Pcg32::new(3, 5);
        let (wall_y_m, noise_m) = (-2.0f32, 0.01f32);
        let beams = 900;
        let (mut ahead, mut behind, mut n_ahead, mut n_behind) = (0.0f64, 0.0f64, 0u32, 0u32);
        for _ in 0..400 {
            // A sensor at the origin sweeping the right wall from behind (−x) to ahead.
            let pts: [Point2; 900] = core::array::from_fn(|i| {
                let bearing = -3.0 + 2.9 * i as f32 / beams as f32;
                let (s, c) = bearing.sin_cos();
                let r = wall_y_m / s + noise_m * rng.gaussian();
                Point2::new(r * c, r * s)
            });
            let labels = [PointLabel::RightWall; 900];
            let mut out = MatchPoints::new();
            select_match_points(&pts, &labels, 100, 512, &mut out);
            for p in &out {
                // Positive: farther from the sensor than the wall.
                let off = f64::from(wall_y_m - p.y_m);
                if p.x_m > 0.0 {
                    ahead += off;
                    n_ahead += 1;
                } else {
                    behind += off;
                    n_behind += 1;
                }
            }
        }
        let (ahead, behind) = (ahead / f64::from(n_ahead), behind / f64::from(n_behind));
        // Standard error of either mean < 0.1 mm; the old choice gave +0.8 mm ahead and
        // −1.1 mm behind.
        assert!(
            ahead.abs() < 4.0e-4 && behind.abs() < 4.0e-4,
            "{ahead} {behind}"
        );
    }

    /// A selected wall point near the sensor is the mean of the wall's dense points there,
    /// so it scatters about the wall far less than one point's range noise.
    #[test]
    fn near_wall_points_are_run_means() {
        let mut rng = crate::rng::Pcg32::new(7, 11);
        let (wall_y_m, noise_m) = (-2.0f32, 0.01f32);
        let (mut sq_near, mut n_near, mut n_far) = (0.0f64, 0u32, 0u32);
        for _ in 0..50 {
            let pts: [Point2; 900] = core::array::from_fn(|i| {
                let bearing = -3.0 + 2.9 * i as f32 / 900.0;
                let (s, c) = bearing.sin_cos();
                let r = wall_y_m / s + noise_m * rng.gaussian();
                Point2::new(r * c, r * s)
            });
            let mut out = MatchPoints::new();
            let c = select_match_points(&pts, &[PointLabel::RightWall; 900], 100, 512, &mut out);
            assert_eq!(out.len(), usize::from(c.wall));
            for p in &out {
                if p.x_m.abs() < 2.0 {
                    sq_near += f64::from(p.y_m - wall_y_m).powi(2);
                    n_near += 1;
                } else if p.x_m.abs() > 15.0 {
                    n_far += 1;
                }
            }
        }
        // About 30 points a run near the sensor: ~2 mm; a single point's noise is 10 mm.
        let rms_near = (sq_near / f64::from(n_near)).sqrt();
        assert!(rms_near < 0.004, "near points scatter {rms_near} m");
        assert!(n_near > 100 && n_far > 100, "{n_near} near, {n_far} far");
    }

    /// Past the landmark budget the landmark points kept are spread over all of them: every
    /// landmark in view keeps its share (the far ones fix the position along the tunnel).
    #[test]
    fn landmark_points_past_the_budget_are_spread_evenly() {
        // Four landmarks of 30 points each, between wall points.
        let mut pts = [Point2::ORIGIN; 400];
        let mut labels = [PointLabel::LeftWall; 400];
        for (i, (p, l)) in pts.iter_mut().zip(labels.iter_mut()).enumerate() {
            *p = Point2::new(i as f32 * 0.05, 2.0);
            if (i / 50) % 2 == 1 && i % 50 < 30 {
                *l = PointLabel::Landmark;
            }
        }
        let mut out = MatchPoints::new();
        let c = select_match_points(&pts, &labels, 100, 64, &mut out);
        assert_eq!(c.landmark, 64);
        // Each landmark keeps 16 of its 30 points.
        for k in 0..4 {
            let (lo, hi) = ((100 * k + 50) as f32 * 0.05, (100 * k + 79) as f32 * 0.05);
            let kept = out
                .iter()
                .filter(|p| p.x_m >= lo - 1e-4 && p.x_m <= hi + 1e-4 && p.y_m == 2.0)
                .filter(|p| {
                    let i = (p.x_m / 0.05).round() as usize;
                    labels[i] == PointLabel::Landmark
                })
                .count();
            assert_eq!(kept, 16, "landmark {k}");
        }
        // Within the budget every landmark point is kept.
        let c = select_match_points(&pts, &labels, 100, 120, &mut out);
        assert_eq!(c.landmark, 120);
    }

    #[test]
    fn falls_back_to_outliers_without_walls() {
        let pts = [Point2::new(1.0, 1.0); 100];
        let labels = [PointLabel::Outlier; 100];
        let mut out = MatchPoints::new();
        let c = select_match_points(&pts, &labels, 30, 512, &mut out);
        assert!(c.unclassified >= 25 && c.unclassified <= 30);
        let c = select_match_points::<Point2>(&[], &[], 30, 512, &mut out);
        assert_eq!(c, SelectionCounts::default());
        assert!(out.is_empty());
    }
}
