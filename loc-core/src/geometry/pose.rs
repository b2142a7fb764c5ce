//! SE(2) poses: a position and a heading.

use serde::{Deserialize, Serialize};

use super::Point2;
use crate::math;

/// A rigid transform in the plane (an element of SE(2)).
///
/// As a pose of frame B in frame A it maps B coordinates to A coordinates:
/// `p_A = R(theta_rad) · p_B + (x_m, y_m)`. A vehicle pose is the vehicle frame in the
/// world frame; a sensor mounting pose is the sensor frame in the vehicle frame.
///
/// Invariant kept by the constructors and operations: `theta_rad` is wrapped into `(-π, π]`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose2 {
    /// Translation x, metres.
    pub x_m: f32,
    /// Translation y, metres.
    pub y_m: f32,
    /// Rotation (heading), radians in `(-π, π]`.
    pub theta_rad: f32,
}

impl Pose2 {
    /// The identity transform.
    pub const IDENTITY: Pose2 = Pose2 {
        x_m: 0.0,
        y_m: 0.0,
        theta_rad: 0.0,
    };

    /// A pose from translation (metres) and heading (radians, wrapped into `(-π, π]`).
    #[inline]
    pub fn new(x_m: f32, y_m: f32, theta_rad: f32) -> Self {
        Self {
            x_m,
            y_m,
            theta_rad: math::wrap_angle(theta_rad),
        }
    }

    /// The translation as a point.
    #[inline]
    pub fn translation(&self) -> Point2 {
        Point2::new(self.x_m, self.y_m)
    }

    /// This pose with its rotation's sine and cosine evaluated once: use it to map many
    /// points (per-point loops must not recompute trigonometry).
    #[inline]
    pub fn transform(&self) -> PoseTransform {
        let (sin, cos) = math::sin_cos(self.theta_rad);
        PoseTransform {
            cos,
            sin,
            x_m: self.x_m,
            y_m: self.y_m,
        }
    }

    /// Maps a point from this pose's child frame into its parent frame (one `sin_cos`; for
    /// many points use [`Pose2::transform`]).
    #[inline]
    pub fn transform_point(&self, p: Point2) -> Point2 {
        self.transform().apply(p)
    }

    /// Rotates a vector (no translation) from the child frame into the parent frame.
    #[inline]
    pub fn rotate_vector(&self, v: Point2) -> Point2 {
        self.transform().rotate(v)
    }

    /// Maps a point from the parent frame into this pose's child frame.
    #[inline]
    pub fn inverse_transform_point(&self, p: Point2) -> Point2 {
        self.transform().apply_inverse(p)
    }

    /// Composition `self ∘ other`: `other` expressed in `self`'s child frame, result in
    /// `self`'s parent frame (e.g. world←vehicle ∘ vehicle←sensor = world←sensor).
    #[inline]
    pub fn compose(&self, other: &Pose2) -> Pose2 {
        let t = self.transform_point(other.translation());
        Pose2::new(t.x_m, t.y_m, self.theta_rad + other.theta_rad)
    }

    /// The inverse transform.
    #[inline]
    pub fn inverse(&self) -> Pose2 {
        let (s, c) = math::sin_cos(self.theta_rad);
        Pose2::new(
            -(c * self.x_m + s * self.y_m),
            s * self.x_m - c * self.y_m,
            -self.theta_rad,
        )
    }

    /// The relative transform `self⁻¹ ∘ other` (the motion from `self` to `other`, expressed
    /// in `self`'s frame).
    #[inline]
    pub fn between(&self, other: &Pose2) -> Pose2 {
        self.inverse().compose(other)
    }

    /// True when every component is finite.
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.x_m.is_finite() && self.y_m.is_finite() && self.theta_rad.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Pose2, b: Pose2) -> bool {
        (a.x_m - b.x_m).abs() < 1e-5
            && (a.y_m - b.y_m).abs() < 1e-5
            && math::wrap_angle(a.theta_rad - b.theta_rad).abs() < 1e-5
    }

    #[test]
    fn compose_inverse_is_identity() {
        let a = Pose2::new(3.0, -2.0, 0.7);
        assert!(close(a.compose(&a.inverse()), Pose2::IDENTITY));
        assert!(close(a.inverse().compose(&a), Pose2::IDENTITY));
        let b = Pose2::new(-1.0, 0.5, -2.9);
        assert!(close(a.compose(&a.between(&b)), b));
    }

    #[test]
    fn point_round_trip() {
        let a = Pose2::new(1.0, 2.0, 1.0);
        let p = Point2::new(-0.3, 4.0);
        let q = a.inverse_transform_point(a.transform_point(p));
        assert!((p.x_m - q.x_m).abs() < 1e-5 && (p.y_m - q.y_m).abs() < 1e-5);
    }
}

/// A [`Pose2`] prepared for mapping many points: the rotation's cosine and sine are
/// evaluated once. Same frame convention as the pose it came from
/// (`p_parent = R · p_child + t`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseTransform {
    /// cos(theta).
    pub cos: f32,
    /// sin(theta).
    pub sin: f32,
    /// Translation x, metres.
    pub x_m: f32,
    /// Translation y, metres.
    pub y_m: f32,
}

impl PoseTransform {
    /// Maps a point from the child frame into the parent frame.
    #[inline]
    pub fn apply(&self, p: Point2) -> Point2 {
        Point2::new(
            self.cos * p.x_m - self.sin * p.y_m + self.x_m,
            self.sin * p.x_m + self.cos * p.y_m + self.y_m,
        )
    }

    /// Rotates a vector from the child frame into the parent frame (no translation).
    #[inline]
    pub fn rotate(&self, v: Point2) -> Point2 {
        Point2::new(
            self.cos * v.x_m - self.sin * v.y_m,
            self.sin * v.x_m + self.cos * v.y_m,
        )
    }

    /// Rotates a vector from the parent frame into the child frame (no translation).
    #[inline]
    pub fn rotate_inverse(&self, v: Point2) -> Point2 {
        Point2::new(
            self.cos * v.x_m + self.sin * v.y_m,
            -self.sin * v.x_m + self.cos * v.y_m,
        )
    }

    /// Maps a point from the parent frame into the child frame.
    #[inline]
    pub fn apply_inverse(&self, p: Point2) -> Point2 {
        let dx = p.x_m - self.x_m;
        let dy = p.y_m - self.y_m;
        Point2::new(
            self.cos * dx + self.sin * dy,
            -self.sin * dx + self.cos * dy,
        )
    }
}
