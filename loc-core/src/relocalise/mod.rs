//! Global relocalisation: where along the tunnel is the vehicle, with no pose to start from
//! (power-up) or after the localizer declared itself lost?
//!
//! Walls alone cannot say — every stretch of a smooth tunnel looks alike — but the
//! landmarks' spacing can: the paper draws each spacing from `U[D − 0.625, D + 0.625]` m
//! (§4.4) precisely so that a run of consecutive spacings is unique along the tunnel. The
//! relocaliser
//! 1. gathers the landmarks seen while driving into a local landmark map, rigid to the
//!    scanner's precision ([`seen`]: feet of the landmark clusters on the fitted walls,
//!    the vehicle re-anchored on the landmarks it sees again);
//! 2. searches, a round at a time, for the placement of that local map among the map's
//!    landmarks that explains it ([`search`]), spreading each round over scans by a work
//!    budget so that no scan costs more than the tracking one, whatever the map's length;
//! 3. locks only when the best placement explains the landmarks seen and beats every
//!    other placement by `win_margin` (a chi-square difference: `e^{margin/2}` in
//!    likelihood); until then the localizer reports
//!    [`crate::localizer::Status::Relocalising`].
//!
//! The lock hands the localizer a starting pose; the localizer then tracks as usual but
//! reports [`crate::localizer::Status::MapUnconfirmed`] until the landmarks have fitted
//! over the integrity monitor's confirmation distance: a wrong lock is never reported as
//! tracking. Fixed memory (≈ 0.8 KiB), no allocation.

pub mod search;
pub mod seen;

pub use search::{Candidate, Round};
pub use seen::{SeenLandmark, SeenLandmarks, MAX_SEEN};

use crate::filter::OdometryIncrement;
use crate::geometry::Pose2;
use crate::map::MapQuery;
use crate::strip::{PointLabel, StripSummary, VehiclePoint};

/// Tuning of the relocaliser and of when the localizer declares itself lost.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RelocaliseConfig {
    /// Relocalise by itself when lost (after `lost_after_m` of scans that were rejected or
    /// left the map unconfirmed). Relocalisation on request
    /// ([`crate::localizer::Localizer::relocalise`]) works either way.
    pub enabled: bool,
    /// Distance driven with every scan rejected or unconfirmed after which the localizer
    /// declares itself lost, metres. One bad scan never does.
    pub lost_after_m: f32,
    /// Matches the filter's gate refuses (the innovation test) while the map is in doubt
    /// after which the localizer declares itself lost at once, without waiting for
    /// `lost_after_m` (a kidnapping: every match then disagrees with the prediction). Two
    /// in a row already stop it reporting tracking until the map is confirmed again.
    pub lost_after_gate_failures: u8,
    /// Landmark clusters farther than this from the vehicle are not used, metres (far ones
    /// are sparsely sampled, their centroids biased).
    pub max_range_m: f32,
    /// Consecutive landmark points farther apart than this start a new cluster, metres.
    pub max_cluster_gap_m: f32,
    /// Fewest points in a cluster.
    pub min_cluster_points: u16,
    /// A cluster whose height-weighted centroid stands less than this off its fitted wall
    /// is not taken for a landmark, metres: shotcrete bumps near the vehicle (a few
    /// centimetres, seen in several scans) would otherwise join the local landmark map as
    /// landmarks no map holds. Keep it below two thirds of the map's landmark heights.
    pub min_height_m: f32,
    /// Consecutive clusters of one scan whose centroids lie closer than this are one
    /// landmark (a free shape's peaks), metres: about the widest landmark's width.
    pub max_landmark_width_m: f32,
    /// A cluster within this of a landmark seen before on the same side is that landmark,
    /// metres (well below the spacing D, well above the odometry's drift between scans).
    pub merge_within_m: f32,
    /// Scans a landmark must have been seen in before the search uses it (and before it
    /// re-anchors the vehicle): a cluster that moves with the vehicle (a wall bulge the
    /// stripper's fit misses, a person walking alongside) is never seen twice in one place.
    pub min_sightings: u16,
    /// Landmarks seen again re-anchor the vehicle's heading when they span this much,
    /// metres.
    pub min_rotation_span_m: f32,
    /// Along-wall spread of a seen landmark against its map landmark near the reference,
    /// metres (centroid bias and wall fit).
    pub sigma_m: f32,
    /// Growth of that spread per metre from the reference (what is left of the odometry's
    /// drift and the heading's error), metres per metre.
    pub sigma_per_m: f32,
    /// A seen landmark farther than this off a map landmark's base line is not that
    /// landmark, metres.
    pub max_normal_m: f32,
    /// Cost of a seen landmark no map landmark explains (cap of its chi-square).
    pub outlier_cost: f32,
    /// The best placement must cost this much less than the runner-up (chi-square units).
    pub win_margin: f32,
    /// Seen landmarks the best placement must explain, the reference included.
    pub min_explained: u8,
    /// Of the seen landmarks, at most this fraction may be left unexplained by the winner
    /// (people, equipment, landmarks missing from the map).
    pub max_unexplained_fraction: f32,
    /// Of the map landmarks the winner puts beside the vehicle's way, more than this
    /// fraction unseen refuses it (some are missing or damaged in every tunnel; a wrong
    /// placement where the vehicle saw only a few landmarks puts many where none was).
    pub max_unseen_fraction: f32,
    /// New landmarks that must be established after a round's winner before it locks, each
    /// one more round it must win with the same placement.
    pub confirm_new_landmarks: u8,
    /// Map landmarks the winner puts within this of the vehicle's way must have been seen,
    /// metres (the scanner's clusters form within about 10 m).
    pub passed_within_m: f32,
    /// Map queries per scan for the search (a query costs about 3 000 instructions on a
    /// Cortex-M4F: 150 keep a relocalising scan near 1 million with the telegram and the
    /// stripping).
    pub work_per_scan: u32,
    /// Standard deviations of the pose handed over at the lock: position (metres), heading
    /// (radians).
    pub lock_sigma: [f32; 2],
}

impl RelocaliseConfig {
    /// The defaults (what [`Default`] gives), usable in `const` and `static` items.
    pub const DEFAULT: Self = Self {
        enabled: true,
        lost_after_m: 8.0,
        lost_after_gate_failures: 5,
        max_range_m: 20.0,
        max_cluster_gap_m: 0.3,
        min_cluster_points: 4,
        min_height_m: 0.06,
        max_landmark_width_m: 1.2,
        merge_within_m: 0.75,
        min_sightings: 5,
        min_rotation_span_m: 6.0,
        sigma_m: 0.05,
        sigma_per_m: 0.003,
        max_normal_m: 0.4,
        outlier_cost: 9.0,
        win_margin: 12.0,
        min_explained: 4,
        max_unexplained_fraction: 0.25,
        max_unseen_fraction: 0.5,
        passed_within_m: 6.0,
        confirm_new_landmarks: 1,
        work_per_scan: 150,
        lock_sigma: [0.15, 0.02],
    };

    /// The values a configuration record must hold to be usable (finite, positive where a
    /// scale, ordered where a range).
    pub fn is_usable(&self) -> bool {
        let positive = [
            self.lost_after_m,
            self.min_height_m,
            self.max_landmark_width_m,
            self.max_range_m,
            self.max_cluster_gap_m,
            self.merge_within_m,
            self.min_rotation_span_m,
            self.sigma_m,
            self.max_normal_m,
            self.passed_within_m,
            self.outlier_cost,
            self.win_margin,
            self.lock_sigma[0],
            self.lock_sigma[1],
        ];
        positive.iter().all(|v| v.is_finite() && *v > 0.0)
            && self.sigma_per_m.is_finite()
            && self.sigma_per_m >= 0.0
            && (0.0..1.0).contains(&self.max_unexplained_fraction)
            && (0.0..1.0).contains(&self.max_unseen_fraction)
            && self.min_explained >= 2
            && self.min_sightings >= 1
            && self.lost_after_gate_failures >= 1
            && self.work_per_scan > 0
    }
}

impl Default for RelocaliseConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Where a relocalisation stands (for the status and the log).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RelocaliseProgress {
    /// Landmarks in the local landmark map seen often enough to be used
    /// (`min_sightings`).
    pub landmarks_seen: u8,
    /// Search rounds finished.
    pub rounds: u16,
    /// Seen landmarks the best placement of the last round explained.
    pub best_explained: u8,
    /// How much cheaper the best placement of the last round was than the runner-up
    /// (chi-square units; infinite without a runner-up, 0 before the first round).
    pub lead: f32,
    /// Distance driven since relocalisation began, metres.
    pub distance_m: f32,
    /// Map landmarks the last winning placement put beside the vehicle's way that were not
    /// seen (a winner with too many is refused).
    pub unseen: u8,
}

/// A lock: the vehicle's pose in the world and the placement that gave it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lock {
    /// The vehicle now, world frame.
    pub pose: Pose2,
    /// The winning placement.
    pub candidate: Candidate,
    /// How much cheaper it was than the runner-up (infinite without one).
    pub lead: f32,
}

/// The relocaliser's state: the local landmark map, the round in progress, progress.
#[derive(Debug, Clone)]
pub struct Relocaliser {
    seen: SeenLandmarks,
    round: Option<Round>,
    /// Seen landmarks tried as the reference since the last new landmark (bit `i`).
    tried: u32,
    progress: RelocaliseProgress,
    /// A winner waiting for new landmarks to confirm it, with the established landmarks
    /// it won on.
    pending: Option<(Candidate, u8)>,
}

impl Default for Relocaliser {
    fn default() -> Self {
        Self::NEW
    }
}

impl Relocaliser {
    /// Nothing seen yet.
    pub const NEW: Self = Self {
        seen: SeenLandmarks::NEW,
        round: None,
        tried: 0,
        pending: None,
        progress: RelocaliseProgress {
            landmarks_seen: 0,
            rounds: 0,
            best_explained: 0,
            lead: 0.0,
            distance_m: 0.0,
            unseen: 0,
        },
    };

    /// Forgets everything and starts over with the vehicle at the local origin.
    pub fn restart(&mut self) {
        *self = Self::NEW;
    }

    /// Where the relocalisation stands.
    pub fn progress(&self) -> RelocaliseProgress {
        self.progress
    }

    /// The local landmark map.
    pub fn seen(&self) -> &SeenLandmarks {
        &self.seen
    }

    /// Moves the vehicle by a motion increment (vehicle frame).
    pub fn advance(&mut self, increment: &OdometryIncrement) {
        self.seen.advance(increment);
        let d = increment.distance_m();
        if d.is_finite() {
            self.progress.distance_m += d;
        }
    }

    /// Adds one stripped scan and runs the search for at most `config.work_per_scan` map
    /// queries; returns the lock when a round ends with a winner.
    pub fn update<M: MapQuery, P: VehiclePoint>(
        &mut self,
        map: &M,
        points: &[P],
        labels: &[PointLabel],
        strip: &StripSummary,
        config: &RelocaliseConfig,
    ) -> Option<Lock> {
        // A round refers to the seen landmarks by index: nothing is forgotten during one.
        let (added, pruned) =
            self.seen
                .observe(points, labels, strip, config, self.round.is_none());
        if added > 0 || pruned {
            // New evidence (or indices moved): every landmark may be the reference again.
            self.tried = 0;
        }
        if self.seen.overflowed() && self.round.is_none() {
            // A hundred metres of landmarks without a unique placement: start over rather
            // than keep evidence that may hold a false cluster at its core.
            let distance_m = self.progress.distance_m;
            self.restart();
            self.progress.distance_m = distance_m;
            return None;
        }
        let established = self.seen.established(config.min_sightings);
        self.progress.landmarks_seen = u8::try_from(established).unwrap_or(u8::MAX);
        if self.round.is_none() {
            self.round = self.next_round(config);
        }
        let mut round = self.round?;
        round.run(map, self.seen.landmarks(), config, config.work_per_scan);
        if !round.is_finished(map) {
            self.round = Some(round);
            return None;
        }
        self.round = None;
        self.progress.rounds = self.progress.rounds.saturating_add(1);
        self.verdict(map, &round, config)
    }

    /// The next round: the untried seen landmark seen most often as the reference, once
    /// enough landmarks are seen.
    fn next_round(&mut self, config: &RelocaliseConfig) -> Option<Round> {
        let seen = self.seen.landmarks();
        let established = self.seen.established(config.min_sightings);
        if established < usize::from(config.min_explained) {
            return None;
        }
        let (i, _) = seen
            .iter()
            .enumerate()
            .filter(|(i, s)| self.tried & (1 << i) == 0 && s.sightings >= config.min_sightings)
            .max_by_key(|(_, s)| s.sightings)?;
        self.tried |= 1 << i;
        Some(Round::new(
            u8::try_from(i).ok()?,
            u8::try_from(seen.len()).ok()?,
            u8::try_from(established).ok()?,
        ))
    }

    /// A finished round's verdict: the lock, or `None` while the evidence is ambiguous.
    fn verdict<M: MapQuery>(
        &mut self,
        map: &M,
        round: &Round,
        config: &RelocaliseConfig,
    ) -> Option<Lock> {
        let best = round.best?;
        let lead = round
            .second
            .map_or(f32::INFINITY, |second| second.cost - best.cost);
        self.progress.best_explained = best.explained;
        self.progress.lead = lead;
        let n = f32::from(round.established);
        let unexplained = n - f32::from(best.explained);
        let wins = best.explained >= config.min_explained
            && unexplained <= config.max_unexplained_fraction * n
            && lead >= config.win_margin;
        if !wins {
            return None;
        }
        // The negative evidence, for the winner only: the map landmarks it puts beside the
        // way must have been seen.
        let (passed, unseen) = search::unseen_landmarks(
            map,
            self.seen.landmarks(),
            self.seen.vehicle_local(),
            &best,
            config,
        );
        self.progress.unseen = unseen;
        if f32::from(unseen) > config.max_unseen_fraction * f32::from(passed) {
            return None;
        }
        // The winner must win again once new landmarks are established: a placement that
        // explains the first landmarks by chance (the §4.4 jitter makes it rare, not
        // impossible: a few per hundred power-ups with wide flat landmarks) does not
        // explain the next ones.
        let established = round.established;
        match self.pending {
            Some((p, at)) if same_placement(&p.local_to_world, &best.local_to_world) => {
                if established < at.saturating_add(config.confirm_new_landmarks) {
                    return None;
                }
            }
            _ => {
                self.pending = Some((best, established));
                if config.confirm_new_landmarks > 0 {
                    return None;
                }
            }
        }
        let pose = best.local_to_world.compose(&self.seen.vehicle_local());
        pose.is_finite().then_some(Lock {
            pose,
            candidate: best,
            lead,
        })
    }
}

/// Whether two placements of the local frame are the same (within half a metre and 3°).
fn same_placement(a: &Pose2, b: &Pose2) -> bool {
    a.translation().dist(b.translation()) <= 0.5
        && crate::math::abs(crate::math::wrap_angle(a.theta_rad - b.theta_rad)) <= 0.05
}
