//! One landmark in one scan: the pose of the landmark's frame in the vehicle frame, fitted
//! to the scan points around it (its flanks and a short run of wall either side).
//!
//! The landmark frame is an SE(2) pose: origin at the centre of the landmark's base on the
//! wall, x along the wall (increasing arc length), y to the left of x. A landmark's profile
//! reaches into the tunnel, which is to the right of the left wall's direction and to the
//! left of the right wall's: [`FitModel::new`] folds that in, so one rigid transform places
//! the profile on either wall.
//!
//! The fit is Gauss–Newton on point-to-segment distances with the corrections taken in the
//! landmark frame (a right perturbation `T ∘ exp(δ)`, `δ = (θ, x, y)`: factrs' tangent
//! order), so its covariance is directly the between factor's noise.

use nalgebra::{Matrix3, Vector3};

use crate::vehicle::SimPose;

/// The shape a scan is fitted to, in the landmark frame (metres).
#[derive(Debug, Clone, PartialEq)]
pub struct FitModel {
    /// The profile's vertices with a run of wall before and after it, in order.
    vertices: Vec<(f64, f64)>,
    /// Half the landmark's width plus the wall run, metres: points farther along are not
    /// the landmark's.
    reach_along_m: f64,
    /// Half the landmark's width, metres.
    half_width_m: f64,
    /// Deepest the profile reaches into the tunnel, metres.
    height_m: f64,
    /// Which way the tunnel is: +1 to the frame's left (right wall), −1 to its right.
    inward_sign: f64,
}

/// How a fit weighs and screens points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitConfig {
    /// Range noise of the scanner, 1σ, metres.
    pub range_noise_m: f64,
    /// Extra 1σ of the wall runs (their roughness is not the landmark's), metres.
    pub wall_sigma_m: f64,
    /// Wall included either side of the landmark, metres. A metre, not a few centimetres:
    /// far off, at grazing incidence, the wall beside the landmark is what fixes its base
    /// and direction (per-fit error at 8–10 m: 8 mm along and 4 mm across with 1 m, 10–12
    /// and 9–11 mm with 0.3 m, and fits beyond 12 m fail; `tunnel-1km`, P1).
    pub wall_run_m: f64,
    /// Points farther than this from the model after the fit are dropped and the fit
    /// repeated, metres.
    pub outlier_m: f64,
    /// Largest distance of the fix from the initial pose, metres (farther: not this
    /// landmark).
    pub max_shift_m: f64,
    /// Largest rotation of the fix from the initial pose, radians (a landmark lies along
    /// its wall; turned further, a flank is being fitted to the bare wall).
    pub max_turn_rad: f64,
    /// Fewest points on the landmark itself (more than a quarter of its height off the
    /// wall) for a fit.
    pub min_landmark_points: usize,
}

impl Default for FitConfig {
    /// The LMS511 (≈10 mm noise) and the paper's landmark sizes.
    fn default() -> Self {
        Self {
            range_noise_m: 0.01,
            wall_sigma_m: 0.01,
            wall_run_m: 1.0,
            outlier_m: 0.04,
            max_shift_m: 0.15,
            max_turn_rad: 0.08,
            min_landmark_points: 4,
        }
    }
}

/// A fitted landmark pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LandmarkFix {
    /// The landmark frame in the vehicle frame.
    pub pose: SimPose,
    /// Covariance of the right perturbation `(θ rad, x m, y m)` of `pose`.
    pub covariance: Matrix3<f64>,
    /// Points used (landmark and wall run).
    pub points: usize,
    /// Of which on the landmark itself (more than a quarter of its height off the wall).
    pub landmark_points: usize,
    /// RMS distance of the used points to the model, metres.
    pub rms_m: f64,
}

impl FitModel {
    /// The model of a landmark whose profile is `profile` (`(u, v)`: along the wall from
    /// −W/2 to W/2, `v` into the tunnel, metres), on a wall whose inward normal is to the
    /// left of its direction (`inward_left`, the right wall) or to its right.
    pub fn new(profile: &[(f64, f64)], inward_left: bool, wall_run_m: f64) -> Self {
        let sign = if inward_left { 1.0 } else { -1.0 };
        let (u0, u1) = match (profile.first(), profile.last()) {
            (Some(a), Some(b)) => (a.0, b.0),
            _ => (0.0, 0.0),
        };
        let mut vertices = vec![(u0 - wall_run_m, 0.0)];
        vertices.extend(profile.iter().map(|&(u, v)| (u, sign * v)));
        vertices.push((u1 + wall_run_m, 0.0));
        let height_m = profile.iter().fold(0.0f64, |h, p| h.max(p.1.abs()));
        Self {
            vertices,
            reach_along_m: u0.abs().max(u1.abs()) + wall_run_m,
            half_width_m: u0.abs().max(u1.abs()),
            height_m,
            inward_sign: sign,
        }
    }

    /// Whether a point given in the landmark frame may belong to this landmark or its wall
    /// runs (a box around the model, 10 cm behind the wall to 10 cm past the tip).
    pub fn covers(&self, p: (f64, f64)) -> bool {
        self.within(p, self.reach_along_m)
    }

    /// Whether a point given in the landmark frame lies on the landmark's footprint (its
    /// width, 10 cm behind the wall to 10 cm past the tip): not wall.
    pub fn covers_landmark(&self, p: (f64, f64)) -> bool {
        self.within(p, self.half_width_m)
    }

    /// Within `half_along_m` of the frame's origin along the wall, and from 10 cm behind
    /// the wall to 10 cm past the tip.
    fn within(&self, p: (f64, f64), half_along_m: f64) -> bool {
        let v = p.1 * self.inward_sign;
        p.0.abs() <= half_along_m && v >= -0.1 && v <= self.height_m + 0.1
    }

    /// The nearest point of the model to `p` and whether it lies on the wall runs.
    fn nearest(&self, p: (f64, f64)) -> ((f64, f64), bool) {
        let last = self.vertices.len().saturating_sub(2);
        let mut best = (f64::INFINITY, p, false);
        for (i, w) in self.vertices.windows(2).enumerate() {
            let (a, b) = (w[0], w[1]);
            let (dx, dy) = (b.0 - a.0, b.1 - a.1);
            let len2 = dx * dx + dy * dy;
            let t = if len2 > 0.0 {
                (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let f = (a.0 + t * dx, a.1 + t * dy);
            let d2 = (p.0 - f.0).powi(2) + (p.1 - f.1).powi(2);
            if d2 < best.0 {
                best = (d2, f, i == 0 || i == last);
            }
        }
        (best.1, best.2)
    }
}

/// Fits `model` from `initial` to those of a scan's `points` (vehicle frame, metres) that
/// it covers there ([`FitModel::covers`]): [`fit`] on the landmark's neighbourhood.
pub fn fit_in_scan(
    model: &FitModel,
    points: &[(f64, f64)],
    initial: SimPose,
    config: &FitConfig,
) -> Option<LandmarkFix> {
    let near: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| model.covers(initial.apply_inverse(**p)))
        .copied()
        .collect();
    fit(model, &near, initial, config)
}

/// Fits `model` to `points` (vehicle frame, metres) from the initial landmark pose
/// `initial` (landmark frame in the vehicle frame). `None` when too few points lie on the
/// landmark or the fit is not well posed (a landmark seen edge-on, or half hidden).
pub fn fit(
    model: &FitModel,
    points: &[(f64, f64)],
    initial: SimPose,
    config: &FitConfig,
) -> Option<LandmarkFix> {
    let mut pose = initial;
    let mut keep: Vec<bool> = points
        .iter()
        .map(|&p| model.covers(initial.apply_inverse(p)))
        .collect();
    let wall_var = config.range_noise_m.powi(2) + config.wall_sigma_m.powi(2);
    let point_var = config.range_noise_m.powi(2);
    let mut info = Matrix3::zeros();
    for round in 0..2 {
        for _ in 0..12 {
            let mut h = Matrix3::zeros();
            let mut g = Vector3::zeros();
            for (&p, _) in points.iter().zip(&keep).filter(|(_, k)| **k) {
                let q = pose.apply_inverse(p);
                let (f, on_wall) = model.nearest(q);
                let (ex, ey) = (q.0 - f.0, q.1 - f.1);
                let d = ex.hypot(ey);
                if d < 1e-12 {
                    continue;
                }
                let n = (ex / d, ey / d);
                // q' = exp(δ)⁻¹ q ≈ q − (δx, δy) − δθ·(−q.y, q.x).
                let j = Vector3::new(-(n.0 * -q.1 + n.1 * q.0), -n.0, -n.1);
                let w = 1.0 / if on_wall { wall_var } else { point_var };
                h += j * j.transpose() * w;
                g += j * (d * w);
            }
            let step = h.try_inverse()? * -g;
            let dp = SimPose::new(step[1], step[2], step[0]);
            pose = pose.compose(dp);
            info = h;
            if step.norm() < 1e-7 {
                break;
            }
        }
        if round == 0 {
            // Drop what the model does not explain (a person beside the landmark, a
            // mixed pixel at its edge) and fit again.
            for (k, &p) in keep.iter_mut().zip(points) {
                if *k {
                    let q = pose.apply_inverse(p);
                    let (f, _) = model.nearest(q);
                    *k = (q.0 - f.0).hypot(q.1 - f.1) <= config.outlier_m;
                }
            }
        }
    }
    let (mut used, mut on_landmark, mut on_wall_runs, mut sq) = (0usize, 0usize, 0usize, 0.0);
    for (&p, _) in points.iter().zip(&keep).filter(|(_, k)| **k) {
        let q = pose.apply_inverse(p);
        let (f, on_wall) = model.nearest(q);
        sq += (q.0 - f.0).powi(2) + (q.1 - f.1).powi(2);
        used += 1;
        on_wall_runs += usize::from(on_wall);
        // Only points well off the wall show the landmark (a bare wall's points near
        // where its corners would be do not).
        on_landmark += usize::from(!on_wall && q.1 * model.inward_sign > 0.25 * model.height_m);
    }
    // Without the wall beside it the fit can sink the landmark into the rock until its tip
    // lies on a bare wall; and a fix far from where the landmark was expected is another
    // landmark, or none.
    let moved = initial.between(pose);
    if on_landmark < config.min_landmark_points
        || on_wall_runs < 3
        || moved.x_m.hypot(moved.y_m) > config.max_shift_m
        || moved.theta_rad.abs() > config.max_turn_rad
    {
        return None;
    }
    let rms_m = (sq / used as f64).sqrt();
    // The residuals say how noisy this scan really is (mixed pixels, roughness): never
    // claim better than the scanner's noise.
    let scale = (rms_m / config.range_noise_m).max(1.0).powi(2);
    let covariance = info.try_inverse()? * scale;
    let ok = covariance.iter().all(|v| v.is_finite())
        && covariance[(1, 1)].sqrt() < 0.05
        && covariance[(2, 2)].sqrt() < 0.05
        && covariance[(0, 0)].sqrt() < 0.2;
    ok.then_some(LandmarkFix {
        pose,
        covariance,
        points: used,
        landmark_points: on_landmark,
        rms_m,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use loc_core::rng::Pcg32;

    /// A P1-like triangle, 0.5 m wide and 0.25 m high.
    fn triangle() -> Vec<(f64, f64)> {
        vec![(-0.25, 0.0), (0.0, 0.25), (0.25, 0.0)]
    }

    /// Samples the model placed at `truth` (vehicle frame) as a scanner at the origin would:
    /// points every `step_m` along the model, with range noise.
    fn sample(model: &FitModel, truth: SimPose, noise_m: f64, rng: &mut Pcg32) -> Vec<(f64, f64)> {
        let mut out = Vec::new();
        for w in model.vertices.windows(2) {
            let n = 20;
            for i in 0..n {
                let t = i as f64 / n as f64;
                let q = (
                    w[0].0 + t * (w[1].0 - w[0].0),
                    w[0].1 + t * (w[1].1 - w[0].1),
                );
                let p = truth.apply(q);
                let r = p.0.hypot(p.1);
                let k = 1.0 + noise_m * f64::from(rng.gaussian()) / r;
                out.push((p.0 * k, p.1 * k));
            }
        }
        out
    }

    #[test]
    fn recovers_a_landmark_on_either_wall_from_a_poor_guess() {
        let cfg = FitConfig::default();
        let mut rng = Pcg32::seeded(5);
        for (inward_left, truth) in [
            (true, SimPose::new(6.0, -2.5, 0.02)),
            (false, SimPose::new(-4.0, 2.4, -0.03)),
        ] {
            let model = FitModel::new(&triangle(), inward_left, cfg.wall_run_m);
            let pts = sample(&model, truth, 0.005, &mut rng);
            let guess = truth.compose(SimPose::new(0.06, -0.03, 0.02));
            let fix = fit(&model, &pts, guess, &cfg).unwrap();
            let e = truth.between(fix.pose);
            assert!(e.x_m.abs() < 0.005 && e.y_m.abs() < 0.005, "{e:?}");
            assert!(e.theta_rad.abs() < 0.01, "{e:?}");
            // The error is within a few σ of the reported covariance.
            let m = Vector3::new(e.theta_rad, e.x_m, e.y_m);
            let chi2 = (m.transpose() * fix.covariance.try_inverse().unwrap() * m)[0];
            assert!(chi2 < 20.0, "{chi2}");
            assert!(fix.landmark_points >= 30);
        }
    }

    #[test]
    fn a_wall_without_its_landmark_gives_no_fix() {
        let cfg = FitConfig::default();
        let model = FitModel::new(&triangle(), true, cfg.wall_run_m);
        let pts: Vec<(f64, f64)> = (0..60).map(|i| (5.0 + i as f64 * 0.02, -2.5)).collect();
        let f = fit(&model, &pts, SimPose::new(5.6, -2.5, 0.0), &cfg);
        assert!(f.is_none(), "{f:?}");
        assert!(fit(&model, &[], SimPose::new(5.6, -2.5, 0.0), &cfg).is_none());
    }
}
