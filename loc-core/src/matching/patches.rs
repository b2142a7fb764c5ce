//! Wall roughness in the normal equations: scan points on the same stretch of wall share
//! that stretch's deviation from the smooth stored map.
//!
//! A shotcrete wall is not the design: it deviates from it by centimetres, smoothly along
//! the tunnel (a correlation length of about a metre). Points on one stretch of wall — and a
//! landmark mounted there — are all displaced by the same offset `w` along the wall's
//! normal, so they are not independent measurements: a thousand points on one metre of
//! wall say no more about the lateral position than that metre's `σ_w` allows. Treating
//! them as independent (the plain point-to-line model) makes a match believe the nearest,
//! densest stretch, and report a covariance many times too small.
//!
//! Model, per patch `k` (a stretch of `patch_length_m` along one side of the vehicle):
//! `r_i = J_i·δ + a_i·w_k + ε_i`, `ε_i ~ N(0, σ_r²/ω_i)`, `w_k ~ N(0, σ_w²)`, with `a_i =
//! n_i·m_k` (`n_i` the residual's normal, `m_k` the patch's wall normal). Eliminating `w_k`
//! (Sherman–Morrison on the patch's covariance `D + σ_w²·a·aᵀ`) gives, in units of one
//! point of variance `σ_r²`:
//!
//! `H = Σ ω JJᵀ − Σ_k u_k·u_kᵀ / (λ + c_k)`, `g = Σ ω J r − Σ_k u_k·h_k / (λ + c_k)`
//!
//! with `u_k = Σ ω a J`, `c_k = Σ ω a²`, `h_k = Σ ω a r` over the patch and `λ = σ_r²/σ_w²`.
//! It is exact for piecewise-constant offsets and costs `O(points + patches)`; the same
//! accumulation gives the Fisher information of a scan ([`super::fisher`]), the Cramér–Rao
//! yardstick of the localiser's accuracy.

use nalgebra::{Matrix3, Vector3};

use super::information::NormalEquations;
use crate::geometry::Point2;

/// Patches per side of the vehicle (bins of `patch_length_m` along its heading, wrapped:
/// with 2 m patches, 32 cover 64 m; stretches farther apart share a patch, which only
/// understates their information).
pub const PATCHES_PER_SIDE: usize = 32;

/// The wall-roughness model of a match.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RoughnessModel {
    /// 1σ deviation of the real walls from the stored map along their normal, metres
    /// (0: smooth walls, the plain point-to-line model).
    pub sigma_m: f32,
    /// Length of wall that shares one offset, metres (about twice the deviation's
    /// correlation length: a piecewise-constant offset of this length has the variance of
    /// the mean of an exponentially correlated one).
    pub patch_length_m: f32,
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
        patch_length_m: 2.0,
    };

    /// Shotcrete as host-sim's rough tunnels make it: 1 cm, correlated over a metre.
    pub const SHOTCRETE: Self = Self {
        sigma_m: 0.01,
        patch_length_m: 2.0,
    };

    /// `λ = σ_r² / σ_w²` for range noise `range_sigma_m`; `None` for smooth walls (or a
    /// model that is not finite and positive).
    fn lambda(&self, range_sigma_m: f32) -> Option<f32> {
        let ok = |v: f32| v.is_finite() && v > 0.0;
        (ok(self.sigma_m) && ok(range_sigma_m) && ok(self.patch_length_m)).then(|| {
            let r = range_sigma_m / self.sigma_m;
            r * r
        })
    }
}

#[derive(Debug, Clone, Copy, Default)]
struct Patch {
    /// `Σ ω·a·J`, `Σ ω·a²`, `Σ ω·a·r` with the IRLS weights…
    u_w: Vector3<f32>,
    c_w: f32,
    h_w: f32,
    /// …and unweighted (for the information).
    u: Vector3<f32>,
    c: f32,
}

/// The per-patch sums of one accumulation (fixed memory, on the caller's stack:
/// `2 × PATCHES_PER_SIDE` patches of 9 floats, 2.3 kB).
#[derive(Debug, Clone)]
pub struct PatchSums {
    patches: [Patch; 2 * PATCHES_PER_SIDE],
    /// Heading of the pose the points were placed with: patch normals and bins follow it.
    sin_cos: (f32, f32),
    inv_length: f32,
    lambda: f32,
}

impl PatchSums {
    /// Empty sums for points placed at heading `theta_rad` (world frame), with range noise
    /// `range_sigma_m` and the roughness `model`; `None` for smooth walls, where
    /// [`NormalEquations::add`] alone is the model (and nothing of this 2.3 kB is touched).
    pub fn new(model: &RoughnessModel, range_sigma_m: f32, theta_rad: f32) -> Option<Self> {
        let lambda = model.lambda(range_sigma_m)?;
        Some(Self {
            patches: [Patch::default(); 2 * PATCHES_PER_SIDE],
            sin_cos: crate::math::sin_cos(theta_rad),
            inv_length: 1.0 / model.patch_length_m,
            lambda,
        })
    }

    /// Adds one residual to `eq` and to its patch: vehicle-frame point `p` (which patch),
    /// world point `q`, pose translation `t`, unit normal `n`, residual `r` (m), IRLS
    /// weight `w` and `w_unit`, the weight of a residual within the noise (so `ω = w /
    /// w_unit` is 1 for inliers).
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
        let j = eq.add(q, t, n, r, w);
        let left = p.y_m >= 0.0;
        // The patch's wall normal in the world: the vehicle's left (or right) axis.
        let (s, c) = self.sin_cos;
        let m = if left {
            Point2::new(-s, c)
        } else {
            Point2::new(s, -c)
        };
        let a = n.dot(m);
        let bin = (crate::math::floor(p.x_m * self.inv_length) as i32)
            .rem_euclid(PATCHES_PER_SIDE as i32);
        let slot = bin as usize + if left { 0 } else { PATCHES_PER_SIDE };
        let omega = if w_unit > 0.0 { w / w_unit } else { 1.0 };
        if let Some(k) = self.patches.get_mut(slot) {
            k.u_w += j * (omega * a);
            k.c_w += omega * a * a;
            k.h_w += omega * a * r;
            k.u += j * a;
            k.c += a * a;
        }
    }

    /// Takes every patch's shared offset out of `eq` (see the module docs); `w_unit` as in
    /// [`PatchSums::add`].
    pub fn apply(&self, eq: &mut NormalEquations, w_unit: f32) {
        let lambda = self.lambda;
        let mut weighted = Matrix3::zeros();
        let mut gradient = Vector3::zeros();
        let mut information = Matrix3::zeros();
        for k in self.patches.iter().filter(|k| k.c > 0.0) {
            let dw = lambda + k.c_w;
            weighted += k.u_w * k.u_w.transpose() * (w_unit / dw);
            gradient += k.u_w * (w_unit * k.h_w / dw);
            information += k.u * k.u.transpose() * (1.0 / (lambda + k.c));
        }
        eq.weighted -= weighted;
        eq.gradient -= gradient;
        eq.information_points -= information;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` points on a straight left wall at y = 2 (vehicle at the origin, heading 0),
    /// spread over `length_m` from x = 0.
    fn wall(n: usize, length_m: f32, model: &RoughnessModel) -> NormalEquations {
        let mut eq = NormalEquations::default();
        let mut sums = PatchSums::new(model, 0.01, 0.0);
        for i in 0..n {
            let x = length_m * i as f32 / n as f32;
            let p = Point2::new(x, 2.0);
            let n = Point2::new(0.0, 1.0);
            match sums.as_mut() {
                Some(s) => s.add(&mut eq, p, p, Point2::ORIGIN, n, 0.0, 1.0, 1.0),
                None => {
                    eq.add(p, Point2::ORIGIN, n, 0.0, 1.0);
                }
            }
        }
        if let Some(s) = &sums {
            s.apply(&mut eq, 1.0);
        }
        eq
    }

    #[test]
    fn smooth_walls_leave_the_point_to_line_model_alone() {
        let eq = wall(100, 10.0, &RoughnessModel::SMOOTH);
        assert!((eq.information_points.m22 - 100.0).abs() < 1e-3);
    }

    #[test]
    fn points_on_one_patch_count_as_one_offset() {
        // σ_w = σ_r: λ = 1. 100 points on one 2 m patch: lateral information 100 − 100²/101
        // ≈ 0.99 points (the patch's offset is all they measure), not 100.
        let model = RoughnessModel {
            sigma_m: 0.01,
            patch_length_m: 2.0,
        };
        let one = wall(100, 1.9, &model);
        assert!(
            (one.information_points.m22 - 100.0 / 101.0).abs() < 1e-3,
            "{}",
            one.information_points.m22
        );
        // Spread over 10 patches: about ten offsets' worth.
        let ten = wall(100, 20.0, &model);
        let y = ten.information_points.m22;
        assert!((y - 10.0 * 10.0 / 11.0).abs() < 0.05, "{y}");
        // Along the wall (x) nothing was known and nothing is invented.
        assert!(ten.information_points.m11.abs() < 1e-4);
    }

    #[test]
    fn a_single_point_gets_range_and_roughness_variance() {
        // k = 1: information λ/(λ+1), i.e. variance σ_r² + σ_w².
        let model = RoughnessModel {
            sigma_m: 0.02,
            patch_length_m: 2.0,
        };
        let eq = wall(1, 0.0, &model);
        let expected = 1.0 / (1.0 + 4.0);
        assert!((eq.information_points.m22 - expected).abs() < 1e-5);
    }
}
