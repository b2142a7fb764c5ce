//! SE(2) for the survey's own solver ([`super::solver_own`]): the exponential and logarithm,
//! their right Jacobian and the adjoint, and the survey's two residuals (between and prior)
//! with their analytic Jacobians.
//!
//! Tangent order `(θ rad, x m, y m)` and right perturbation `T ⊕ τ = T ∘ Exp(τ)`, as factrs
//! (and the survey's covariances). Residuals: between `r = Log(z⁻¹ ∘ a⁻¹ ∘ b)`, prior
//! `r = Log(z⁻¹ ∘ x)` — factrs writes the inverses (`Log(b⁻¹ ∘ a ∘ z)`, `Log(x⁻¹ ∘ z)`),
//! which are `−r`: the same squared Mahalanobis length.

use nalgebra::{Matrix3, Vector3};

use crate::vehicle::SimPose;

/// A tangent vector `(θ rad, x m, y m)`.
pub(super) type Tangent = Vector3<f64>;

/// Below this |θ| (rad) the series of `sin θ/θ` and friends are used (their next terms are
/// below 1e-18 there; the closed forms lose digits to cancellation).
const SMALL_ANGLE_RAD: f64 = 1e-3;

/// The angle wrapped into `(−π, π]`, radians.
fn wrap(theta_rad: f64) -> f64 {
    theta_rad.sin().atan2(theta_rad.cos())
}

/// `(sin θ/θ, (1 − cos θ)/θ)`: the entries of SE(2)'s `V(θ)`.
fn v_entries(theta: f64) -> (f64, f64) {
    if theta.abs() < SMALL_ANGLE_RAD {
        let t2 = theta * theta;
        (
            1.0 - t2 / 6.0 + t2 * t2 / 120.0,
            theta * (0.5 - t2 / 24.0 + t2 * t2 / 720.0),
        )
    } else {
        (theta.sin() / theta, (1.0 - theta.cos()) / theta)
    }
}

/// `((θ − sin θ)/θ², (1 − cos θ)/θ²)`: the right Jacobian's translation column.
fn jr_entries(theta: f64) -> (f64, f64) {
    if theta.abs() < SMALL_ANGLE_RAD {
        let t2 = theta * theta;
        (
            theta * (1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0),
            0.5 - t2 / 24.0 + t2 * t2 / 720.0,
        )
    } else {
        let t2 = theta * theta;
        ((theta - theta.sin()) / t2, (1.0 - theta.cos()) / t2)
    }
}

/// `Exp(τ)`.
pub(super) fn exp(t: &Tangent) -> SimPose {
    let (a, b) = v_entries(t[0]);
    SimPose::new(a * t[1] - b * t[2], b * t[1] + a * t[2], t[0])
}

/// `Log(T)`, the angle wrapped into `(−π, π]`.
pub(super) fn log(p: SimPose) -> Tangent {
    let theta = wrap(p.theta_rad);
    let (a, b) = v_entries(theta);
    let d = a * a + b * b;
    Vector3::new(
        theta,
        (a * p.x_m + b * p.y_m) / d,
        (-b * p.x_m + a * p.y_m) / d,
    )
}

/// `T ⊕ τ = T ∘ Exp(τ)`.
pub(super) fn plus(p: SimPose, t: &Tangent) -> SimPose {
    p.compose(exp(t))
}

/// The inverse of the right Jacobian of `Exp` at `τ`: `Log(Exp(τ) ∘ Exp(δ)) ≈ τ + Jr⁻¹(τ) δ`.
pub(super) fn right_jacobian_inverse(t: &Tangent) -> Matrix3<f64> {
    // Jr = [[1, 0, 0], [u, a, b], [v, −b, a]] (Solà et al., "A micro Lie theory", (163),
    // reordered to (θ, x, y)); its inverse has the 2×2 block inverted and
    // −M⁻¹ (u, v) in the first column.
    let (a, b) = v_entries(t[0]);
    let (p, q) = jr_entries(t[0]);
    let (u, v) = (t[1] * p - t[2] * q, t[1] * q + t[2] * p);
    let d = a * a + b * b;
    let (ia, ib) = (a / d, b / d);
    // M⁻¹ = [[ia, −ib], [ib, ia]].
    Matrix3::new(
        1.0,
        0.0,
        0.0,
        -(ia * u - ib * v),
        ia,
        -ib,
        -(ib * u + ia * v),
        ib,
        ia,
    )
}

/// The adjoint of `T`: `T ∘ Exp(τ) = Exp(Ad(T) τ) ∘ T`.
pub(super) fn adjoint(p: SimPose) -> Matrix3<f64> {
    let (s, c) = p.theta_rad.sin_cos();
    Matrix3::new(1.0, 0.0, 0.0, p.y_m, c, -s, -p.x_m, s, c)
}

/// A between factor's residual `Log(z⁻¹ ∘ a⁻¹ ∘ b)` and its Jacobians with respect to `a`
/// and `b`.
pub(super) fn between(a: SimPose, b: SimPose, z: SimPose) -> (Tangent, Matrix3<f64>, Matrix3<f64>) {
    let r = log(z.between(a.between(b)));
    let jb = right_jacobian_inverse(&r);
    let ja = -jb * adjoint(b.between(a));
    (r, ja, jb)
}

/// A between factor's residual alone.
pub(super) fn between_residual(a: SimPose, b: SimPose, z: SimPose) -> Tangent {
    log(z.between(a.between(b)))
}

/// A prior's residual `Log(z⁻¹ ∘ x)` and its Jacobian with respect to `x`.
pub(super) fn prior(x: SimPose, z: SimPose) -> (Tangent, Matrix3<f64>) {
    let r = log(z.between(x));
    (r, right_jacobian_inverse(&r))
}

/// A prior's residual alone.
pub(super) fn prior_residual(x: SimPose, z: SimPose) -> Tangent {
    log(z.between(x))
}

/// The Huber loss and its IRLS weight at the squared Mahalanobis length `d2` (threshold `k`
/// on the length): `(d²/2, 1)` within, `(k(d − k/2), k/d)` beyond.
pub(super) fn huber(d2: f64, k: f64) -> (f64, f64) {
    let d = d2.sqrt();
    if d <= k {
        (d2 / 2.0, 1.0)
    } else {
        (k * (d - k / 2.0), k / d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &Matrix3<f64>, b: &Matrix3<f64>, tol: f64) -> bool {
        (a - b).abs().max() < tol
    }

    fn tangent_of(p: SimPose) -> Tangent {
        Vector3::new(p.theta_rad, p.x_m, p.y_m)
    }

    const POSES: [(f64, f64, f64); 4] = [
        (0.3, -1.2, 0.7),
        (2.0, 0.5, -2.9),
        (-0.4, 0.1, 1e-8),
        (5.0, 3.0, -0.02),
    ];

    #[test]
    fn exp_and_log_are_inverse_and_agree_with_the_group() {
        for (x, y, t) in POSES {
            let p = SimPose::new(x, y, t);
            let q = exp(&log(p));
            let d = p.between(q);
            assert!(d.x_m.hypot(d.y_m) < 1e-12 && wrap(d.theta_rad).abs() < 1e-12);
            let tau = tangent_of(p) * 0.5;
            assert!((log(exp(&tau)) - tau).norm() < 1e-12);
        }
    }

    /// Central differences of `f` at `x` along the right perturbation.
    fn numeric(f: impl Fn(SimPose) -> Tangent, x: SimPose) -> Matrix3<f64> {
        let h = 1e-6;
        let mut j = Matrix3::zeros();
        for i in 0..3 {
            let mut d = Tangent::zeros();
            d[i] = h;
            let col = (f(plus(x, &d)) - f(plus(x, &-d))) / (2.0 * h);
            j.set_column(i, &col);
        }
        j
    }

    #[test]
    fn the_jacobians_agree_with_finite_differences() {
        for (i, (x, y, t)) in POSES.into_iter().enumerate() {
            let a = SimPose::new(x, y, t);
            let (bx, by, bt) = POSES[(i + 1) % POSES.len()];
            let b = SimPose::new(bx, by, bt);
            // A measurement near the truth and one far off (a Huber outlier).
            for z in [
                a.between(b).compose(SimPose::new(0.01, -0.02, 0.03)),
                SimPose::new(1.0, 2.0, 2.5),
            ] {
                let (_, ja, jb) = between(a, b, z);
                assert!(
                    close(&ja, &numeric(|a| between_residual(a, b, z), a), 1e-6),
                    "{ja}"
                );
                assert!(
                    close(&jb, &numeric(|b| between_residual(a, b, z), b), 1e-6),
                    "{jb}"
                );
                let (_, jx) = prior(b, z);
                assert!(
                    close(&jx, &numeric(|x| prior_residual(x, z), b), 1e-6),
                    "{jx}"
                );
            }
            // The adjoint moves a right perturbation to the left.
            let tau = Vector3::new(0.2, -0.3, 0.5);
            let left = exp(&(adjoint(a) * tau)).compose(a);
            let d = plus(a, &tau).between(left);
            assert!(d.x_m.hypot(d.y_m) < 1e-12 && wrap(d.theta_rad).abs() < 1e-12);
        }
    }

    #[test]
    fn huber_is_quadratic_within_and_linear_beyond_its_threshold() {
        assert_eq!(huber(1.0, 1.345), (0.5, 1.0));
        let (cost, w) = huber(9.0, 1.345);
        assert!((cost - 1.345 * (3.0 - 1.345 / 2.0)).abs() < 1e-12);
        assert!((w - 1.345 / 3.0).abs() < 1e-12);
    }
}
