//! Putting a landmark profile on a wall: landmark frame → world frame.

use crate::geometry::Point2;

use super::{Profile, MAX_PROFILE_VERTICES};

/// Where and how a landmark sits on a wall, world frame.
///
/// A landmark point `(u, v)` maps to `anchor + u · tangent + (v + offset_m) · inward_normal`.
/// On a curved wall the landmark is a rigid plate laid along the tangent at its anchor: for
/// a 1.5 m plate on a 50 m radius the wall departs from the plate by at most 6 mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallFrame {
    /// The landmark's centre on the wall surface, world frame, metres.
    pub anchor: Point2,
    /// Unit vector along the wall in the direction of increasing arc length.
    pub tangent: Point2,
    /// Unit vector normal to the wall, pointing into the tunnel.
    pub inward_normal: Point2,
}

impl WallFrame {
    /// World point of landmark-frame point `p` (`x_m` = u, `y_m` = v), standing off the wall
    /// by `offset_m` (positive into the tunnel).
    #[inline]
    pub fn to_world(&self, p: Point2, offset_m: f32) -> Point2 {
        self.anchor
            .add(self.tangent.scale(p.x_m))
            .add(self.inward_normal.scale(p.y_m + offset_m))
    }

    /// Landmark-frame point `(u, v)` of world point `p` (inverse of [`WallFrame::to_world`]
    /// with zero offset).
    #[inline]
    pub fn to_landmark(&self, p: Point2) -> Point2 {
        let d = p.sub(self.anchor);
        Point2::new(d.dot(self.tangent), d.dot(self.inward_normal))
    }

    /// The profile's vertices in the world frame.
    pub fn place(
        &self,
        profile: &Profile,
        offset_m: f32,
    ) -> heapless::Vec<Point2, MAX_PROFILE_VERTICES> {
        profile
            .vertices()
            .iter()
            .map(|&p| self.to_world(p, offset_m))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmark::{Genome, LandmarkModel};

    #[test]
    fn triangle_on_a_left_wall_points_into_the_tunnel() {
        // Left wall along +x at y = 2.5; the tunnel is at smaller y.
        let frame = WallFrame {
            anchor: Point2::new(10.0, 2.5),
            tangent: Point2::new(1.0, 0.0),
            inward_normal: Point2::new(0.0, -1.0),
        };
        let g = Genome::paper_default(LandmarkModel::P1Triangle);
        let p = Profile::new(LandmarkModel::P1Triangle, &g);
        let w = frame.place(&p, 0.0);
        assert_eq!(w[0], Point2::new(9.75, 2.5));
        assert_eq!(w[1], Point2::new(10.0, 2.25));
        assert_eq!(w[2], Point2::new(10.25, 2.5));
        assert_eq!(frame.to_landmark(w[1]), Point2::new(0.0, 0.25));
        let off = frame.place(&p, 0.05);
        assert!((off[0].y_m - 2.45).abs() < 1e-6);
    }
}
