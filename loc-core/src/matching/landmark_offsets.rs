//! What the localiser learns of each landmark's offset across its wall, and hands to the
//! matches that follow.
//!
//! A landmark is mounted on the real wall, which stands off the design by its roughness
//! (centimetres on shotcrete), and on brackets that stand it off further: it sits that far
//! off its map position, across the wall. Seen from one side — a scanner sees only the near
//! flank of a triangle until it is nearly abreast of it — a landmark pushed across the wall
//! looks like one moved along it, and the match takes the shift for the vehicle's position
//! along the tunnel. The rough-wall model ([`RoughWalls`]) predicts the offset from the wall
//! beside the landmark, but only as far as the wall's correlation reaches. Abreast of a
//! landmark the scanner sees both flanks, and the offset is measured apart from the
//! position along. So after accepted updates (every [`READ_EVERY_SCANS`]-th; not while it
//! relocalises) the localiser
//! reads, from that scan's points at the updated pose, what they say of each landmark's
//! offset ([`LandmarkOffsets::observe`]); it keeps the readings' mean per landmark, and every later
//! match takes it as one more measurement of the offset at that landmark
//! ([`RoughWalls::add_known_offset`]).
//!
//! Readings of consecutive scans share their errors (the same wall, nearly the same pose),
//! so their mean is not as certain as that of as many independent ones
//! ([`EFFECTIVE_READINGS`]). A landmark whose readings disagree with each other
//! ([`CONSISTENT_SIGMAS`]) is not a rigid shape standing off its map position — bent,
//! knocked, read from either side — and its offset is not given to the matches (on the
//! S-bend with landmarks on one wall, seed 4, a bent landmark's readings had taken the worst
//! tracked pose from 7.5 to 10.5 σ; with the check 8.1 σ, 6.9 σ as offsets are now read).
//!
//! Only with rough walls ([`super::RoughnessModel`] not smooth): on smooth walls nothing
//! models a landmark's offset, and nothing is learnt. Measured (README, issue 8 item 17):
//! 200 m of `tunnel-1km` 4.33 / 3.87 / 3.98 → 3.85 / 3.20 / 3.13 mm, the whole kilometre
//! 4.22 → 3.55 mm.
//!
//! Tried and not kept (position RMS on the comparison's recordings): the readings fused
//! with the wall after the landmark (a reverse pass; the tunnel 4–18 % worse: the landmark
//! is rigid, the wall beside it is not); the landmark's points added against the known
//! offset alone, apart from the wall (the S-bend's wide F4 landmarks 3 % worse than these:
//! they then hold the lateral position to that of the poses they were read at); readings
//! kept as moving with the pose as their estimates did (level on the comparison, but a
//! tracked pose 7.1–7.4 σ off with landmarks installed 1 cm off their marks, against 5.0 σ
//! here); offsets read against the wall beside the landmark rather than absolute (the
//! tunnel 3–23 % worse, the S-bend 6–10 % better than these).

use nalgebra::Matrix3;

use super::association::{paired, Association};
use super::information::NormalEquations;
use super::roughness::{OffsetEstimate, RoughWalls};
use super::MatchConfig;
use crate::geometry::{Point2, Pose2, PoseTransform};
use crate::map::MapQuery;

/// Landmarks whose offsets are remembered at once (the ones seen recently: a scan sees
/// about a dozen of them). Each slot takes 20 bytes.
pub const LANDMARK_OFFSET_SLOTS: usize = 24;

/// How many independent readings the readings of one landmark are worth at most: those of
/// consecutive scans share most of their errors (the same wall, nearly the same pose
/// error), so their mean is not as certain as that of as many independent ones. Measured
/// on 200 m of `tunnel-1km` (README, issue 8 item 17): 1 (the best single reading) 4.06 /
/// 3.49 / 3.50 mm, 4: 3.95 / 3.25 / 3.23, 16: 3.93 / 3.15 / 3.11, every reading
/// independent 3.92 / 3.11 / 3.08 with the S-bend 1 % worse than at 16.
pub const EFFECTIVE_READINGS: f32 = 16.0;

/// How far (in standard deviations of their difference) a reading may lie from the mean
/// of the readings before it: beyond, the landmark is taken for one that is not as mapped
/// but for an offset (see [`LandmarkOffset::inconsistent`]).
pub const CONSISTENT_SIGMAS: f32 = 3.0;

/// Landmark offsets are read from one scan in this many: consecutive scans' readings share
/// most of their errors, and a reading costs a pass over the matched points (40 k
/// instructions on the Cortex-M4F when every scan was read).
pub const READ_EVERY_SCANS: u32 = 2;

/// Fewest points on a landmark for its offset to be read from a scan.
const MIN_POINTS: u16 = 3;

/// What is known of one landmark's offset (20 bytes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LandmarkOffset {
    /// The landmark's index in the map.
    pub landmark: u16,
    /// Sum of the readings' weights (inverse variances), m⁻², and of their offsets so
    /// weighted, m⁻¹.
    weight_sum: f32,
    weighted_offset_sum: f32,
    /// The smallest single reading's variance, m².
    min_variance_m2: f32,
    /// When it was last read ([`LandmarkOffsets`]' count of readings).
    last_read: u32,
    /// A reading disagreed with the ones before beyond [`CONSISTENT_SIGMAS`]: the landmark
    /// is not a rigid shape standing off its map position (bent, moved, knocked), and its
    /// offset is not given to the matches.
    pub inconsistent: bool,
}

impl LandmarkOffset {
    /// The landmark's offset from its map position along its wall's outward normal (into
    /// the rock), metres: the mean of the readings, each weighted by its inverse variance.
    pub fn offset_m(&self) -> f32 {
        self.weighted_offset_sum / self.weight_sum
    }

    /// The offset's variance, m²: that of the readings' weighted mean, were they
    /// independent, but no less than that of [`EFFECTIVE_READINGS`] independent readings as
    /// good as the best of them.
    pub fn variance_m2(&self) -> f32 {
        crate::math::max(
            1.0 / self.weight_sum,
            self.min_variance_m2 / EFFECTIVE_READINGS,
        )
    }
}

/// The offsets of up to [`LANDMARK_OFFSET_SLOTS`] landmarks; the one read longest ago makes
/// way for a new one.
#[derive(Debug, Clone)]
pub struct LandmarkOffsets {
    slots: [Option<LandmarkOffset>; LANDMARK_OFFSET_SLOTS],
    readings: u32,
    /// Scans offered to [`LandmarkOffsets::observe`].
    scans: u32,
}

impl Default for LandmarkOffsets {
    fn default() -> Self {
        Self::NEW
    }
}

impl LandmarkOffsets {
    /// Nothing known.
    pub const NEW: Self = Self {
        slots: [None; LANDMARK_OFFSET_SLOTS],
        readings: 0,
        scans: 0,
    };

    /// Forgets everything (a new pose: readings taken at a wrong one would mislead).
    pub fn clear(&mut self) {
        *self = Self::NEW;
    }

    /// What is known of `landmark`'s offset, and its slot.
    pub fn find(&self, landmark: u16) -> Option<(usize, LandmarkOffset)> {
        self.slots
            .iter()
            .enumerate()
            .find_map(|(i, s)| s.filter(|o| o.landmark == landmark).map(|o| (i, o)))
    }

    /// Everything known.
    pub fn iter(&self) -> impl Iterator<Item = &LandmarkOffset> {
        self.slots.iter().flatten()
    }

    /// Takes one reading of `landmark`'s offset, `reading` (its variance from the scan's
    /// points) taken at a pose whose uncertainty adds `pose_variance_m2` to it (see
    /// [`OffsetEstimate::pose_variance_m2`]); a reading that is not finite, or whose
    /// variance is not positive, is ignored.
    pub fn learn(&mut self, landmark: u16, reading: &OffsetEstimate, pose_variance_m2: f32) {
        let scan_variance_m2 = reading.variance_m2;
        let variance_m2 = scan_variance_m2 + pose_variance_m2;
        let valid = reading.offset_m.is_finite()
            && reading.jacobian.iter().all(|v| v.is_finite())
            && variance_m2.is_finite()
            && variance_m2 > 0.0
            && scan_variance_m2 > 0.0
            && pose_variance_m2 >= 0.0;
        if !valid {
            return;
        }
        self.readings = self.readings.wrapping_add(1);
        let now = self.readings;
        let slot = match self.find(landmark) {
            Some((i, _)) => i,
            None => {
                // A free slot, or the one read longest ago.
                let age = |s: &Option<LandmarkOffset>| {
                    s.map_or(u32::MAX, |o| now.wrapping_sub(o.last_read))
                };
                let i = self
                    .slots
                    .iter()
                    .enumerate()
                    .max_by_key(|(_, s)| age(s))
                    .map_or(0, |(i, _)| i);
                if let Some(s) = self.slots.get_mut(i) {
                    *s = Some(LandmarkOffset {
                        landmark,
                        weight_sum: 0.0,
                        weighted_offset_sum: 0.0,
                        min_variance_m2: variance_m2,
                        last_read: now,
                        inconsistent: false,
                    });
                }
                i
            }
        };
        if let Some(Some(o)) = self.slots.get_mut(slot) {
            if o.weight_sum > 0.0 {
                let z = (reading.offset_m - o.offset_m())
                    / crate::math::sqrt(o.variance_m2() + variance_m2);
                // (A NaN — no variance left to compare with — is a disagreement too.)
                let agrees = crate::math::abs(z) <= CONSISTENT_SIGMAS;
                o.inconsistent |= !agrees;
            }
            let w = 1.0 / variance_m2;
            o.weight_sum += w;
            o.weighted_offset_sum += w * reading.offset_m;
            o.min_variance_m2 = crate::math::min(o.min_variance_m2, variance_m2);
            o.last_read = now;
        }
    }

    /// Reads every landmark's offset from a scan at its updated `pose` (world frame;
    /// `covariance` of `(x_m, y_m, theta_rad)`): `assoc` are the scan's final associations
    /// with `points` (vehicle frame, the points matched). Each point is placed at `pose` and
    /// re-projected onto the map segment it was paired with; those the measurement model
    /// explains ([`MatchConfig::explained_distance_m`]) run through the rough-wall filter
    /// in scan order, and at each landmark's last point (at least three on it)
    /// the filter's estimate of the offset there — the landmark's points and the wall
    /// before them — is a reading. Only every [`READ_EVERY_SCANS`]-th scan offered is read.
    pub fn observe<M: MapQuery>(
        &mut self,
        map: &M,
        assoc: &[Association],
        points: &[Point2],
        pose: Pose2,
        covariance: &Matrix3<f32>,
        config: &MatchConfig,
    ) {
        // The first scan offered is read, then every READ_EVERY_SCANS-th.
        let read = self.scans % READ_EVERY_SCANS == 0;
        self.scans = self.scans.wrapping_add(1);
        if !read {
            return;
        }
        let Some(mut walls) = RoughWalls::new(
            &config.roughness,
            config.range_noise_sigma_m,
            pose.theta_rad,
        ) else {
            return;
        };
        let explained_m = config.explained_distance_m();
        let limit_m = if explained_m > 0.0 {
            explained_m
        } else {
            config.association_gate_m
        };
        let at_pose = PointsAtPose::new(pose, points, limit_m);
        let mut anchors = LandmarkAnchors::new(pose);
        // The landmark being read: its index, points so far and last point.
        let mut run: Option<(u16, u16, Point2)> = None;
        let mut read = |walls: &mut RoughWalls, run: Option<(u16, u16, Point2)>| {
            if let Some((id, _, last)) = run.filter(|r| r.1 >= MIN_POINTS) {
                let reading = walls.offset_at(last);
                self.learn(id, &reading, reading.pose_variance_m2(covariance));
            }
        };
        for (a, p, q, paired) in assoc.iter().filter_map(|a| at_pose.place(a)) {
            let landmark = a.landmark();
            if run.is_some_and(|(id, _, _)| landmark != Some(id)) {
                read(&mut walls, run.take());
            }
            let p = anchors.point(map, landmark, p);
            if let Some(id) = landmark {
                let n = run.map_or(0, |(_, n, _)| n);
                run = Some((id, n.saturating_add(1), p));
            }
            walls.track(p, q, at_pose.t, paired.normal, paired.residual_m());
        }
        read(&mut walls, run.take());
    }
}

/// A scan's points placed at a pose and re-paired with the map segments they were
/// associated with.
struct PointsAtPose<'a> {
    transform: PoseTransform,
    t: Point2,
    points: &'a [Point2],
    limit_m: f32,
}

impl<'a> PointsAtPose<'a> {
    fn new(pose: Pose2, points: &'a [Point2], limit_m: f32) -> Self {
        Self {
            transform: pose.transform(),
            t: pose.translation(),
            points,
            limit_m,
        }
    }

    /// Association `a`'s point (vehicle frame), placed in the world, and its pairing with
    /// its segment there; `None` when not associated or not explained (beyond `limit_m`).
    fn place<'b>(
        &self,
        a: &'b Association,
    ) -> Option<(&'b Association, Point2, Point2, Association)> {
        if !a.associated() {
            return None;
        }
        let p = *self.points.get(usize::from(a.point))?;
        let q = self.transform.apply(p);
        let pr = a.segment.project_with_normal(q, a.line_normal);
        let paired = paired(q, a.segment, pr, a.pairing);
        (crate::math::abs(paired.residual_m()) <= self.limit_m).then_some((a, p, q, paired))
    }
}

/// Where a landmark's points sit in the walls' offset chain ([`RoughWalls`]). A landmark is
/// rigid, mounted whole where its anchor (its base's centre) meets the rough wall, so every
/// point of it carries the wall's offset there — not the offset of the wall behind the
/// point, which would let its two flanks differ by the roughness between them. Landmark
/// points are moved along the vehicle's x to their anchor's; wall points stay as they are.
/// The matches' accumulations, the offsets' reading ([`LandmarkOffsets::observe`]) and the
/// Cramér–Rao bound ([`super::scan_information`]) all place them so.
pub(crate) struct LandmarkAnchors {
    t: Point2,
    sin_cos: (f32, f32),
    /// Anchors looked up so far (world frame): a match looks each landmark up once, not
    /// once per iteration.
    anchors: [(u16, Point2); ANCHORS],
    len: usize,
    /// The last landmark and its anchor's x (vehicle frame), metres: a landmark's points
    /// come in a run.
    last: Option<(u16, f32)>,
}

/// Landmarks whose anchors a match keeps (a scan sees a handful; more are looked up again).
const ANCHORS: usize = 8;

impl LandmarkAnchors {
    /// For points placed at `pose` (world frame).
    pub(crate) fn new(pose: Pose2) -> Self {
        let mut a = Self {
            t: Point2::ORIGIN,
            sin_cos: (0.0, 1.0),
            anchors: [(0, Point2::ORIGIN); ANCHORS],
            len: 0,
            last: None,
        };
        a.place(pose);
        a
    }

    /// Places the points at `pose` from now on (the next iteration of a match); the anchors
    /// looked up are kept.
    pub(crate) fn place(&mut self, pose: Pose2) {
        self.t = pose.translation();
        self.sin_cos = crate::math::sin_cos(pose.theta_rad);
        self.last = None;
    }

    /// Vehicle-frame point `p`, paired with map landmark `landmark` (none: a wall), as the
    /// offset chain takes it.
    pub(crate) fn point<M: MapQuery>(
        &mut self,
        map: &M,
        landmark: Option<u16>,
        p: Point2,
    ) -> Point2 {
        let Some(id) = landmark else {
            return p;
        };
        let x_m = match self.last {
            Some((last, x_m)) if last == id => x_m,
            _ => {
                let kept = self.anchors.iter().take(self.len).find(|(i, _)| *i == id);
                let anchor = match kept {
                    Some(&(_, anchor)) => anchor,
                    None => {
                        let Some(base) = map.landmark_base(id) else {
                            return p;
                        };
                        let anchor = base.anchor();
                        if let Some(slot) = self.anchors.get_mut(self.len) {
                            *slot = (id, anchor);
                            self.len += 1;
                        }
                        anchor
                    }
                };
                let w = anchor.sub(self.t);
                let (s, c) = self.sin_cos;
                let x_m = c * w.x_m + s * w.y_m;
                self.last = Some((id, x_m));
                x_m
            }
        };
        Point2::new(x_m, p.y_m)
    }
}

/// Hands a match's accumulation the known offsets: each known landmark's once, before the
/// first of its points (see [`RoughWalls::add_known_offset`]).
pub(crate) struct OffsetPriors<'a> {
    offsets: &'a LandmarkOffsets,
    /// Slots given already in this accumulation.
    given: u32,
    /// The landmark of the last point (its points come in runs: looked up once a run).
    last: Option<u16>,
}

impl<'a> OffsetPriors<'a> {
    /// For one accumulation of the normal equations.
    pub(crate) fn new(offsets: &'a LandmarkOffsets) -> Self {
        Self {
            offsets,
            given: 0,
            last: None,
        }
    }

    /// Call before adding point `p` (vehicle frame) paired with `landmark` (none: a wall)
    /// to `walls`; `w_unit` as for [`RoughWalls::add`].
    #[inline]
    pub(crate) fn before_point(
        &mut self,
        walls: &mut RoughWalls,
        eq: &mut NormalEquations,
        landmark: Option<u16>,
        p: Point2,
        w_unit: f32,
    ) {
        if landmark == self.last {
            return;
        }
        self.last = landmark;
        let Some((slot, known)) = landmark
            .and_then(|id| self.offsets.find(id))
            .filter(|(_, known)| !known.inconsistent)
        else {
            return;
        };
        let bit = 1u32 << (slot % 32);
        if self.given & bit == 0 {
            self.given |= bit;
            walls.add_known_offset(eq, p, known.offset_m(), known.variance_m2(), w_unit);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::matching::RoughnessModel;
    use nalgebra::Vector3;

    fn reading(offset_m: f32, variance_m2: f32) -> OffsetEstimate {
        OffsetEstimate {
            offset_m,
            jacobian: Vector3::new(0.0, 1.0, 0.0),
            variance_m2,
        }
    }

    #[test]
    fn readings_are_averaged_by_their_inverse_variances_without_claiming_independence() {
        let mut t = LandmarkOffsets::NEW;
        t.learn(7, &reading(0.010, 0.5e-4), 0.5e-4);
        t.learn(7, &reading(0.020, 3.0e-4), 1.0e-4);
        let o = t.find(7).unwrap().1;
        // Weights 1 / (scan + pose variance): (0.010 / 1e-4 + 0.020 / 4e-4) / (1 / 1e-4 +
        // 1 / 4e-4) = 0.012 m.
        assert!((o.offset_m() - 0.012).abs() < 1e-6, "{}", o.offset_m());
        // Two readings: the variance of their weighted mean, were they independent.
        assert!(
            (o.variance_m2() - 0.8e-4).abs() < 1e-9,
            "{}",
            o.variance_m2()
        );
        // A thousand readings of one scan's errors are worth EFFECTIVE_READINGS at most.
        for _ in 0..1000 {
            t.learn(7, &reading(0.012, 0.5e-4), 0.5e-4);
        }
        let o = t.find(7).unwrap().1;
        assert!((o.variance_m2() - 1.0e-4 / EFFECTIVE_READINGS).abs() < 1e-10);
    }

    #[test]
    fn a_landmark_read_at_odds_with_itself_is_not_given_to_the_matches() {
        let mut t = LandmarkOffsets::NEW;
        for _ in 0..20 {
            t.learn(3, &reading(0.010, 1.0e-6), 0.0);
        }
        assert!(!t.find(3).unwrap().1.inconsistent);
        // 2 mm off a mean known to 0.25 mm, with a reading of 1 mm σ: 2 σ, consistent.
        t.learn(3, &reading(0.012, 1.0e-6), 0.0);
        assert!(!t.find(3).unwrap().1.inconsistent);
        // A bent landmark read from its other side: 10 mm off.
        t.learn(3, &reading(0.020, 1.0e-6), 0.0);
        assert!(t.find(3).unwrap().1.inconsistent);
        // What a match's accumulation takes from the table: wall points up to the
        // landmark, then the landmark's offset if given.
        let information = |table: &LandmarkOffsets| {
            let model = RoughnessModel {
                sigma_m: 0.01,
                correlation_m: 1.0,
            };
            let mut walls = RoughWalls::new(&model, 0.01, 0.0).unwrap();
            let mut eq = NormalEquations::default();
            let normal = Point2::new(0.0, 1.0);
            for i in 0..5 {
                let p = Point2::new(0.2 * i as f32, -2.0);
                walls.add(&mut eq, p, p, Point2::ORIGIN, normal, 0.0, 1.0, 1.0);
            }
            let mut priors = OffsetPriors::new(table);
            priors.before_point(&mut walls, &mut eq, Some(3), Point2::new(1.0, -2.0), 1.0);
            eq.information_points
        };
        let walls_only = information(&LandmarkOffsets::NEW);
        assert_eq!(information(&t), walls_only);
        let mut consistent = LandmarkOffsets::NEW;
        consistent.learn(3, &reading(0.010, 1.0e-6), 0.0);
        assert_ne!(information(&consistent), walls_only);
    }

    #[test]
    fn bad_readings_are_ignored_and_the_oldest_landmark_makes_way() {
        let mut t = LandmarkOffsets::NEW;
        t.learn(1, &reading(f32::NAN, 1.0e-4), 0.0);
        t.learn(1, &reading(0.01, 0.0), 0.0);
        t.learn(1, &reading(0.01, f32::INFINITY), 0.0);
        t.learn(1, &reading(0.01, 1.0e-4), -1.0);
        t.learn(1, &reading(0.01, 1.0e-4), f32::NAN);
        let mut bad_jacobian = reading(0.01, 1.0e-4);
        bad_jacobian.jacobian.x = f32::NAN;
        t.learn(1, &bad_jacobian, 0.0);
        assert_eq!(t.iter().count(), 0);
        for id in 0..LANDMARK_OFFSET_SLOTS as u16 {
            t.learn(id, &reading(0.001 * f32::from(id), 1.0e-4), 0.0);
        }
        // Landmark 0 read again: landmark 1 is now the one read longest ago.
        t.learn(0, &reading(0.0, 1.0e-4), 0.0);
        t.learn(500, &reading(0.005, 1.0e-4), 0.0);
        assert!(t.find(1).is_none());
        assert!(t.find(0).is_some() && t.find(500).is_some());
        assert_eq!(t.iter().count(), LANDMARK_OFFSET_SLOTS);
        t.clear();
        assert_eq!(t.iter().count(), 0);
    }
}
