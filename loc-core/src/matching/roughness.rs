//! Wall roughness in the normal equations: scan points along one wall share that wall's
//! deviation from the smooth stored map, a deviation correlated along the wall.
//!
//! A shotcrete wall is not the design: it deviates from it by millimetres to centimetres,
//! smoothly along the tunnel. Points on one stretch of wall — and a landmark mounted there —
//! are displaced by nearly the same offset along the wall's normal, so they are not
//! independent measurements: a thousand points on one metre of wall say no more about the
//! lateral position than that metre's deviation allows. Treating them as independent (the
//! plain point-to-line model) makes a match believe the nearest, densest stretch, and report
//! a covariance many times too small.
//!
//! Model, per wall: `r_i = J_i·δ + a_i·w(x_i) + ε_i`, `ε_i ~ N(0, σ_r²/ω_i)`, with `w` the
//! wall's offset along its normal at the point's abscissa `x_i` (vehicle frame), a
//! stationary Gauss–Markov process: variance `σ_w²`, correlation `exp(−|Δx|/ℓ)` (how host-sim
//! draws its walls), and `a_i = n_i·m` (`n_i` the residual's normal, `m` the wall's).
//!
//! The generalised least squares of that model is solved exactly, in `O(points)`, by a
//! scalar Kalman filter running along each wall (the points arrive in scan order, which runs
//! along each wall): it predicts each point's share of the offset from the points before it,
//! and the normal equations take the innovations — the residual and the Jacobian whitened of
//! what the earlier points already said about the offset — weighted by the innovation's
//! variance. The filter runs on the residual and the Jacobian's three columns at once (its
//! gain does not depend on the data): the offset's estimate is `m_r − m_J·δ`. In units of
//! one point of variance `σ_r²`:
//!
//! `H = Σ ω_S ẽ_J ẽ_Jᵀ`, `g = Σ ω_S ẽ_J ẽ_r`, `ẽ = e − a·m_pred`, `ω_S = 1/(a²P + 1/ω)`.
//!
//! The same accumulation gives the Fisher information of a scan ([`super::fisher`]), the
//! Cramér–Rao yardstick of the localiser's accuracy. It replaced piecewise-constant 2 m
//! patches binned in the vehicle frame, whose bins moved across the walls as the vehicle
//! drove: the S-bend's position RMS fell by 5–9 % (measured 2026-12-03, README).

use nalgebra::{Matrix3, Vector3};

use super::information::NormalEquations;
use crate::geometry::Point2;

/// The wall-roughness model of a match.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RoughnessModel {
    /// 1σ deviation of the real walls from the stored map along their normal, metres
    /// (0: smooth walls, the plain point-to-line model).
    pub sigma_m: f32,
    /// Distance along a wall over which its deviation's correlation falls to `1/e`, metres
    /// (exponential correlation).
    pub correlation_m: f32,
}

impl Default for RoughnessModel {
    /// Smooth walls ([`RoughnessModel::SMOOTH`]): the plain point-to-line model, at no
    /// cost. Set the walls' roughness where they are rough (host-sim sets the scenario's;
    /// on a vehicle, the survey's).
    fn default() -> Self {
        Self::SMOOTH
    }
}

impl RoughnessModel {
    /// Smooth walls: every point independent.
    pub const SMOOTH: Self = Self {
        sigma_m: 0.0,
        correlation_m: 1.0,
    };

    /// Shotcrete: 1 cm, correlated over a metre.
    pub const SHOTCRETE: Self = Self {
        sigma_m: 0.01,
        correlation_m: 1.0,
    };

    /// `λ = σ_r² / σ_w²` for range noise `range_sigma_m`; `None` for smooth walls (or a
    /// model that is not finite and positive).
    fn lambda(&self, range_sigma_m: f32) -> Option<f32> {
        let ok = |v: f32| v.is_finite() && v > 0.0;
        (ok(self.sigma_m) && ok(range_sigma_m) && ok(self.correlation_m)).then(|| {
            let r = range_sigma_m / self.sigma_m;
            r * r
        })
    }
}

/// What the points so far on one wall say about its offset: the offset's estimate `m_r −
/// m_J·δ` and its variance `p` (units of `σ_r²`).
#[derive(Debug, Clone, Copy)]
struct OffsetFilter {
    p: f32,
    m_r: f32,
    m_j: Vector3<f32>,
}

impl OffsetFilter {
    /// Before the wall's first point: the stationary variance `prior`, no estimate.
    fn new(prior: f32) -> Self {
        Self {
            p: prior,
            m_r: 0.0,
            m_j: Vector3::zeros(),
        }
    }

    /// Moves the estimate to the next point: correlation `rho` with the last one, the
    /// offset's stationary variance `prior`.
    #[inline]
    fn advance(&mut self, rho: f32, prior: f32) {
        self.m_r *= rho;
        self.m_j *= rho;
        self.p = rho * rho * self.p + (1.0 - rho * rho) * prior;
    }

    /// Takes the point the estimate was advanced to (normal projection `a`, Jacobian `j`,
    /// residual `r`, noise variance `noise`); returns its innovation `(ẽ_J, ẽ_r)` and the
    /// innovation's inverse variance.
    #[inline]
    fn take(&mut self, a: f32, j: Vector3<f32>, r: f32, noise: f32) -> (Vector3<f32>, f32, f32) {
        let e_r = r - a * self.m_r;
        let e_j = j - self.m_j * a;
        let inv_s = 1.0 / (a * a * self.p + noise);
        let gain = self.p * a * inv_s;
        self.m_r += gain * e_r;
        self.m_j += e_j * gain;
        self.p -= gain * a * self.p;
        (e_j, e_r, inv_s)
    }
}

/// One wall's filters: for the step (with the IRLS weights) and for the information
/// (every point at full weight).
#[derive(Debug, Clone, Copy)]
struct WallFilters {
    /// Abscissa of the wall's last point, metres (vehicle frame); NaN before the first.
    last_x_m: f32,
    weighted: OffsetFilter,
    unit: OffsetFilter,
}

/// The rough walls of one accumulation: both walls' offset filters (fixed memory, 108
/// bytes, on the caller's stack).
#[derive(Debug, Clone)]
pub struct RoughWalls {
    /// Left wall (vehicle `y ≥ 0`), then right.
    walls: [WallFilters; 2],
    /// Heading of the pose the points were placed with: the walls' normals follow it.
    sin_cos: (f32, f32),
    inv_correlation: f32,
    /// The offset's stationary variance, units of `σ_r²` (`1/λ`).
    prior: f32,
    /// `σ_r²`, m²: the unit of the filters' variances.
    range_var_m2: f32,
}

impl RoughWalls {
    /// Empty sums for points placed at heading `theta_rad` (world frame), with range noise
    /// `range_sigma_m` and the roughness `model`; `None` for smooth walls, where
    /// [`NormalEquations::add`] alone is the model.
    pub fn new(model: &RoughnessModel, range_sigma_m: f32, theta_rad: f32) -> Option<Self> {
        let prior = 1.0 / model.lambda(range_sigma_m)?;
        let wall = WallFilters {
            last_x_m: f32::NAN,
            weighted: OffsetFilter::new(prior),
            unit: OffsetFilter::new(prior),
        };
        Some(Self {
            walls: [wall; 2],
            sin_cos: crate::math::sin_cos(theta_rad),
            inv_correlation: 1.0 / model.correlation_m,
            prior,
            range_var_m2: range_sigma_m * range_sigma_m,
        })
    }

    /// Index into `walls` of vehicle-frame point `p`'s wall: left (`y ≥ 0`), then right.
    #[inline]
    fn wall_index(p: Point2) -> usize {
        usize::from(p.y_m < 0.0)
    }

    /// The wall of vehicle-frame point `p` and its normal in the world
    /// ([`outward_normal`]).
    #[inline]
    fn wall_of(&mut self, p: Point2) -> (Option<&mut WallFilters>, Point2) {
        let m = outward_normal(p, self.sin_cos);
        (self.walls.get_mut(Self::wall_index(p)), m)
    }

    /// Vehicle-frame point `p`'s wall, its filters moved to `p`'s abscissa, and the wall's
    /// normal in the world (see [`RoughWalls::wall_of`]).
    #[inline]
    fn wall_at(&mut self, p: Point2) -> Option<(&mut WallFilters, Point2)> {
        let (inv_correlation, prior) = (self.inv_correlation, self.prior);
        let (wall, m) = self.wall_of(p);
        let wall = wall?;
        let rho = if wall.last_x_m.is_nan() {
            0.0
        } else {
            crate::math::exp(-crate::math::abs(p.x_m - wall.last_x_m) * inv_correlation)
        };
        wall.last_x_m = p.x_m;
        wall.weighted.advance(rho, prior);
        wall.unit.advance(rho, prior);
        Some((wall, m))
    }

    /// Adds one residual to `eq`, whitened of its wall's offset: vehicle-frame point `p`
    /// (which wall, and where along it), world point `q`, pose translation `t`, unit normal
    /// `n`, residual `r` (m), IRLS weight `w` and `w_unit`, the weight of a residual within
    /// the noise (so `ω = w / w_unit` is 1 for inliers). Add each wall's points in order
    /// along it (scan order is): the filter correlates each with the one before.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn add(
        &mut self,
        eq: &mut NormalEquations,
        p: Point2,
        q: Point2,
        t: Point2,
        n: Point2,
        r: f32,
        w: f32,
        w_unit: f32,
    ) {
        let j = NormalEquations::jacobian(q, t, n);
        eq.count_residual(r);
        let omega = if w_unit > 0.0 { w / w_unit } else { 1.0 };
        let Some((wall, m)) = self.wall_at(p) else {
            return;
        };
        let a = n.dot(m);
        // A point without weight says nothing to the step (the estimate passes it by).
        if omega > 0.0 {
            let (e_j, e_r, inv_s) = wall.weighted.take(a, j, r, 1.0 / omega);
            let k = w_unit * inv_s;
            eq.weighted += e_j * e_j.transpose() * k;
            eq.gradient += e_j * (k * e_r);
        }
        let (e_j, _, inv_s) = wall.unit.take(a, j, r, 1.0);
        eq.information_points += e_j * e_j.transpose() * inv_s;
    }

    /// Takes one residual as [`RoughWalls::add`] does at full weight, for what the filters
    /// say of the walls' offsets ([`RoughWalls::offset_at`]) only: nothing is added to any
    /// normal equations (reading landmark offsets after a match, at a third of the cost).
    pub fn track(&mut self, p: Point2, q: Point2, t: Point2, n: Point2, r: f32) {
        let j = NormalEquations::jacobian(q, t, n);
        let Some((wall, m)) = self.wall_at(p) else {
            return;
        };
        let _ = wall.unit.take(n.dot(m), j, r, 1.0);
    }

    /// Adds what is known beforehand of the wall's offset at vehicle-frame point `p` (a
    /// landmark's first point): `offset_m` outward, variance `variance_m2` (learnt on
    /// earlier scans: [`super::LandmarkOffsets`]).
    /// It is one more measurement of the offset there: through the filter it corrects the
    /// residuals of the points after it by what it says of the offset, and takes its share
    /// of the normal equations (`w_unit` as in [`RoughWalls::add`]). Not a residual: the
    /// point count is left alone.
    pub fn add_known_offset(
        &mut self,
        eq: &mut NormalEquations,
        p: Point2,
        offset_m: f32,
        variance_m2: f32,
        w_unit: f32,
    ) {
        let noise = variance_m2 / self.range_var_m2;
        if !(noise.is_finite() && noise > 0.0 && offset_m.is_finite()) {
            return;
        }
        let Some((wall, _)) = self.wall_at(p) else {
            return;
        };
        // The offset itself is measured (`a = 1`); the pose does not enter (`J = 0`).
        let zero = Vector3::zeros();
        let (e_j, e_r, inv_s) = wall.weighted.take(1.0, zero, offset_m, noise);
        let k = w_unit * inv_s;
        eq.weighted += e_j * e_j.transpose() * k;
        eq.gradient += e_j * (k * e_r);
        let (e_j, _, inv_s) = wall.unit.take(1.0, zero, offset_m, noise);
        eq.information_points += e_j * e_j.transpose() * inv_s;
    }

    /// What the points added so far say of the offset of vehicle-frame point `p`'s wall at
    /// `p`'s abscissa (the points' correlation with it taken into account: the filter is
    /// moved there, as the next point there would move it).
    pub fn offset_at(&mut self, p: Point2) -> OffsetEstimate {
        let range_var_m2 = self.range_var_m2;
        let Some((wall, _)) = self.wall_at(p) else {
            return OffsetEstimate::UNKNOWN;
        };
        let f = &wall.unit;
        OffsetEstimate {
            offset_m: f.m_r,
            jacobian: f.m_j,
            variance_m2: f.p * range_var_m2,
        }
    }
}

/// The outward normal (into the rock) of the wall of vehicle-frame point `p` (left for
/// `y ≥ 0`, else right), in the world for a vehicle heading with `(sin, cos)` `sin_cos`:
/// the vehicle's left or right axis.
#[inline]
pub(super) fn outward_normal(p: Point2, sin_cos: (f32, f32)) -> Point2 {
    let (s, c) = sin_cos;
    if p.y_m >= 0.0 {
        Point2::new(-s, c)
    } else {
        Point2::new(s, -c)
    }
}

/// A wall's offset as the points of one accumulation estimate it: `offset_m − jacobian·δ`
/// for a pose correction `δ` (world `(x_m, y_m, theta_rad)`) from the pose the residuals
/// were taken at, with variance `variance_m2` at a known pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OffsetEstimate {
    /// Outward offset at the pose the residuals were taken at, metres.
    pub offset_m: f32,
    /// How the estimate moves with the pose (m/m, m/rad).
    pub jacobian: Vector3<f32>,
    /// Its variance were the pose known, m².
    pub variance_m2: f32,
}

impl OffsetEstimate {
    /// Nothing known.
    pub const UNKNOWN: Self = Self {
        offset_m: 0.0,
        jacobian: Vector3::new(0.0, 0.0, 0.0),
        variance_m2: f32::INFINITY,
    };

    /// The variance the pose adds, known to `covariance` (world `(x_m, y_m, theta_rad)`),
    /// m²: the residuals were taken at a pose that is itself uncertain, and the estimate
    /// moves with it.
    pub fn pose_variance_m2(&self, covariance: &Matrix3<f32>) -> f32 {
        (self.jacobian.transpose() * covariance * self.jacobian).x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` points on a straight left wall at y = 2 (vehicle at the origin, heading 0),
    /// spread over `length_m` from x = 0.
    fn wall(n: usize, length_m: f32, model: &RoughnessModel) -> NormalEquations {
        let mut eq = NormalEquations::default();
        let mut walls = RoughWalls::new(model, 0.01, 0.0);
        for i in 0..n {
            let x = length_m * i as f32 / n as f32;
            let p = Point2::new(x, 2.0);
            let n = Point2::new(0.0, 1.0);
            match walls.as_mut() {
                Some(s) => s.add(&mut eq, p, p, Point2::ORIGIN, n, 0.0, 1.0, 1.0),
                None => {
                    eq.add(p, Point2::ORIGIN, n, 0.0, 1.0);
                }
            }
        }
        eq
    }

    #[test]
    fn the_walls_filters_take_108_bytes() {
        assert_eq!(core::mem::size_of::<RoughWalls>(), 108);
    }

    #[test]
    fn smooth_walls_leave_the_point_to_line_model_alone() {
        let eq = wall(100, 10.0, &RoughnessModel::SMOOTH);
        assert!((eq.information_points.m22 - 100.0).abs() < 1e-3);
    }

    #[test]
    fn points_close_together_count_as_one_offset() {
        // σ_w = σ_r (λ = 1), 100 points within 1 cm of a 10 m correlation: lateral
        // information about one offset's worth (1/(σ_r²/100 + σ_w²) ≈ 0.99), not 100.
        let model = RoughnessModel {
            sigma_m: 0.01,
            correlation_m: 10.0,
        };
        let one = wall(100, 0.01, &model);
        let y = one.information_points.m22;
        assert!((y - 1.0 / (0.01 + 1.0)).abs() < 2e-3, "{y}");
        // Spread over 20 correlation lengths: many independent offsets' worth, yet far
        // fewer than 100 points.
        let spread = RoughnessModel {
            sigma_m: 0.01,
            correlation_m: 0.5,
        };
        let y = wall(100, 10.0, &spread).information_points.m22;
        assert!(y > 5.0 && y < 20.0, "{y}");
        // Along the wall (x) nothing was known and nothing is invented.
        assert!(wall(100, 10.0, &spread).information_points.m11.abs() < 1e-4);
    }

    #[test]
    fn a_single_point_gets_range_and_roughness_variance() {
        // Information λ/(λ+1), i.e. variance σ_r² + σ_w².
        let model = RoughnessModel {
            sigma_m: 0.02,
            correlation_m: 1.0,
        };
        let eq = wall(1, 0.0, &model);
        let expected = 1.0 / (1.0 + 4.0);
        assert!((eq.information_points.m22 - expected).abs() < 1e-5);
    }

    /// The filter's information equals the generalised least squares of the model written
    /// out: `Jᵀ C⁻¹ J` with `C = σ_r² I + σ_w² a aᵀ ρ^{|Δx|}`, here for points on both
    /// walls of a turned vehicle, some at grazing normals.
    #[test]
    fn the_filter_is_the_exact_generalised_least_squares() {
        use nalgebra::SMatrix;
        const K: usize = 12;
        let model = RoughnessModel {
            sigma_m: 0.015,
            correlation_m: 0.7,
        };
        let sigma_r = 0.01f32;
        let theta = 0.3f32;
        let (s, c) = crate::math::sin_cos(theta);
        let mut pts = [(Point2::ORIGIN, Point2::ORIGIN, Point2::ORIGIN, false); K];
        for (i, e) in pts.iter_mut().enumerate() {
            let x = 0.37 * i as f32 - 1.0;
            let left = i % 3 != 0;
            let y = if left { 2.0 } else { -2.0 };
            // Normals tilted off the wall's (a landmark's flank) on every fourth point.
            let tilt = if i % 4 == 0 { 0.6 } else { 0.0 };
            let wall_n = if left { (0.0f32, 1.0f32) } else { (0.0, -1.0) };
            let nv = (wall_n.0 + tilt, wall_n.1);
            let len = (nv.0 * nv.0 + nv.1 * nv.1).sqrt();
            let n_vehicle = Point2::new(nv.0 / len, nv.1 / len);
            let n = Point2::new(
                c * n_vehicle.x_m - s * n_vehicle.y_m,
                s * n_vehicle.x_m + c * n_vehicle.y_m,
            );
            let p = Point2::new(x, y);
            let q = Point2::new(c * x - s * y + 5.0, s * x + c * y - 1.0);
            *e = (p, q, n, left);
        }
        let t = Point2::new(5.0, -1.0);
        let mut eq = NormalEquations::default();
        let mut walls = RoughWalls::new(&model, sigma_r, theta).unwrap();
        // Left wall's points first, then the right's (each in order along its wall).
        for &(p, q, n, _) in pts
            .iter()
            .filter(|e| e.3)
            .chain(pts.iter().filter(|e| !e.3))
        {
            walls.add(&mut eq, p, q, t, n, 0.0, 1.0, 1.0);
        }
        let mut jm = SMatrix::<f64, K, 3>::zeros();
        let mut cov = SMatrix::<f64, K, K>::identity();
        let lambda_inv = f64::from(model.sigma_m / sigma_r).powi(2);
        let wall_normal = |left: bool| {
            if left {
                Point2::new(-s, c)
            } else {
                Point2::new(s, -c)
            }
        };
        for (i, &(p, q, n, left)) in pts.iter().enumerate() {
            let j = NormalEquations::jacobian(q, t, n);
            for col in 0..3 {
                jm[(i, col)] = f64::from(j[col]);
            }
            for (l, &(p2, _, n2, left2)) in pts.iter().enumerate() {
                if left == left2 {
                    let a = f64::from(n.dot(wall_normal(left)));
                    let a2 = f64::from(n2.dot(wall_normal(left2)));
                    let rho = (-f64::from((p.x_m - p2.x_m).abs() / model.correlation_m)).exp();
                    cov[(i, l)] += lambda_inv * a * a2 * rho;
                }
            }
        }
        let exact = jm.transpose() * cov.try_inverse().unwrap() * jm;
        for r in 0..3 {
            for col in 0..3 {
                let got = f64::from(eq.information_points[(r, col)]);
                let want = exact[(r, col)];
                assert!(
                    (got - want).abs() < 1e-3 * (1.0 + want.abs()),
                    "({r},{col}) {got} {want}"
                );
            }
        }
    }
}
