//! Point-to-line normal equations, the truncated Gauss–Newton step, and what the
//! information matrix says about degeneracy.
//!
//! State order is `(x_m, y_m, theta_rad)` in the world frame. A scan point `p` (vehicle frame)
//! maps to `q = R(θ)·p + t`; against a map line with unit normal `n` through `c` its residual
//! is `r = n·(q − c)` and its Jacobian `J = [n_x, n_y, n·perp(q − t)]`.
//!
//! Metres and radians do not mix in an eigen-decomposition, so `θ` is scaled by a
//! characteristic length `L` (`rotation_scale_m`, ≈ the distance of the scan points) before
//! one is taken: a rotation by `δθ` then counts like a translation by `L·δθ`.

use nalgebra::{Matrix2, Matrix3, SymmetricEigen, Vector3};

use crate::geometry::Point2;
use crate::math;

/// Accumulated point-to-line normal equations.
#[derive(Debug, Clone, Copy)]
pub struct NormalEquations {
    /// `Σ w·JᵀJ` (the step's Gauss–Newton matrix).
    pub weighted: Matrix3<f32>,
    /// `Σ w·Jᵀr` (the gradient).
    pub gradient: Vector3<f32>,
    /// `Σ JᵀJ`, unweighted: the information in units of one range noise variance.
    pub information_points: Matrix3<f32>,
    /// Residuals added.
    pub count: u32,
    /// `Σ r²`, m².
    pub sum_sq_m2: f32,
}

impl Default for NormalEquations {
    fn default() -> Self {
        Self {
            weighted: Matrix3::zeros(),
            gradient: Vector3::zeros(),
            information_points: Matrix3::zeros(),
            count: 0,
            sum_sq_m2: 0.0,
        }
    }
}

impl NormalEquations {
    /// Adds one residual: world point `q`, pose translation `t`, unit line normal `n`,
    /// residual `r` (metres) and IRLS weight `w`; returns its Jacobian `J`.
    #[inline]
    pub fn add(&mut self, q: Point2, t: Point2, n: Point2, r: f32, w: f32) -> Vector3<f32> {
        let j = Self::jacobian(q, t, n);
        let jjt = j * j.transpose();
        self.information_points += jjt;
        self.weighted += jjt * w;
        self.gradient += j * (w * r);
        self.count_residual(r);
        j
    }

    /// Counts one residual `r` (metres) in `count` and `sum_sq_m2`; the sums of the step and
    /// the information are the caller's (the rough walls add whitened ones).
    #[inline]
    pub fn count_residual(&mut self, r: f32) {
        self.count = self.count.saturating_add(1);
        self.sum_sq_m2 += r * r;
    }

    /// The Jacobian of a point-to-line residual with respect to the pose `(x, y, θ)`: world
    /// point `q`, pose translation `t`, unit line normal `n`.
    #[inline]
    pub fn jacobian(q: Point2, t: Point2, n: Point2) -> Vector3<f32> {
        Vector3::new(n.x_m, n.y_m, n.dot(q.sub(t).perp()))
    }

    /// RMS residual, metres (0 without residuals).
    pub fn rms_m(&self) -> f32 {
        if self.count == 0 {
            0.0
        } else {
            math::sqrt(self.sum_sq_m2 / self.count as f32)
        }
    }
}

/// `diag(1, 1, 1/L)`: maps state increments to scaled ones (`θ` in metres at distance `L`)
/// when used on matrices as `S·M·S`.
fn scaling(rotation_scale_m: f32) -> Matrix3<f32> {
    Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 1.0 / valid_scale(rotation_scale_m)))
}

/// `L` itself, 1 m when not finite and positive.
fn valid_scale(rotation_scale_m: f32) -> f32 {
    if rotation_scale_m.is_finite() && rotation_scale_m > 0.0 {
        rotation_scale_m
    } else {
        1.0
    }
}

/// When a direction of state space counts as observed by a match: its eigenvalue of the
/// scaled information `S·I·S` (`S = diag(1, 1, 1/L)`) is at least `min_information_per_m2`.
/// The matcher derives it from its [`crate::matching::MatchConfig`] and hands it on in the
/// [`crate::matching::MatchResult`], so the filter judges observability exactly as the
/// matcher did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observability {
    /// Least information of an observed direction, m⁻² (scaled state).
    pub min_information_per_m2: f32,
    /// An observed direction with less information than this, m⁻² (scaled state), is
    /// *weakly* observed: what fixes it is a few features every scan of a stretch shares (a
    /// curve ahead seen over tens of metres of straight), so their roughness and the map's
    /// errors are the same in successive matches and the filter must not average them (see
    /// [`crate::filter::UpdateConfig::weak_refix_ratio`]).
    pub weak_below_per_m2: f32,
    /// `L`, metres: how a rotation counts against a translation.
    pub rotation_scale_m: f32,
}

impl Observability {
    /// The observed directions of `information` ([`observable_subspace`]).
    pub fn subspace(&self, information: &Matrix3<f32>) -> ObservableSubspace {
        observable_subspace(
            information,
            self.min_information_per_m2,
            self.rotation_scale_m,
        )
    }
}

/// The directions of state space the information pins down: the eigenvectors of the scaled
/// information `S·I·S` (`S = diag(1, 1, 1/L)`, scaled state `(x_m, y_m, L·theta_rad)`) with
/// eigenvalue at least `min_information`. Columns past `rank` are zero.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObservableSubspace {
    /// Orthonormal observed eigenvectors in scaled coordinates; the first `rank` columns are
    /// valid. As a state increment `(x_m, y_m, theta_rad)` column `v` is `S·v`; as a
    /// measurement row (what the scan measures of the state) it is `vᵀ·S⁻¹`.
    pub scaled_basis: Matrix3<f32>,
    /// The eigenvalue of each column (units of the information given, scaled state).
    pub eigenvalues: Vector3<f32>,
    /// How many directions are observed (0–3).
    pub rank: usize,
    /// The `L` used, metres.
    pub rotation_scale_m: f32,
}

impl ObservableSubspace {
    /// `S⁻¹ = diag(1, 1, L)`: maps state increments to scaled ones.
    pub fn unscale(&self) -> Matrix3<f32> {
        Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, self.rotation_scale_m))
    }

    /// The observed direction with the least information: its column index and eigenvalue.
    pub fn weakest(&self) -> Option<(usize, f32)> {
        self.eigenvalues
            .iter()
            .copied()
            .enumerate()
            .take(self.rank)
            .min_by(|a, b| a.1.partial_cmp(&b.1).unwrap_or(core::cmp::Ordering::Equal))
    }

    /// Column `k` (at most 2) as a state increment `(x_m, y_m, theta_rad)` (`S·v`).
    pub fn state_direction(&self, k: usize) -> Vector3<f32> {
        let v = self.scaled_basis.column(k.min(2)).into_owned();
        Vector3::new(v.x, v.y, v.z / self.rotation_scale_m)
    }

    /// The same subspace without column `k` (no change when `k` is not observed).
    pub fn without(&self, k: usize) -> Self {
        if k >= self.rank {
            return *self;
        }
        let mut out = Self::empty(self.rotation_scale_m);
        for (j, (col, &lambda)) in self
            .scaled_basis
            .column_iter()
            .zip(self.eigenvalues.iter())
            .enumerate()
            .take(self.rank)
        {
            if j != k {
                out.push(&col.into_owned(), lambda);
            }
        }
        out
    }

    /// No observed direction, at rotation scale `l`.
    fn empty(l: f32) -> Self {
        Self {
            scaled_basis: Matrix3::zeros(),
            eigenvalues: Vector3::zeros(),
            rank: 0,
            rotation_scale_m: l,
        }
    }

    /// Appends an observed direction: scaled column `v`, eigenvalue `lambda` (ignored when
    /// all three are taken).
    fn push(&mut self, v: &Vector3<f32>, lambda: f32) {
        if let (Some(mut col), Some(e)) = (
            self.scaled_basis.column_iter_mut().nth(self.rank),
            self.eigenvalues.get_mut(self.rank),
        ) {
            col.copy_from(v);
            *e = lambda;
            self.rank += 1;
        }
    }
}

/// Splits state space into observed and unobserved directions (see [`ObservableSubspace`]).
/// A non-finite information matrix observes nothing.
pub fn observable_subspace(
    information: &Matrix3<f32>,
    min_information: f32,
    rotation_scale_m: f32,
) -> ObservableSubspace {
    let mut out = ObservableSubspace::empty(valid_scale(rotation_scale_m));
    if !information.iter().all(|v| v.is_finite()) {
        return out;
    }
    let s = scaling(rotation_scale_m);
    let scaled = s * information * s;
    let eig = SymmetricEigen::new(0.5 * (scaled + scaled.transpose()));
    for (&lambda, v) in eig.eigenvalues.iter().zip(eig.eigenvectors.column_iter()) {
        if lambda.is_finite() && lambda >= min_information && lambda > 0.0 {
            out.push(&v.into_owned(), lambda);
        }
    }
    out
}

/// The Gauss–Newton step `−H⁺·g` restricted to the directions `information_points` observes
/// (eigenvalue ≥ `min_information_points`), shrunk by `1 / (1 + damping)` (Levenberg).
/// Along unobserved directions the step is zero: the matcher never moves the pose where the
/// scan has nothing to say. One 3×3 eigen-decomposition per call.
///
/// Gauge fix: a step may be changed by any multiple of the unobserved state direction
/// `u = S·v` without changing the fit (to first order); the multiple is chosen so the step
/// leaves the translation along `u`'s translation part untouched. In a straight tunnel this
/// changes nothing; in a curved one it stops a heading correction from leaking into the
/// along-tunnel position (the minimum-norm step would turn part of it into motion around
/// the bend).
pub fn truncated_step(
    eq: &NormalEquations,
    min_information_points: f32,
    rotation_scale_m: f32,
    damping: f32,
) -> Vector3<f32> {
    let s = scaling(rotation_scale_m);
    let shrink = 1.0 / (1.0 + math::max(damping, 0.0));
    let hs = s * eq.weighted * s;
    let gs = s * eq.gradient;
    if !eq.information_points.iter().all(|v| v.is_finite()) {
        return Vector3::zeros();
    }
    let info_s = s * eq.information_points * s;
    let eig = SymmetricEigen::new(0.5 * (info_s + info_s.transpose()));
    let mut observed = Matrix3::zeros();
    let mut rank = 0usize;
    let mut weakest: Option<(f32, Vector3<f32>)> = None;
    for (&lambda, v) in eig.eigenvalues.iter().zip(eig.eigenvectors.column_iter()) {
        if lambda.is_finite() && lambda >= min_information_points && lambda > 0.0 {
            if let Some(mut col) = observed.column_iter_mut().nth(rank) {
                col.copy_from(&v);
                rank += 1;
            }
        } else if weakest.is_none_or(|(l, _)| lambda < l) {
            weakest = Some((lambda, v.into_owned()));
        }
    }
    let mut y = Vector3::zeros();
    match rank {
        0 => return Vector3::zeros(),
        1 => {
            let b = observed.column(0);
            let h = b.dot(&(hs * b));
            if h > 0.0 {
                y.x = -b.dot(&gs) / h;
            }
        }
        2 => {
            let b = observed.fixed_columns::<2>(0);
            let h: Matrix2<f32> = b.transpose() * hs * b;
            if let Some(inv) = h.try_inverse() {
                let yy = -(inv * (b.transpose() * gs));
                y.x = yy.x;
                y.y = yy.y;
            }
        }
        _ => {
            return match hs.try_inverse() {
                Some(inv) => s * (-(inv * gs)) * shrink,
                None => Vector3::zeros(),
            };
        }
    }
    let step = s * (observed * y) * shrink;
    // Gauge fix along the weakest unobserved direction (see above).
    let Some((_, v)) = weakest else {
        return step;
    };
    let u = s * v;
    let t_sq = u.x * u.x + u.y * u.y;
    if t_sq <= 0.01 * u.norm_squared() {
        return step;
    }
    let fixed = step - u * ((step.x * u.x + step.y * u.y) / t_sq);
    if fixed.iter().all(|v| v.is_finite()) {
        fixed
    } else {
        step
    }
}

/// How well a scan pins the vehicle's position: the translation information with the heading
/// marginalised out (Schur complement `I_tt − I_tθ·I_θt / I_θθ`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Degeneracy {
    /// Smallest eigenvalue of that 2×2 information, m⁻² (already divided by σ²).
    pub min_eigenvalue_per_m2: f32,
    /// Its eigenvector: the least-observed direction of travel, unit, world frame. In a
    /// smooth tunnel with no landmark in view this is the tunnel's axis.
    pub direction_world: Point2,
    /// The same direction as a state increment `(x_m, y_m, theta_rad)` including the heading
    /// change that best compensates it (non-zero in a curved tunnel, where moving along the
    /// axis also turns the walls).
    pub state_direction: [f32; 3],
    /// Largest eigenvalue of the 2×2 information, m⁻².
    pub max_eigenvalue_per_m2: f32,
    /// True when the scan leaves a direction of the pose unobserved (fewer than three
    /// directions reach the matcher's threshold, see [`observable_subspace`]); the position
    /// along `direction_world` is then not observed.
    pub degenerate: bool,
}

/// The degeneracy of an information matrix, consistent with [`observable_subspace`]: the
/// match is degenerate when fewer than three scaled eigen-directions reach
/// `threshold_per_m2`, and the reported direction is then the translation part of the
/// weakest one. The eigenvalue reported is that of the translation information with the
/// heading marginalised (Schur complement `I_tt − I_tθ·I_θt / I_θθ`), in m⁻².
pub fn degeneracy(
    information: &Matrix3<f32>,
    threshold_per_m2: f32,
    rotation_scale_m: f32,
) -> Degeneracy {
    let i_tt = information.fixed_view::<2, 2>(0, 0).into_owned();
    let i_tth = information.fixed_view::<2, 1>(0, 2).into_owned();
    let i_thth = information.m33;
    let schur = if i_thth > f32::MIN_POSITIVE {
        i_tt - i_tth * i_tth.transpose() / i_thth
    } else {
        i_tt
    };
    let fallback = Degeneracy {
        min_eigenvalue_per_m2: 0.0,
        direction_world: Point2::new(1.0, 0.0),
        state_direction: [1.0, 0.0, 0.0],
        max_eigenvalue_per_m2: 0.0,
        degenerate: true,
    };
    if !schur.iter().all(|v| v.is_finite()) {
        return fallback;
    }
    let eig = SymmetricEigen::new(0.5 * (schur + schur.transpose()));
    let (l0, l1) = (eig.eigenvalues.x, eig.eigenvalues.y);
    let (lmin, lmax, v) = if l0 <= l1 {
        (l0, l1, eig.eigenvectors.column(0))
    } else {
        (l1, l0, eig.eigenvectors.column(1))
    };
    let mut d = Point2::new(v.x, v.y);
    let observed = observable_subspace(information, threshold_per_m2, rotation_scale_m);
    let degenerate = observed.rank < 3;
    let mut state = None;
    if degenerate {
        // The weakest direction outside the observed subspace, as a state increment.
        if let Some(u) = weakest_unobserved(information, &observed, rotation_scale_m) {
            let t = Point2::new(u.x, u.y);
            let tn = t.norm();
            if tn > 0.1 * u.norm() {
                d = t;
                state = Some(u / tn);
            }
        }
    }
    let n = d.norm();
    if !n.is_finite() || n <= 0.0 {
        return fallback;
    }
    d = d.scale(1.0 / n);
    // A canonical sign keeps reports stable from scan to scan.
    if d.x_m < 0.0 || (d.x_m == 0.0 && d.y_m < 0.0) {
        d = d.scale(-1.0);
    }
    // The heading change that goes with a move along d (zero in a straight tunnel): from the
    // unobserved eigenvector, else the one that best compensates the move.
    let dtheta = match state {
        Some(u) => {
            if u.x * d.x_m + u.y * d.y_m < 0.0 {
                -u.z
            } else {
                u.z
            }
        }
        None if i_thth > f32::MIN_POSITIVE => -(i_tth.x * d.x_m + i_tth.y * d.y_m) / i_thth,
        None => 0.0,
    };
    Degeneracy {
        min_eigenvalue_per_m2: math::max(lmin, 0.0),
        direction_world: d,
        state_direction: [d.x_m, d.y_m, dtheta],
        max_eigenvalue_per_m2: math::max(lmax, 0.0),
        degenerate,
    }
}

/// The unobserved scaled eigenvector with the smallest eigenvalue, unscaled to a state
/// increment `(x_m, y_m, theta_rad)`.
fn weakest_unobserved(
    information: &Matrix3<f32>,
    observed: &ObservableSubspace,
    rotation_scale_m: f32,
) -> Option<Vector3<f32>> {
    let s = scaling(rotation_scale_m);
    let scaled = s * information * s;
    let eig = SymmetricEigen::new(0.5 * (scaled + scaled.transpose()));
    let mut best: Option<(f32, Vector3<f32>)> = None;
    for (&lambda, v) in eig.eigenvalues.iter().zip(eig.eigenvectors.column_iter()) {
        // Unobserved: (nearly) orthogonal to every observed direction.
        let overlap = (observed.scaled_basis.transpose() * v).norm();
        if overlap < 0.5 && best.is_none_or(|(l, _)| lambda < l) {
            best = Some((lambda, s * v));
        }
    }
    best.map(|(_, u)| u)
}

/// The covariance `information⁻¹` restricted to the observed directions; along unobserved
/// ones the variance is `unobserved_variance` (m² or rad², a large stand-in for infinity).
pub fn covariance_from_information(
    information: &Matrix3<f32>,
    min_information: f32,
    rotation_scale_m: f32,
    unobserved_variance: f32,
) -> Matrix3<f32> {
    let s = scaling(rotation_scale_m);
    let scaled = s * information * s;
    let sym = 0.5 * (scaled + scaled.transpose());
    if !sym.iter().all(|v| v.is_finite()) {
        return Matrix3::identity() * unobserved_variance;
    }
    let eig = SymmetricEigen::new(sym);
    let mut cov_scaled = Matrix3::zeros();
    for (&lambda, v) in eig.eigenvalues.iter().zip(eig.eigenvectors.column_iter()) {
        let var = if lambda >= min_information && lambda > 0.0 {
            1.0 / lambda
        } else {
            unobserved_variance
        };
        cov_scaled += v * v.transpose() * var;
    }
    // Σ = S·Σ_scaled·S with S = diag(1, 1, 1/L) maps back to (m, m, rad).
    s * cov_scaled * s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Information of points on the two walls y = ±2.5 of a tunnel along x.
    fn straight_walls() -> NormalEquations {
        let mut eq = NormalEquations::default();
        for i in 0..40 {
            let x = i as f32 * 0.5;
            for (y, ny) in [(2.5f32, -1.0f32), (-2.5, 1.0)] {
                eq.add(
                    Point2::new(x, y),
                    Point2::ORIGIN,
                    Point2::new(0.0, ny),
                    0.0,
                    1.0,
                );
            }
        }
        eq
    }

    #[test]
    fn a_direction_is_dropped_from_the_subspace() {
        let o = observable_subspace(
            &Matrix3::from_diagonal(&Vector3::new(3.0, 1e4, 1e5)),
            1.0,
            10.0,
        );
        assert_eq!(o.rank, 3);
        let (k, lambda) = o.weakest().unwrap();
        assert!((lambda - 3.0).abs() < 1e-3);
        assert!((o.state_direction(k).x.abs() - 1.0).abs() < 1e-5);
        let d = o.without(k);
        assert_eq!(d.rank, 2);
        assert!(d.eigenvalues.iter().take(2).all(|&l| l > 100.0));
        assert_eq!(d.scaled_basis.column(2).norm(), 0.0);
        assert_eq!(d.without(2), d);
        assert_eq!(
            observable_subspace(&Matrix3::zeros(), 1.0, 10.0).weakest(),
            None
        );
    }

    #[test]
    fn straight_tunnel_is_degenerate_along_x() {
        let eq = straight_walls();
        let d = degeneracy(&(eq.information_points / 1e-4), 1e4, 10.0);
        assert!(d.degenerate);
        assert!(d.direction_world.x_m > 0.999, "{d:?}");
        assert!(d.max_eigenvalue_per_m2 > 1e5);
        let o = observable_subspace(&eq.information_points, 1.0, 10.0);
        assert_eq!(o.rank, 2);
        for k in 0..2 {
            assert!(o.scaled_basis[(0, k)].abs() < 1e-4);
        }
    }

    #[test]
    fn step_is_zero_along_unobserved_axis() {
        let mut eq = straight_walls();
        eq.gradient = Vector3::new(5.0, 1.0, 0.1);
        let step = truncated_step(&eq, 1.0, 10.0, 0.0);
        assert_eq!(step[0], 0.0);
        assert!(step[1] != 0.0);
    }

    #[test]
    fn full_rank_covariance_is_inverse() {
        let info = Matrix3::new(4.0, 1.0, 0.0, 1.0, 3.0, 0.5, 0.0, 0.5, 2.0);
        let cov = covariance_from_information(&info, 1e-6, 1.0, 1e6);
        let id = cov * info;
        assert!((id - Matrix3::identity()).abs().max() < 1e-4);
    }
}
