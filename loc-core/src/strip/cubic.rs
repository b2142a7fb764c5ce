//! Cubic wall polynomials `y = f(x)` in the vehicle frame: exact fits through four points
//! (RANSAC hypotheses) and weighted least-squares fits (refit on the inliers).
//!
//! `x` is shifted and scaled to `u = (x − x_offset_m) / x_scale_m ∈ [−1, 1]` over the wall's
//! extent before any power is taken: the monomial normal equations on `[−1, 1]` have a
//! condition number of a few hundred, against ~10¹⁴ for raw metres out to 40 m, which f32
//! could not solve.

use nalgebra::{SMatrix, SVector};

use crate::geometry::Point2;
use crate::math;

/// Normalisation of `x` for one wall: `u = (x − offset_m) / scale_m`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct XScaling {
    /// Centre of the wall's x extent, metres (vehicle frame).
    pub offset_m: f32,
    /// Half the wall's x extent, metres; at least [`XScaling::MIN_SCALE_M`].
    pub scale_m: f32,
    /// `1 / scale_m`, 1/m (a multiplication is cheaper than a division on every point).
    pub inv_scale_per_m: f32,
}

impl XScaling {
    /// Smallest half-extent used, metres (a wall seen over a few centimetres is not a wall).
    pub const MIN_SCALE_M: f32 = 0.5;

    /// The scaling that maps `[min_x_m, max_x_m]` onto `[−1, 1]`.
    pub fn spanning(min_x_m: f32, max_x_m: f32) -> Self {
        let half = 0.5 * (max_x_m - min_x_m);
        let scale_m = if half.is_finite() && half > Self::MIN_SCALE_M {
            half
        } else {
            Self::MIN_SCALE_M
        };
        let offset_m = 0.5 * (max_x_m + min_x_m);
        Self {
            offset_m: if offset_m.is_finite() { offset_m } else { 0.0 },
            scale_m,
            inv_scale_per_m: 1.0 / scale_m,
        }
    }

    /// The normalised abscissa of `x_m`.
    #[inline]
    pub fn normalise(&self, x_m: f32) -> f32 {
        (x_m - self.offset_m) * self.inv_scale_per_m
    }
}

/// A wall `y = c0 + c1·u + c2·u² + c3·u³` with `u` the normalised x (see [`XScaling`]),
/// vehicle frame, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cubic {
    /// Coefficients `c0..c3` in the normalised abscissa, metres.
    pub coefficients_m: [f32; 4],
    /// The abscissa normalisation the coefficients refer to.
    pub scaling: XScaling,
}

impl Cubic {
    /// `y` on the wall at `x_m`, metres.
    #[inline]
    pub fn eval(&self, x_m: f32) -> f32 {
        let u = self.scaling.normalise(x_m);
        let [c0, c1, c2, c3] = self.coefficients_m;
        c0 + u * (c1 + u * (c2 + u * c3))
    }

    /// Slope `dy/dx` at `x_m` (dimensionless).
    #[inline]
    pub fn slope(&self, x_m: f32) -> f32 {
        let u = self.scaling.normalise(x_m);
        let [_, c1, c2, c3] = self.coefficients_m;
        (c1 + u * (2.0 * c2 + u * 3.0 * c3)) * self.scaling.inv_scale_per_m
    }

    /// Signed distance from the wall to `p`, metres, measured along the wall's normal
    /// (positive for `y` above the curve), first-order: `(y − f(x)) / √(1 + f′(x)²)`.
    #[inline]
    pub fn signed_distance_m(&self, p: Point2) -> f32 {
        let s = self.slope(p.x_m);
        (p.y_m - self.eval(p.x_m)) / math::sqrt(1.0 + s * s)
    }

    /// Vertical residual `y − f(x)` and slope `f′(x)` at `p` in one evaluation.
    #[inline]
    pub fn residual_and_slope(&self, p: Point2) -> (f32, f32) {
        let u = self.scaling.normalise(p.x_m);
        let [c0, c1, c2, c3] = self.coefficients_m;
        let y = c0 + u * (c1 + u * (c2 + u * c3));
        let slope = (c1 + u * (2.0 * c2 + u * 3.0 * c3)) * self.scaling.inv_scale_per_m;
        (p.y_m - y, slope)
    }

    /// True when `p` lies within `tol_m` of the wall along its normal (first order), without
    /// a square root: `r² ≤ tol²·(1 + f′²)`.
    #[inline]
    pub fn within_m(&self, p: Point2, tol_m: f32) -> bool {
        let (r, s) = self.residual_and_slope(p);
        r * r <= tol_m * tol_m * (1.0 + s * s)
    }

    /// The unit tangent of the wall at `x_m` pointing towards increasing x (vehicle frame).
    pub fn tangent(&self, x_m: f32) -> Point2 {
        let s = self.slope(x_m);
        let n = math::sqrt(1.0 + s * s);
        Point2::new(1.0 / n, s / n)
    }

    /// The cubic through four points (exact interpolation), or `None` when two of them share
    /// an abscissa (singular Vandermonde system) or the result is not finite.
    pub fn through(points: [Point2; 4], scaling: XScaling) -> Option<Cubic> {
        let mut a = SMatrix::<f32, 4, 4>::zeros();
        let mut b = SVector::<f32, 4>::zeros();
        for (row, p) in points.iter().enumerate() {
            let u = scaling.normalise(p.x_m);
            let mut pow = 1.0;
            for col in 0..4 {
                if let Some(e) = a.get_mut((row, col)) {
                    *e = pow;
                }
                pow *= u;
            }
            if let Some(e) = b.get_mut(row) {
                *e = p.y_m;
            }
        }
        let c = a.lu().solve(&b)?;
        Self::from_solution(&c, scaling)
    }

    fn from_solution(c: &SVector<f32, 4>, scaling: XScaling) -> Option<Cubic> {
        let coefficients_m = [c[0], c[1], c[2], c[3]];
        if coefficients_m.iter().all(|v| v.is_finite()) {
            Some(Cubic {
                coefficients_m,
                scaling,
            })
        } else {
            None
        }
    }
}

/// Running sums for a least-squares polynomial fit of degree ≤ 3: `Σ uᵏ` (k = 0..6) and
/// `Σ y·uᵏ` (k = 0..3). O(1) memory; adding a point costs a dozen multiplications.
#[derive(Debug, Clone, Copy)]
pub struct LeastSquares {
    scaling: XScaling,
    sum_u_pow: [f32; 7],
    sum_y_u_pow: [f32; 4],
    count: u32,
}

impl LeastSquares {
    /// Empty sums for abscissae normalised by `scaling`.
    pub fn new(scaling: XScaling) -> Self {
        Self {
            scaling,
            sum_u_pow: [0.0; 7],
            sum_y_u_pow: [0.0; 4],
            count: 0,
        }
    }

    /// Adds one point (vehicle frame) with unit weight. Non-finite points are ignored.
    pub fn add(&mut self, p: Point2) {
        self.add_weighted(p, 1.0);
    }

    /// Adds one point (vehicle frame) with weight `w > 0`. Non-finite points or weights
    /// are ignored.
    #[inline]
    pub fn add_weighted(&mut self, p: Point2, w: f32) {
        if !p.is_finite() || !w.is_finite() || w <= 0.0 {
            return;
        }
        let u = self.scaling.normalise(p.x_m);
        let mut pow = w;
        for (k, s) in self.sum_u_pow.iter_mut().enumerate() {
            *s += pow;
            if let Some(sy) = self.sum_y_u_pow.get_mut(k) {
                *sy += p.y_m * pow;
            }
            pow *= u;
        }
        self.count = self.count.saturating_add(1);
    }

    /// Points added so far.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// The least-squares polynomial of degree `min(3, count − 1)` (a short wall gets a line
    /// or a parabola rather than an unconstrained cubic), or `None` for no points or a
    /// singular system (all points at one abscissa).
    pub fn solve(&self) -> Option<Cubic> {
        let degree = match self.count {
            0 => return None,
            1..=3 => (self.count - 1) as usize,
            _ => 3,
        };
        let mut a = SMatrix::<f32, 4, 4>::identity();
        let mut b = SVector::<f32, 4>::zeros();
        for row in 0..=degree {
            for col in 0..=degree {
                if let (Some(e), Some(&s)) = (a.get_mut((row, col)), self.sum_u_pow.get(row + col))
                {
                    *e = s;
                }
            }
            if let (Some(e), Some(&s)) = (b.get_mut(row), self.sum_y_u_pow.get(row)) {
                *e = s;
            }
        }
        let c = a.cholesky()?.solve(&b);
        Cubic::from_solution(&c, self.scaling)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn truth(x: f32) -> f32 {
        2.5 - 0.05 * x + 0.004 * x * x - 0.0001 * x * x * x
    }

    #[test]
    fn exact_fit_reproduces_cubic() {
        let s = XScaling::spanning(0.0, 30.0);
        let pts = [0.5f32, 8.0, 17.0, 29.0].map(|x| Point2::new(x, truth(x)));
        let c = Cubic::through(pts, s).unwrap();
        for x in [1.0f32, 12.0, 25.0] {
            assert!((c.eval(x) - truth(x)).abs() < 1e-4, "{x}");
        }
        assert!(Cubic::through([Point2::new(1.0, 0.0); 4], s).is_none());
    }

    #[test]
    fn least_squares_recovers_cubic_and_slope() {
        let s = XScaling::spanning(0.0, 40.0);
        let mut ls = LeastSquares::new(s);
        for i in 0..400 {
            let x = i as f32 * 0.1;
            ls.add(Point2::new(x, truth(x)));
        }
        let c = ls.solve().unwrap();
        for x in [0.0f32, 10.0, 39.0] {
            assert!((c.eval(x) - truth(x)).abs() < 2e-3, "{x}: {}", c.eval(x));
            let slope = -0.05 + 0.008 * x - 0.0003 * x * x;
            assert!((c.slope(x) - slope).abs() < 1e-3);
        }
        let d = c.signed_distance_m(Point2::new(10.0, truth(10.0) + 0.1));
        assert!((d - 0.1).abs() < 2e-3);
    }

    #[test]
    fn few_points_fall_back_to_lower_degree() {
        let s = XScaling::spanning(0.0, 2.0);
        let mut ls = LeastSquares::new(s);
        assert!(ls.solve().is_none());
        ls.add(Point2::new(0.0, 1.0));
        ls.add(Point2::new(2.0, 2.0));
        let c = ls.solve().unwrap();
        assert!((c.eval(1.0) - 1.5).abs() < 1e-5);
        ls.add(Point2::new(f32::NAN, 0.0));
        assert_eq!(ls.count(), 2);
    }
}
