//! A 2D point (or vector) in metres.

use serde::{Deserialize, Serialize};

use crate::math;

/// A point or a vector in the plane, metres. The frame is given by the API that holds it.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Point2 {
    /// x coordinate, metres.
    pub x_m: f32,
    /// y coordinate, metres.
    pub y_m: f32,
}

impl Point2 {
    /// The origin.
    pub const ORIGIN: Point2 = Point2 { x_m: 0.0, y_m: 0.0 };

    /// A point from its coordinates in metres.
    #[inline]
    pub const fn new(x_m: f32, y_m: f32) -> Self {
        Self { x_m, y_m }
    }

    /// The point at `range_m` along a beam at `angle_rad` from the origin (polar to Cartesian).
    #[inline]
    pub fn from_polar(range_m: f32, angle_rad: f32) -> Self {
        let (s, c) = math::sin_cos(angle_rad);
        Self::new(range_m * c, range_m * s)
    }

    /// Component-wise sum.
    #[inline]
    // Named methods on purpose (no operator traits): explicit in the hot loops.
    #[allow(clippy::should_implement_trait)]
    pub fn add(self, o: Point2) -> Point2 {
        Point2::new(self.x_m + o.x_m, self.y_m + o.y_m)
    }

    /// Component-wise difference `self - o`.
    #[inline]
    #[allow(clippy::should_implement_trait)]
    pub fn sub(self, o: Point2) -> Point2 {
        Point2::new(self.x_m - o.x_m, self.y_m - o.y_m)
    }

    /// Scaled by `k`.
    #[inline]
    pub fn scale(self, k: f32) -> Point2 {
        Point2::new(self.x_m * k, self.y_m * k)
    }

    /// Dot product, m².
    #[inline]
    pub fn dot(self, o: Point2) -> f32 {
        self.x_m * o.x_m + self.y_m * o.y_m
    }

    /// z component of the cross product `self × o`, m².
    #[inline]
    pub fn cross(self, o: Point2) -> f32 {
        self.x_m * o.y_m - self.y_m * o.x_m
    }

    /// Squared length, m².
    #[inline]
    pub fn norm_sq(self) -> f32 {
        self.dot(self)
    }

    /// Length, metres.
    #[inline]
    pub fn norm(self) -> f32 {
        math::sqrt(self.norm_sq())
    }

    /// Squared distance to `o`, m².
    #[inline]
    pub fn dist_sq(self, o: Point2) -> f32 {
        self.sub(o).norm_sq()
    }

    /// Distance to `o`, metres.
    #[inline]
    pub fn dist(self, o: Point2) -> f32 {
        math::sqrt(self.dist_sq(o))
    }

    /// The vector rotated by +90° (counter-clockwise).
    #[inline]
    pub fn perp(self) -> Point2 {
        Point2::new(-self.y_m, self.x_m)
    }

    /// True when both coordinates are finite.
    #[inline]
    pub fn is_finite(self) -> bool {
        self.x_m.is_finite() && self.y_m.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polar_and_products() {
        let p = Point2::from_polar(2.0, core::f32::consts::FRAC_PI_2);
        assert!(p.x_m.abs() < 1e-6 && (p.y_m - 2.0).abs() < 1e-6);
        let a = Point2::new(1.0, 0.0);
        assert_eq!(a.cross(Point2::new(0.0, 1.0)), 1.0);
        assert_eq!(a.perp(), Point2::new(0.0, 1.0));
        assert_eq!(Point2::new(3.0, 4.0).norm(), 5.0);
    }
}
