//! Where in the map does the local landmark map fit? One **round** of the search takes a
//! reference landmark among those seen and tries it on every map landmark in turn
//! ([`MapQuery::landmark_base`]): the wall directions and the feet fix a candidate
//! transform from the local frame to the world, under which every other seen landmark must
//! land on a map landmark of the matching wall. The §4.4 spacing jitter (±0.625 m around
//! D) is what makes only the true placement explain them all.
//!
//! The cost of a candidate is a capped chi-square: each other seen landmark adds
//! `min((e/σ)², outlier_cost)`, `e` its along-wall offset from the nearest map landmark of
//! its wall (farther than `max_normal_m` off that landmark's base line: not it), `σ`
//! growing with the distance from the reference (what odometry between sightings leaves).
//! The round keeps the two cheapest candidates only (fixed memory, whatever the map's
//! size) and abandons a candidate as soon as its cost passes the runner-up's. A round is
//! spread over scans by a work budget (one unit per map query), so a scan's cost stays
//! bounded on a long map.

use crate::geometry::{Point2, Pose2};
use crate::map::{LandmarkBase, MapQuery, WallSide};
use crate::math;

use super::seen::SeenLandmark;
use super::RelocaliseConfig;

/// One placement of the local landmark map in the world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// The map landmark the reference was placed on.
    pub landmark: u16,
    /// Capped chi-square of the other seen landmarks (lower is better).
    pub cost: f32,
    /// Seen landmarks a map landmark explains within 3σ, the reference included.
    pub explained: u8,
    /// The local frame in the world (world ← local).
    pub local_to_world: Pose2,
    /// The vehicle faces down the chainage in this placement (its left wall is the map's
    /// right one).
    pub reversed: bool,
}

/// A round in progress: the reference, the landmarks it is scored on, the next map
/// landmark to try, the best two so far.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Round {
    /// Index of the reference among the seen landmarks.
    pub reference: u8,
    /// Seen landmarks the round scores (those seen when it began).
    pub landmarks: u8,
    /// Of which seen often enough to be used (`min_sightings`), the reference included.
    pub established: u8,
    /// The next map landmark to try.
    pub next: u16,
    /// The cheapest candidate so far.
    pub best: Option<Candidate>,
    /// The second cheapest.
    pub second: Option<Candidate>,
}

impl Round {
    /// A round with `reference` over the first `landmarks` seen landmarks.
    pub fn new(reference: u8, landmarks: u8, established: u8) -> Self {
        Self {
            reference,
            landmarks,
            established,
            next: 0,
            best: None,
            second: None,
        }
    }

    /// Whether every map landmark has been tried.
    pub fn is_finished<M: MapQuery>(&self, map: &M) -> bool {
        self.next >= map.landmark_count()
    }

    /// Tries map landmarks until the round is finished or `budget` units of work (map
    /// queries) are spent; returns the work spent.
    pub fn run<M: MapQuery>(
        &mut self,
        map: &M,
        seen: &[SeenLandmark],
        config: &RelocaliseConfig,
        budget: u32,
    ) -> u32 {
        let seen = seen.get(..usize::from(self.landmarks)).unwrap_or(seen);
        let Some(reference) = seen.get(usize::from(self.reference)) else {
            self.next = map.landmark_count();
            return 0;
        };
        let mut work = 0u32;
        while self.next < map.landmark_count() && work < budget {
            let id = self.next;
            self.next += 1;
            work += 1;
            let Some(base) = map.landmark_base(id) else {
                continue;
            };
            let bound = self.second.map_or(f32::INFINITY, |c| c.cost);
            let (candidate, spent) = score(map, seen, reference, id, &base, bound, config);
            work = work.saturating_add(spent);
            if let Some(c) = candidate {
                self.keep(c);
            }
        }
        work
    }

    fn keep(&mut self, c: Candidate) {
        match (self.best, self.second) {
            (None, _) => self.best = Some(c),
            (Some(b), _) if c.cost < b.cost => {
                self.second = self.best;
                self.best = Some(c);
            }
            (Some(_), None) => self.second = Some(c),
            (Some(_), Some(s)) if c.cost < s.cost => self.second = Some(c),
            _ => {}
        }
    }
}

/// The candidate placing `reference` on map landmark `id` (`base`), scored on the other
/// seen landmarks; `None` when it cannot be placed (wrong side) or its cost passes `bound`.
/// Also returns the map queries spent.
fn score<M: MapQuery>(
    map: &M,
    seen: &[SeenLandmark],
    reference: &SeenLandmark,
    id: u16,
    base: &LandmarkBase,
    bound: f32,
    config: &RelocaliseConfig,
) -> (Option<Candidate>, u32) {
    // Facing down the chainage, the vehicle's left wall is the map's right one.
    let reversed = (base.wall == WallSide::Left) != reference.left;
    let Some(local_to_world) = placement(reference, base, reversed) else {
        return (None, 0);
    };
    let mut cost = 0.0f32;
    let mut explained = 1u8;
    let mut work = 0u32;
    for s in seen {
        if core::ptr::eq(s, reference) || s.sightings < config.min_sightings {
            continue;
        }
        let wall = if s.left != reversed {
            WallSide::Left
        } else {
            WallSide::Right
        };
        let sigma = config.sigma_m + config.sigma_per_m * s.foot_local.dist(reference.foot_local);
        let w = local_to_world.transform_point(s.foot_local);
        let reach = config.max_normal_m + 3.0 * sigma;
        let e = nearest_along(map, w, wall, reach, config.max_normal_m);
        work += 1;
        let z2 = e.map_or(f32::INFINITY, |e| (e / sigma) * (e / sigma));
        if z2 < 9.0 {
            explained = explained.saturating_add(1);
        }
        cost += math::min(z2, config.outlier_cost);
        if cost >= bound {
            return (None, work);
        }
    }
    (
        Some(Candidate {
            landmark: id,
            cost,
            explained,
            local_to_world,
            reversed,
        }),
        work,
    )
}

/// Most map landmarks checked by [`unseen_landmarks`].
const MAX_PASSED: usize = 48;

/// The negative evidence against a placement: the map landmarks it puts within
/// `config.passed_within_m` of the vehicle's way so far (the segment from the local origin
/// to `vehicle_local`), ahead of where the search began (the scanner sees nothing behind
/// it) and not beyond the vehicle (where they may not be established yet) — where the
/// scanner must have seen them — and how many of those no
/// established seen landmark on the matching side lies near (`max(3σ, 0.3 m)` along the
/// wall). A wrong placement whose seen landmarks happen to fall on map landmarks still puts
/// the map's other landmarks where nothing was seen.
pub fn unseen_landmarks<M: MapQuery>(
    map: &M,
    seen: &[SeenLandmark],
    vehicle_local: Pose2,
    candidate: &Candidate,
    config: &RelocaliseConfig,
) -> (u8, u8) {
    let t = candidate.local_to_world;
    let from = Point2::ORIGIN;
    let to = vehicle_local.translation();
    let way = to.sub(from);
    let way_len = way.norm();
    // Map landmarks near the way: queried every few metres along it.
    let mut ids: heapless::Vec<u16, MAX_PASSED> = heapless::Vec::new();
    let step = math::max(0.5 * config.passed_within_m, 1.0);
    let samples = (way_len / step) as usize + 1;
    for k in 0..=samples.min(64) {
        let f = if samples == 0 {
            0.0
        } else {
            k as f32 / samples as f32
        };
        let centre = t.transform_point(from.add(way.scale(f)));
        map.for_each_landmark_segment_near(centre, config.passed_within_m, &mut |id, _| {
            if !ids.contains(&id) {
                let _ = ids.push(id);
            }
        });
    }
    let world_to_local = t.inverse();
    let (mut passed, mut unseen) = (0u8, 0u8);
    for id in ids {
        let Some(b) = map.landmark_base(id) else {
            continue;
        };
        let anchor = world_to_local.transform_point(b.anchor());
        let along = anchor.dot(way.scale(1.0 / math::max(way_len, 1e-3)));
        let beside_the_way = distance_to_segment(anchor, from, to) <= config.passed_within_m
            && anchor.x_m >= 1.0
            && along <= way_len;
        if !beside_the_way {
            continue;
        }
        passed = passed.saturating_add(1);
        let left = (b.wall == WallSide::Left) != candidate.reversed;
        let near = seen.iter().any(|s| {
            s.left == left
                && s.sightings >= config.min_sightings
                && s.foot_local.dist(anchor)
                    <= math::max(
                        3.0 * (config.sigma_m + config.sigma_per_m * anchor.norm()),
                        0.3,
                    )
        });
        if !near {
            unseen = unseen.saturating_add(1);
        }
    }
    (passed, unseen)
}

/// Distance from `p` to the segment `a`–`b`, metres.
fn distance_to_segment(p: Point2, a: Point2, b: Point2) -> f32 {
    let ab = b.sub(a);
    let len_sq = ab.norm_sq();
    let t = if len_sq > 1e-12 {
        (p.sub(a).dot(ab) / len_sq).clamp(0.0, 1.0)
    } else {
        0.0
    };
    p.dist(a.add(ab.scale(t)))
}

/// The world ← local transform that puts `reference`'s foot on `base`'s anchor with its
/// wall along the map's wall, the vehicle facing down the chainage when `reversed`
/// (`None` for a degenerate base).
fn placement(reference: &SeenLandmark, base: &LandmarkBase, reversed: bool) -> Option<Pose2> {
    let along = base.base.b.sub(base.base.a);
    if along.norm_sq() < 1e-8 {
        return None;
    }
    let mut heading = math::atan2(along.y_m, along.x_m)
        - math::atan2(reference.tangent_local.y_m, reference.tangent_local.x_m);
    if reversed {
        heading += core::f32::consts::PI;
    }
    let rotation = Pose2::new(0.0, 0.0, heading);
    let t = base
        .anchor()
        .sub(rotation.rotate_vector(reference.foot_local));
    let pose = Pose2::new(t.x_m, t.y_m, heading);
    pose.is_finite().then_some(pose)
}

/// Most distinct landmarks examined around one query point.
const MAX_NEARBY: usize = 8;

/// The along-wall offset (metres, unsigned) from `p` (world frame) to the nearest anchor
/// of a landmark on `wall` with a segment within `reach_m`, among those whose base line `p`
/// lies within `max_normal_m` of.
fn nearest_along<M: MapQuery>(
    map: &M,
    p: Point2,
    wall: WallSide,
    reach_m: f32,
    max_normal_m: f32,
) -> Option<f32> {
    let mut ids: heapless::Vec<u16, MAX_NEARBY> = heapless::Vec::new();
    map.for_each_landmark_segment_near(p, reach_m, &mut |id, _| {
        if !ids.contains(&id) {
            let _ = ids.push(id);
        }
    });
    let mut best: Option<f32> = None;
    for id in ids {
        let Some(b) = map.landmark_base(id) else {
            continue;
        };
        if b.wall != wall {
            continue;
        }
        let along = b.base.b.sub(b.base.a);
        let len = along.norm();
        if len < 1e-4 {
            continue;
        }
        let t = along.scale(1.0 / len);
        let d = p.sub(b.anchor());
        if math::abs(d.cross(t)) > max_normal_m {
            continue;
        }
        let e = math::abs(d.dot(t));
        if best.is_none_or(|b| e < b) {
            best = Some(e);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::landmark::LandmarkModel;
    use crate::map::TunnelMap;
    use crate::testkit::{LandmarkLayout, TunnelSpec};

    fn map() -> std::boxed::Box<TunnelMap> {
        let mut map = std::boxed::Box::new(TunnelMap::new());
        TunnelSpec::straight(400.0)
            .with_landmarks(LandmarkLayout::paper(LandmarkModel::P1Triangle, 9))
            .build_into(&mut *map)
            .unwrap();
        map
    }

    /// The map's landmarks between arcs 100 and 130 m as a vehicle facing along the
    /// chainage (`reverse`: against it) at `local_in_world` would have seen them.
    fn seen_from(
        map: &TunnelMap,
        local_in_world: Pose2,
        reverse: bool,
    ) -> std::vec::Vec<(u16, SeenLandmark)> {
        let world_to_local = local_in_world.inverse();
        map.landmarks()
            .iter()
            .enumerate()
            .filter(|(_, l)| (100.0..130.0).contains(&l.placement.s_m))
            .map(|(i, l)| {
                let on_left = l.placement.wall == WallSide::Left;
                let tangent = local_in_world.inverse().rotate_vector(l.frame.tangent);
                (
                    i as u16,
                    SeenLandmark {
                        foot_local: world_to_local.transform_point(l.frame.anchor),
                        tangent_local: if reverse {
                            tangent.scale(-1.0)
                        } else {
                            tangent
                        },
                        left: on_left != reverse,
                        sightings: 10,
                        weight: 5.0,
                        last_seen_m: 0.0,
                    },
                )
            })
            .collect()
    }

    #[test]
    fn the_true_placement_wins_in_either_direction() {
        let map = map();
        let config = RelocaliseConfig::DEFAULT;
        for reverse in [false, true] {
            let local_in_world = Pose2::new(95.0, 0.3, if reverse { 3.1 } else { 0.05 });
            let seen = seen_from(&map, local_in_world, reverse);
            assert!(seen.len() >= 5);
            let landmarks: std::vec::Vec<SeenLandmark> = seen.iter().map(|s| s.1).collect();
            let n = landmarks.len() as u8;
            let mut round = Round::new(2, n, n);
            round.run(&*map, &landmarks, &config, u32::MAX);
            assert!(round.is_finished(&*map));
            let best = round.best.unwrap();
            assert_eq!(best.landmark, seen[2].0, "reverse {reverse}");
            assert_eq!(best.explained, n);
            assert!(best.cost < 1e-2, "{best:?}");
            let p = best.local_to_world;
            assert!(
                p.translation().dist(local_in_world.translation()) < 1e-3,
                "{p:?}"
            );
            assert!(crate::math::wrap_angle(p.theta_rad - local_in_world.theta_rad).abs() < 1e-4);
            // Every other placement leaves at least one landmark unexplained (with a
            // handful of landmarks a wrong placement can explain a few: the verdict needs
            // the margin, which more landmarks give).
            let second = round.second.unwrap();
            assert!(second.cost - best.cost > config.outlier_cost, "{second:?}");
        }
    }

    #[test]
    fn a_round_spread_over_small_budgets_finds_the_same_and_spends_what_it_says() {
        let map = map();
        let config = RelocaliseConfig::DEFAULT;
        let seen = seen_from(&map, Pose2::new(90.0, -0.2, 0.0), false);
        let landmarks: std::vec::Vec<SeenLandmark> = seen.iter().map(|s| s.1).collect();
        let n = landmarks.len() as u8;
        let mut whole = Round::new(0, n, n);
        whole.run(&*map, &landmarks, &config, u32::MAX);
        let mut pieces = Round::new(0, n, n);
        let mut calls = 0;
        while !pieces.is_finished(&*map) {
            let spent = pieces.run(&*map, &landmarks, &config, 20);
            // At most one candidate past the budget: its queries, one per seen landmark.
            assert!(spent <= 20 + u32::from(n), "{spent}");
            calls += 1;
        }
        assert!(calls > 3);
        assert_eq!(pieces.best, whole.best);
        assert_eq!(pieces.second, whole.second);
    }

    #[test]
    fn a_map_that_lists_no_landmarks_gives_no_placement() {
        struct Unlisted<'a>(&'a TunnelMap);
        impl MapQuery for Unlisted<'_> {
            fn nearest(&self, p: Point2, d: f32) -> Option<crate::map::MapHit> {
                self.0.nearest(p, d)
            }
            fn raycast(&self, o: Point2, a: f32, r: f32) -> Option<crate::map::RayHit> {
                self.0.raycast(o, a, r)
            }
            fn for_each_landmark_segment_near(
                &self,
                c: Point2,
                r: f32,
                f: &mut dyn FnMut(u16, crate::geometry::Segment),
            ) {
                self.0.for_each_landmark_segment_near(c, r, f)
            }
        }
        let map = map();
        let seen = seen_from(&map, Pose2::new(90.0, 0.0, 0.0), false);
        let landmarks: std::vec::Vec<SeenLandmark> = seen.iter().map(|s| s.1).collect();
        let mut round = Round::new(0, 4, 4);
        assert_eq!(
            round.run(&Unlisted(&map), &landmarks, &RelocaliseConfig::DEFAULT, 100),
            0
        );
        assert!(round.is_finished(&Unlisted(&map)));
        assert_eq!(round.best, None);
    }
}
