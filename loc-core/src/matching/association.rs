//! Data association: each scan point, placed in the world by a candidate pose, paired with
//! the nearest map segment, and the selection of the K best pairs.

use core::cmp::Ordering;

use crate::geometry::{Point2, Pose2, Segment, SegmentProjection};
use crate::map::{FeatureKind, MapQuery};
use crate::math;

/// What a scan point is paired with: nothing, a wall, or a landmark (by its index in the
/// map). Two bytes, so that an [`Association`] stays 56 (the match workspace holds 512 of
/// them in the controller's RAM).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pairing(u16);

impl Pairing {
    /// Paired with nothing (no map geometry within the gate).
    pub const NONE: Self = Self(u16::MAX);
    /// Paired with a wall.
    pub const WALL: Self = Self(u16::MAX - 1);

    /// Paired with the landmark of map index `id` (maps hold far fewer than 65 534
    /// landmarks; a larger index is taken as the largest there can be).
    pub const fn landmark(id: u16) -> Self {
        Self(if id < u16::MAX - 1 { id } else { u16::MAX - 2 })
    }

    /// The pairing with map geometry of `kind`.
    pub fn of(kind: FeatureKind) -> Self {
        kind.landmark_id().map_or(Self::WALL, Self::landmark)
    }

    /// True when paired with map geometry.
    #[inline]
    pub const fn is_paired(self) -> bool {
        self.0 != Self::NONE.0
    }

    /// The landmark's map index when paired with one.
    #[inline]
    pub const fn landmark_id(self) -> Option<u16> {
        if self.0 < Self::WALL.0 {
            Some(self.0)
        } else {
            None
        }
    }
}

impl Default for Pairing {
    fn default() -> Self {
        Self::NONE
    }
}

/// One scan point's pairing with the map at the current pose.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Association {
    /// Distance from the world point to the nearest map geometry, metres; the association
    /// gate when nothing lies within it.
    pub distance_m: f32,
    /// The scan point in the world frame at the pose associated with.
    pub world: Point2,
    /// Closest map point, world frame.
    pub closest: Point2,
    /// Unit normal of the residual: the segment's normal, or, when the closest point is an
    /// end of a landmark's segment, the direction from that end to the point (so
    /// `normal·(world − closest)` is the true distance); past a wall segment's end, the
    /// distance to the wall's line.
    pub normal: Point2,
    /// The map segment associated with (meaningless when not associated).
    pub segment: Segment,
    /// Unit normal of that segment's line (re-projections onto it need no square root).
    pub line_normal: Point2,
    /// What the segment is part of ([`Pairing::NONE`] when no map geometry lay within the
    /// gate). Landmark points are searched again after small moves (see
    /// [`AssociationSchedule`]).
    pub pairing: Pairing,
    /// Index of the scan point in the slice associated.
    pub point: u16,
}

impl Association {
    /// True when map geometry lay within the gate.
    #[inline]
    pub fn associated(&self) -> bool {
        self.pairing.is_paired()
    }

    /// The map index of the landmark the point is paired with, if any.
    #[inline]
    pub fn landmark(&self) -> Option<u16> {
        self.pairing.landmark_id()
    }

    /// The signed point-to-line residual, metres.
    #[inline]
    pub fn residual_m(&self) -> f32 {
        self.normal.dot(self.world.sub(self.closest))
    }
}

/// Places `points` (vehicle frame) in the world at `pose` and associates each with the
/// nearest map geometry within `gate_m`. Writes `min(points, out)` entries; returns how many
/// found a partner.
pub fn associate<M: MapQuery>(
    map: &M,
    points: &[Point2],
    pose: Pose2,
    gate_m: f32,
    out: &mut [Association],
) -> usize {
    let (s, c) = math::sin_cos(pose.theta_rad);
    let mut found = 0;
    for (i, (p, a)) in points.iter().zip(out.iter_mut()).enumerate() {
        let world = Point2::new(
            c * p.x_m - s * p.y_m + pose.x_m,
            s * p.x_m + c * p.y_m + pose.y_m,
        );
        *a = match map.nearest(world, gate_m) {
            Some(hit) if hit.projection.distance_m.is_finite() => {
                found += 1;
                paired(world, hit.segment, hit.projection, Pairing::of(hit.kind))
            }
            _ => unpaired(world, gate_m),
        };
        a.point = crate::math::saturating_u16(i);
    }
    found
}

/// Like [`associate`] but keeps each wall point's segment from the last association and only
/// re-projects onto it (no map search): valid while the pose has moved little since, and
/// an order of magnitude cheaper. A point whose projection leaves its segment's interior is
/// searched again alone (its nearest piece of map has changed). With `search_landmarks`,
/// points on landmarks are searched again (their nearest flank changes with small moves,
/// and they are few); unassociated points stay so. Points farther than `gate_m` from their
/// segment become unassociated. Entries must come from an earlier [`associate`] on the same
/// points.
pub fn reproject<M: MapQuery>(
    map: &M,
    points: &[Point2],
    pose: Pose2,
    gate_m: f32,
    search_landmarks: bool,
    out: &mut [Association],
) -> usize {
    reproject_counting(map, points, pose, gate_m, search_landmarks, out, &mut 0)
}

/// [`reproject`], adding the map searches it made to `searches`.
fn reproject_counting<M: MapQuery>(
    map: &M,
    points: &[Point2],
    pose: Pose2,
    gate_m: f32,
    search_landmarks: bool,
    out: &mut [Association],
    searches: &mut u32,
) -> usize {
    let (s, c) = math::sin_cos(pose.theta_rad);
    let mut found = 0;
    for a in out.iter_mut().take(points.len()) {
        let Some(p) = points.get(usize::from(a.point)) else {
            continue;
        };
        let world = Point2::new(
            c * p.x_m - s * p.y_m + pose.x_m,
            s * p.x_m + c * p.y_m + pose.y_m,
        );
        if !a.associated() {
            a.world = world;
            continue;
        }
        let point = a.point;
        let mut search = |world| {
            *searches += 1;
            map.nearest(world, gate_m)
                .filter(|h| h.projection.distance_m.is_finite())
                .map(|h| (h.segment, h.projection, Pairing::of(h.kind)))
        };
        let hit = if a.landmark().is_some() && search_landmarks {
            search(world)
        } else {
            let pr = a.segment.project_with_normal(world, a.line_normal);
            if pr.t > 0.0 && pr.t < 1.0 {
                // Still the same kind of geometry: a landmark point stays one, to be
                // searched again at the next landmark search.
                (pr.distance_m <= gate_m).then_some((a.segment, pr, a.pairing))
            } else {
                // Slid off its segment's end: the neighbouring piece of wall (or whatever
                // lies there) is found for this point alone.
                search(world)
            }
        };
        *a = match hit {
            Some((segment, pr, pairing)) => {
                found += 1;
                paired(world, segment, pr, pairing)
            }
            None => unpaired(world, gate_m),
        };
        a.point = point;
    }
    found
}

pub(super) fn paired(
    world: Point2,
    segment: Segment,
    pr: SegmentProjection,
    pairing: Pairing,
) -> Association {
    // Past a landmark's corner the residual runs from the corner to the point. Past a
    // wall segment's end it stays across the wall's line: where a stored wall stops, the
    // scanned wall's last point is only the last beam to reach it — a beam spacing short of
    // the real end at grazing incidence, or beyond it when the real wall goes on — so the
    // end is no point to pull the scan onto along the tunnel (the wall-end observation
    // measures it, with that spacing in its variance). As a corner it made the match claim
    // the position along to 13 mm, 113 mm off, at the bare S-bend's end.
    let at_end = pr.t <= 0.0 || pr.t >= 1.0;
    let normal = if pairing.landmark_id().is_some() && at_end && pr.distance_m > 1e-6 {
        world.sub(pr.closest).scale(1.0 / pr.distance_m)
    } else {
        pr.normal
    };
    Association {
        distance_m: pr.distance_m,
        world,
        closest: pr.closest,
        normal,
        segment,
        line_normal: pr.normal,
        pairing,
        point: 0,
    }
}

fn unpaired(world: Point2, gate_m: f32) -> Association {
    Association {
        distance_m: gate_m,
        world,
        closest: world,
        normal: Point2::new(1.0, 0.0),
        segment: Segment::new(world, world),
        line_normal: Point2::new(1.0, 0.0),
        pairing: Pairing::NONE,
        point: 0,
    }
}

/// Decides between a full association and a cheap re-projection: full on the first call
/// and whenever the pose has moved more than `MAX_SHIFT_M` / `MAX_TURN_RAD` since the last
/// full association; landmark points are searched again when it moved more than
/// `LANDMARK_SHIFT_M` / `LANDMARK_TURN_RAD` since their last search (their nearest flank
/// changes with small moves). Between full associations a wall point that slides off the
/// end of its segment is searched again alone ([`reproject`]), so the full association is
/// needed only for what re-projection cannot see: points that entered or left the gate, or
/// whose nearest feature changed kind.
///
/// It also counts the work done, in the units of [`super::MatchConfig::max_work`]: each
/// point associated or re-projected counts 1, each map search [`Self::SEARCH_WORK`] more.
#[derive(Debug, Clone, Copy, Default)]
pub struct AssociationSchedule {
    last_full: Option<Pose2>,
    last_landmark: Option<Pose2>,
    work: u32,
}

impl AssociationSchedule {
    /// Translation since the last full association that forces a new one, metres.
    pub const MAX_SHIFT_M: f32 = 0.25;
    /// Rotation since the last full association that forces a new one, radians (a point
    /// 20 m out moves 0.25 m).
    pub const MAX_TURN_RAD: f32 = 0.0125;
    /// Translation since the last landmark search that forces a new one, metres.
    pub const LANDMARK_SHIFT_M: f32 = 0.0125;
    /// Rotation since the last landmark search that forces a new one, radians.
    pub const LANDMARK_TURN_RAD: f32 = 0.000625;
    /// The work a map search adds to a point's unit (measured on the Cortex-M4F: a
    /// nearest-segment search costs about 2.5 times a point's share of an iteration).
    pub const SEARCH_WORK: u32 = 2;

    /// A schedule whose first call associates fully.
    pub const fn new() -> Self {
        Self {
            last_full: None,
            last_landmark: None,
            work: 0,
        }
    }

    /// The work done by the calls so far (see the type's docs).
    pub const fn work(&self) -> u32 {
        self.work
    }

    /// Associates (fully or by re-projection) at `pose`; returns the points associated.
    pub fn run<M: MapQuery>(
        &mut self,
        map: &M,
        points: &[Point2],
        pose: Pose2,
        gate_m: f32,
        out: &mut [Association],
    ) -> usize {
        let moved = |last: Option<Pose2>, shift_m: f32, turn_rad: f32| {
            last.is_none_or(|l| {
                let (dx, dy) = (pose.x_m - l.x_m, pose.y_m - l.y_m);
                dx * dx + dy * dy > shift_m * shift_m
                    || math::abs(math::wrap_angle(pose.theta_rad - l.theta_rad)) > turn_rad
            })
        };
        let n = crate::math::saturating_u16(points.len().min(out.len()));
        let mut searches = 0u32;
        let found = if moved(self.last_full, Self::MAX_SHIFT_M, Self::MAX_TURN_RAD) {
            self.last_full = Some(pose);
            self.last_landmark = Some(pose);
            searches = u32::from(n);
            associate(map, points, pose, gate_m, out)
        } else {
            let search = moved(
                self.last_landmark,
                Self::LANDMARK_SHIFT_M,
                Self::LANDMARK_TURN_RAD,
            );
            if search {
                self.last_landmark = Some(pose);
            }
            reproject_counting(map, points, pose, gate_m, search, out, &mut searches)
        };
        self.work = self
            .work
            .saturating_add(u32::from(n))
            .saturating_add(searches.saturating_mul(Self::SEARCH_WORK));
        found
    }
}

/// A selection key: a point's distance to the map (metres) and its index in the
/// association buffer. Selecting over 8-byte keys instead of whole associations keeps the
/// K-best selection cheap.
pub type DistanceKey = (f32, u16);

/// Fills `keys` from `assoc` (one key per association, in order) and reorders them so the
/// first `k` are the `k` smallest distances (in no particular order) with entry `k − 1` the
/// k-th ranked; returns that k-th distance. O(n) expected (introselect), no full sort.
/// `None` for `k = 0` or `k` beyond the shorter of the two buffers.
pub fn select_k_best(assoc: &[Association], keys: &mut [DistanceKey], k: usize) -> Option<f32> {
    let n = assoc.len().min(keys.len());
    let kth = k.checked_sub(1)?;
    if kth >= n {
        return None;
    }
    for (i, (key, a)) in keys.iter_mut().zip(assoc.iter()).enumerate() {
        *key = (a.distance_m, crate::math::saturating_u16(i));
    }
    let keys = keys.get_mut(..n)?;
    let (_, nth, _) =
        keys.select_nth_unstable_by(kth, |a, b| a.0.partial_cmp(&b.0).unwrap_or(Ordering::Equal));
    Some(nth.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn a(d: f32) -> Association {
        Association {
            distance_m: d,
            ..Association::default()
        }
    }

    #[test]
    fn a_pairing_says_what_the_point_is_paired_with_in_two_bytes() {
        assert_eq!(core::mem::size_of::<Pairing>(), 2);
        assert_eq!(core::mem::size_of::<Association>(), 56);
        assert!(!Pairing::NONE.is_paired() && Pairing::NONE.landmark_id().is_none());
        assert!(Pairing::default() == Pairing::NONE);
        assert!(Pairing::WALL.is_paired() && Pairing::WALL.landmark_id().is_none());
        assert_eq!(Pairing::of(FeatureKind::RightWall), Pairing::WALL);
        assert_eq!(
            Pairing::of(FeatureKind::Landmark { id: 7 }).landmark_id(),
            Some(7)
        );
        assert_eq!(Pairing::landmark(0).landmark_id(), Some(0));
        // An index beyond any map's stays a landmark, never a wall or nothing.
        assert_eq!(
            Pairing::landmark(u16::MAX).landmark_id(),
            Some(u16::MAX - 2)
        );
    }

    /// Past a wall segment's end the residual stays across the wall (no pull along it);
    /// past a landmark's corner it runs from the corner.
    #[test]
    fn past_a_wall_end_the_residual_stays_across_the_wall() {
        let wall = Segment::new(Point2::new(0.0, 2.0), Point2::new(10.0, 2.0));
        let p = Point2::new(10.05, 2.01);
        let pr = wall.project(p);
        let a = paired(p, wall, pr, Pairing::WALL);
        assert!(a.normal.x_m.abs() < 1e-6 && (a.normal.y_m.abs() - 1.0).abs() < 1e-6);
        assert!(
            (a.residual_m().abs() - 0.01).abs() < 1e-5,
            "{}",
            a.residual_m()
        );
        let corner = paired(p, wall, pr, Pairing::landmark(0));
        assert!(corner.normal.x_m > 0.9, "{:?}", corner.normal);
        assert!((corner.residual_m() - pr.distance_m).abs() < 1e-6);
    }

    #[test]
    fn selects_k_smallest() {
        let v = [a(5.0), a(1.0), a(4.0), a(2.0), a(3.0), a(0.5)];
        let mut keys = [(0.0f32, 0u16); 8];
        let kth = select_k_best(&v, &mut keys, 3).unwrap();
        assert_eq!(kth, 2.0);
        let mut first: [f32; 3] = core::array::from_fn(|i| v[usize::from(keys[i].1)].distance_m);
        first.sort_by(|x, y| x.partial_cmp(y).unwrap());
        assert_eq!(first, [0.5, 1.0, 2.0]);
        assert!(select_k_best(&v, &mut keys, 0).is_none());
        assert!(select_k_best(&v, &mut keys, 7).is_none());
        assert!(select_k_best(&v, &mut keys[..2], 3).is_none());
    }
}
