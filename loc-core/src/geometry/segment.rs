//! Line segments and point-to-segment projection.

use serde::{Deserialize, Serialize};

use super::Point2;

/// A straight segment from `a` to `b`, metres.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Segment {
    /// Start point.
    pub a: Point2,
    /// End point.
    pub b: Point2,
}

/// Where a point projects onto a segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentProjection {
    /// The closest point of the segment, metres.
    pub closest: Point2,
    /// Distance from the query point to `closest`, metres.
    pub distance_m: f32,
    /// Position of `closest` along the segment: 0 at `a`, 1 at `b` (clamped to `[0, 1]`).
    pub t: f32,
    /// Unit normal of the segment's supporting line, `(b - a)` rotated by +90°; for a
    /// zero-length segment, the unit vector from `closest` to the query point (or +x when
    /// they coincide).
    pub normal: Point2,
}

impl Segment {
    /// A segment from `a` to `b`.
    #[inline]
    pub const fn new(a: Point2, b: Point2) -> Self {
        Self { a, b }
    }

    /// Length, metres.
    #[inline]
    pub fn length(&self) -> f32 {
        self.a.dist(self.b)
    }

    /// The point of the segment closest to `p`, with distance and line normal.
    pub fn project(&self, p: Point2) -> SegmentProjection {
        let d = self.b.sub(self.a);
        let len_sq = d.norm_sq();
        if len_sq <= f32::EPSILON {
            let v = p.sub(self.a);
            let n = v.norm();
            let normal = if n > 0.0 {
                v.scale(1.0 / n)
            } else {
                Point2::new(1.0, 0.0)
            };
            return SegmentProjection {
                closest: self.a,
                distance_m: n,
                t: 0.0,
                normal,
            };
        }
        let w = p.sub(self.a);
        let t_line = w.dot(d) / len_sq;
        let t = t_line.clamp(0.0, 1.0);
        let closest = self.a.add(d.scale(t));
        let normal = d.perp().scale(1.0 / crate::math::sqrt(len_sq));
        // Inside the segment the distance is the one to its line: no second square root.
        let distance_m = if t_line > 0.0 && t_line < 1.0 {
            crate::math::abs(normal.dot(w))
        } else {
            p.dist(closest)
        };
        SegmentProjection {
            closest,
            distance_m,
            t,
            normal,
        }
    }
}

impl Segment {
    /// [`Segment::project`] given the segment's unit line normal (`(b − a)` rotated by +90°,
    /// normalised, as an earlier projection returned it): when `p` projects inside the
    /// segment the distance is `|normal · (p − a)|` and no square root is taken (the common
    /// case when a matcher re-projects points onto the segments it associated them with);
    /// at an end or on a degenerate segment it is `project` itself.
    #[inline]
    pub fn project_with_normal(&self, p: Point2, unit_normal: Point2) -> SegmentProjection {
        let d = self.b.sub(self.a);
        let len_sq = d.norm_sq();
        let w = p.sub(self.a);
        let t = if len_sq > f32::EPSILON {
            w.dot(d) / len_sq
        } else {
            0.0
        };
        if !(t > 0.0 && t < 1.0) {
            return self.project(p);
        }
        SegmentProjection {
            closest: self.a.add(d.scale(t)),
            distance_m: crate::math::abs(unit_normal.dot(w)),
            t,
            normal: unit_normal,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_inside_and_clamped() {
        let s = Segment::new(Point2::new(0.0, 0.0), Point2::new(2.0, 0.0));
        let p = s.project(Point2::new(1.0, 3.0));
        assert_eq!(p.closest, Point2::new(1.0, 0.0));
        assert_eq!(p.distance_m, 3.0);
        assert_eq!(p.normal, Point2::new(0.0, 1.0));
        let q = s.project(Point2::new(5.0, 4.0));
        assert_eq!(q.t, 1.0);
        assert_eq!(q.distance_m, 5.0);
        let z = Segment::new(Point2::ORIGIN, Point2::ORIGIN).project(Point2::new(0.0, 2.0));
        assert_eq!(z.distance_m, 2.0);
    }

    #[test]
    fn projection_with_known_normal_agrees() {
        let s = Segment::new(Point2::new(1.0, -2.0), Point2::new(4.0, 2.0));
        let n = s.project(Point2::ORIGIN).normal;
        for (x, y) in [(2.0, 0.0), (3.0, 3.0), (-1.0, -4.0), (6.0, 2.0), (2.5, 0.0)] {
            let p = Point2::new(x, y);
            let (a, b) = (s.project(p), s.project_with_normal(p, n));
            assert!(
                (a.distance_m - b.distance_m).abs() < 1e-6,
                "{p:?}: {a:?} {b:?}"
            );
            assert!(a.closest.dist(b.closest) < 1e-6 && (a.t - b.t).abs() < 1e-6);
            assert_eq!(a.normal, b.normal);
        }
        let z = Segment::new(Point2::ORIGIN, Point2::ORIGIN);
        let p = Point2::new(0.0, 2.0);
        assert_eq!(
            z.project_with_normal(p, Point2::new(1.0, 0.0)),
            z.project(p)
        );
    }
}
