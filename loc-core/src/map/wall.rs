//! Tunnel walls: which side, and positions along a wall polyline by arc length.

use serde::{Deserialize, Serialize};

use crate::geometry::{Point2, Segment};
use crate::landmark::WallFrame;

use super::{FeatureKind, WallEnd, WallEndAt};

/// One of the tunnel's two walls. Both wall polylines run in the direction of increasing
/// chainage; the left wall is on the left looking that way.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WallSide {
    /// Left of the direction of increasing chainage.
    Left,
    /// Right of the direction of increasing chainage.
    Right,
}

impl WallSide {
    /// The feature kind of this wall's segments.
    #[inline]
    pub fn kind(self) -> FeatureKind {
        match self {
            WallSide::Left => FeatureKind::LeftWall,
            WallSide::Right => FeatureKind::RightWall,
        }
    }

    /// Unit normal into the tunnel for a wall running along unit `tangent`: the left wall's
    /// interior is to its right (tangent turned −90°), the right wall's to its left.
    #[inline]
    pub fn inward_normal(self, tangent: Point2) -> Point2 {
        match self {
            WallSide::Left => Point2::new(tangent.y_m, -tangent.x_m),
            WallSide::Right => tangent.perp(),
        }
    }

    /// One-byte tag of the map file format.
    #[inline]
    pub fn tag(self) -> u8 {
        match self {
            WallSide::Left => 0,
            WallSide::Right => 1,
        }
    }

    /// The side with file-format tag `tag`.
    #[inline]
    pub fn from_tag(tag: u8) -> Option<Self> {
        match tag {
            0 => Some(WallSide::Left),
            1 => Some(WallSide::Right),
            _ => None,
        }
    }
}

/// The start or finish of a wall polyline given as consecutive segments; `None` when it
/// is empty or its end segment has no length.
pub(crate) fn polyline_end(
    wall: WallSide,
    at: WallEndAt,
    mut segments: impl DoubleEndedIterator<Item = Segment>,
) -> Option<WallEnd> {
    let (point, from) = match at {
        WallEndAt::Start => {
            let s = segments.next()?;
            (s.a, s.b)
        }
        WallEndAt::Finish => {
            let s = segments.next_back()?;
            (s.b, s.a)
        }
    };
    let d = point.sub(from);
    let len = d.norm();
    (len > 1e-6 && point.is_finite() && len.is_finite()).then(|| WallEnd {
        wall,
        at,
        point,
        outward: d.scale(1.0 / len),
    })
}

/// Length of a wall polyline given as consecutive segments, metres.
pub(crate) fn polyline_length_m(segments: impl Iterator<Item = Segment>) -> f32 {
    segments.map(|s| s.length()).sum()
}

/// The frame at arc length `s_m` along a wall made of consecutive `segments`: the point on
/// the wall and the unit tangent of the (non-degenerate) segment holding it. `None` when
/// `s_m` is not finite, off the wall (beyond a 1 mm tolerance at the ends), or the wall has
/// no length.
pub(crate) fn frame_at(
    side: WallSide,
    segments: impl Iterator<Item = Segment>,
    s_m: f32,
) -> Option<WallFrame> {
    const END_TOL_M: f32 = 1e-3;
    if !s_m.is_finite() || s_m < -END_TOL_M {
        return None;
    }
    let mut walked = 0.0_f32;
    let mut last: Option<(Segment, f32)> = None;
    for seg in segments {
        let len = seg.length();
        if len <= f32::EPSILON {
            continue;
        }
        if s_m <= walked + len {
            let t = ((s_m - walked) / len).clamp(0.0, 1.0);
            return Some(frame_on(side, &seg, t, len));
        }
        walked += len;
        last = Some((seg, len));
    }
    // Past the end: accept a rounding overshoot at the last point.
    let (seg, len) = last?;
    (s_m <= walked + END_TOL_M).then(|| frame_on(side, &seg, 1.0, len))
}

fn frame_on(side: WallSide, seg: &Segment, t: f32, len: f32) -> WallFrame {
    let tangent = seg.b.sub(seg.a).scale(1.0 / len);
    WallFrame {
        anchor: seg.a.add(seg.b.sub(seg.a).scale(t)),
        tangent,
        inward_normal: side.inward_normal(tangent),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_along_a_bent_wall() {
        let segs = [
            Segment::new(Point2::new(0.0, 0.0), Point2::new(3.0, 0.0)),
            Segment::new(Point2::new(3.0, 0.0), Point2::new(3.0, 0.0)), // degenerate
            Segment::new(Point2::new(3.0, 0.0), Point2::new(3.0, 4.0)),
        ];
        assert_eq!(polyline_length_m(segs.iter().copied()), 7.0);
        let f = frame_at(WallSide::Right, segs.iter().copied(), 5.0).unwrap();
        assert_eq!(f.anchor, Point2::new(3.0, 2.0));
        assert_eq!(f.tangent, Point2::new(0.0, 1.0));
        assert_eq!(f.inward_normal, Point2::new(-1.0, 0.0));
        let l = frame_at(WallSide::Left, segs.iter().copied(), 1.0).unwrap();
        assert_eq!(l.inward_normal, Point2::new(0.0, -1.0));
        assert!(frame_at(WallSide::Left, segs.iter().copied(), 7.0005).is_some());
        assert!(frame_at(WallSide::Left, segs.iter().copied(), 7.1).is_none());
        assert!(frame_at(WallSide::Left, segs.iter().copied(), f32::NAN).is_none());
        assert!(frame_at(WallSide::Left, segs.iter().copied(), -1.0).is_none());
    }
}
