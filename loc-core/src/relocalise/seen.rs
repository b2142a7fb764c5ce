//! The landmarks seen since relocalisation began, in a **local frame**: where the vehicle
//! was when it began (its odometry composes the vehicle's pose in it).
//!
//! Each scan's landmark clusters ([`crate::strip::landmark_clusters`]) are reduced to their
//! **foot** — the height-weighted centroid projected onto the fitted wall, which for a
//! symmetric landmark is the centre of its base, the map's anchor — and to the wall's
//! direction there. A foot within `merge_within_m` of a landmark already seen on the same
//! side is that landmark seen again: it is averaged in. Before that, the landmarks seen
//! again re-anchor the vehicle's local pose (their offset, and with two far enough apart
//! their rotation), so that odometry drift does not accumulate while landmarks stay in view
//! (every few metres with the paper's spacing and a 20 m range): the local landmark map is
//! as rigid as the scanner's ranges, which is what makes spacing comparisons against the
//! map decisive.

use crate::filter::OdometryIncrement;
use crate::geometry::{Point2, Pose2};
use crate::math;
use crate::strip::{landmark_clusters, LandmarkCluster, PointLabel, StripSummary, VehiclePoint};

use super::RelocaliseConfig;

/// Most landmarks remembered (at the paper's 10 m spacing on both walls: about 100 m of
/// tunnel). When full, new landmarks are not added: the relocaliser starts over.
pub const MAX_SEEN: usize = 24;

/// Weight after which a landmark's position stops being a plain weighted mean (so that it
/// still follows when the first sightings were poor): about 20 sightings from close by.
const MAX_WEIGHT: f32 = 20.0;

/// Range at which a sighting weighs half as much as one from close by, metres: a far
/// landmark is sampled sparsely and seen from the side, its centroid biased by centimetres.
const HALF_WEIGHT_RANGE_M: f32 = 8.0;

/// A landmark seen in fewer than `min_sightings` scans is forgotten once it has not been
/// seen over this distance, metres.
const STALE_AFTER_M: f32 = 2.0;

/// The weight of a sighting at `range_m`.
fn sighting_weight(range_m: f32) -> f32 {
    let q = range_m / HALF_WEIGHT_RANGE_M;
    1.0 / (1.0 + q * q)
}

/// One landmark seen, local frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeenLandmark {
    /// Where it meets its wall (the foot of its centroid on the fitted wall), local frame,
    /// metres.
    pub foot_local: Point2,
    /// Unit direction of its wall there, local frame (the vehicle's forward side).
    pub tangent_local: Point2,
    /// On the vehicle's left wall (else its right).
    pub left: bool,
    /// Scans it was seen in.
    pub sightings: u16,
    /// Sum of the sightings' weights (near ones weigh more), capped.
    pub weight: f32,
    /// Distance driven when it was last seen, metres (the relocaliser's odometer).
    pub last_seen_m: f32,
}

/// One cluster of the current scan reduced to what is compared: vehicle frame.
#[derive(Debug, Clone, Copy)]
struct Foot {
    foot: Point2,
    /// Weight of this sighting (by range).
    weight: f32,
    tangent: Point2,
    left: bool,
}

/// The local landmark map and the vehicle's pose in it.
#[derive(Debug, Clone)]
pub struct SeenLandmarks {
    list: heapless::Vec<SeenLandmark, MAX_SEEN>,
    /// The vehicle in the local frame.
    vehicle_local: Pose2,
    /// Landmarks that could not be added (the list was full).
    overflowed: bool,
    /// Distance driven since relocalisation began, metres.
    odometer_m: f32,
}

impl Default for SeenLandmarks {
    fn default() -> Self {
        Self::NEW
    }
}

impl SeenLandmarks {
    /// Nothing seen, the vehicle at the local origin.
    pub const NEW: Self = Self {
        list: heapless::Vec::new(),
        vehicle_local: Pose2::IDENTITY,
        overflowed: false,
        odometer_m: 0.0,
    };

    /// The landmarks seen so far.
    pub fn landmarks(&self) -> &[SeenLandmark] {
        &self.list
    }

    /// How many landmarks were seen in `min_sightings` scans or more (the ones the search
    /// uses).
    pub fn established(&self, min_sightings: u16) -> usize {
        self.list
            .iter()
            .filter(|s| s.sightings >= min_sightings)
            .count()
    }

    /// The vehicle's pose in the local frame.
    pub fn vehicle_local(&self) -> Pose2 {
        self.vehicle_local
    }

    /// Whether a landmark had to be dropped because the list was full.
    pub fn overflowed(&self) -> bool {
        self.overflowed
    }

    /// Moves the vehicle by an odometry (or constant-velocity) increment, vehicle frame.
    /// A non-finite increment is ignored.
    pub fn advance(&mut self, increment: &OdometryIncrement) {
        let moved = self.vehicle_local.compose(&increment.as_pose());
        if moved.is_finite() {
            self.vehicle_local = moved;
            self.odometer_m += increment.distance_m();
        }
    }

    /// Adds one stripped scan (vehicle-frame points in beam order with their labels):
    /// re-anchors the vehicle on the landmarks seen before, then merges or adds each of the
    /// scan's landmarks (appended: the indices of those seen before stay). With `prune`, it
    /// first forgets the clusters seen too few times that have not been seen again (which
    /// moves the indices). Returns how many landmarks were added and whether any was
    /// forgotten.
    pub fn observe<P: VehiclePoint>(
        &mut self,
        points: &[P],
        labels: &[PointLabel],
        strip: &StripSummary,
        config: &RelocaliseConfig,
        prune: bool,
    ) -> (usize, bool) {
        let clusters = landmark_clusters(
            points,
            labels,
            strip,
            config.max_cluster_gap_m,
            config.min_cluster_points,
        );
        // The peaks of one landmark (free shapes) are one landmark.
        let mut landmarks: heapless::Vec<LandmarkCluster, { crate::strip::MAX_CLUSTERS }> =
            heapless::Vec::new();
        let width_sq = config.max_landmark_width_m * config.max_landmark_width_m;
        for c in clusters {
            match landmarks.last_mut() {
                Some(last) if last.centroid().dist_sq(c.centroid()) <= width_sq => {
                    *last = last.merged(c);
                }
                _ => {
                    let _ = landmarks.push(c);
                }
            }
        }
        let mut feet: heapless::Vec<Foot, { crate::strip::MAX_CLUSTERS }> = heapless::Vec::new();
        for c in &landmarks {
            let centroid = c.centroid();
            if centroid.norm_sq() > config.max_range_m * config.max_range_m {
                continue;
            }
            if let Some(f) = foot(strip, centroid, config.min_height_m) {
                let _ = feet.push(f);
            }
        }
        self.reanchor(&feet, config);
        // A cluster seen in fewer than `min_sightings` scans and not again over a few metres
        // moved with the vehicle or was a glint: not a landmark, and it must not fill the
        // list.
        let odometer_m = self.odometer_m;
        let before = self.list.len();
        if prune {
            self.list.retain(|s| {
                s.sightings >= config.min_sightings || odometer_m - s.last_seen_m <= STALE_AFTER_M
            });
        }
        let pruned = self.list.len() != before;
        let mut added = 0;
        for f in &feet {
            let p = self.vehicle_local.transform_point(f.foot);
            let t = self.vehicle_local.rotate_vector(f.tangent);
            match self.nearest(p, f.left, config.merge_within_m) {
                Some(i) => {
                    if let Some(s) = self.list.get_mut(i) {
                        let k = f.weight / (s.weight + f.weight);
                        s.foot_local = s.foot_local.add(p.sub(s.foot_local).scale(k));
                        let tangent = s.tangent_local.add(t.sub(s.tangent_local).scale(k));
                        let len = tangent.norm();
                        if len > 1e-6 {
                            s.tangent_local = tangent.scale(1.0 / len);
                        }
                        s.sightings = s.sightings.saturating_add(1);
                        s.last_seen_m = odometer_m;
                        s.weight = math::min(s.weight + f.weight, MAX_WEIGHT);
                    }
                }
                None => {
                    let new = SeenLandmark {
                        foot_local: p,
                        tangent_local: t,
                        left: f.left,
                        sightings: 1,
                        weight: f.weight,
                        last_seen_m: odometer_m,
                    };
                    if self.list.push(new).is_ok() {
                        added += 1;
                    } else {
                        self.overflowed = true;
                    }
                }
            }
        }
        (added, pruned)
    }

    /// The seen landmark on side `left` nearest to `p` (local frame) within `within_m`.
    fn nearest(&self, p: Point2, left: bool, within_m: f32) -> Option<usize> {
        let mut best: Option<(usize, f32)> = None;
        for (i, s) in self.list.iter().enumerate() {
            if s.left != left {
                continue;
            }
            let d = s.foot_local.dist_sq(p);
            if d <= within_m * within_m && best.is_none_or(|(_, b)| d < b) {
                best = Some((i, d));
            }
        }
        best.map(|(i, _)| i)
    }

    /// Corrects the vehicle's local pose so that this scan's landmarks seen before land on
    /// their remembered positions: the weighted mean offset, and the rotation about their
    /// centroid when two or more span `min_rotation_span_m`. Weighted as a mean of the
    /// remembered sightings and this one (a landmark seen once pulls half way).
    fn reanchor(&mut self, feet: &[Foot], config: &RelocaliseConfig) {
        // Pairs (remembered, observed now) in the local frame, with weights.
        let mut pairs: heapless::Vec<(Point2, Point2, f32), { crate::strip::MAX_CLUSTERS }> =
            heapless::Vec::new();
        for f in feet {
            let p = self.vehicle_local.transform_point(f.foot);
            if let Some(s) = self
                .nearest(p, f.left, config.merge_within_m)
                .and_then(|i| self.list.get(i))
                .filter(|s| s.sightings >= config.min_sightings)
            {
                // As precise as the remembered position and this sighting together.
                let w = s.weight * f.weight / (s.weight + f.weight);
                let _ = pairs.push((s.foot_local, p, w));
            }
        }
        let total: f32 = pairs.iter().map(|p| p.2).sum();
        if pairs.is_empty() || total <= 0.0 {
            return;
        }
        // The vehicle's local pose after odometry weighs as one sighting from close by.
        let gain = total / (total + 1.0);
        let mean = |pick: fn(&(Point2, Point2, f32)) -> Point2| {
            pairs
                .iter()
                .fold(Point2::ORIGIN, |acc, q| acc.add(pick(q).scale(q.2 / total)))
        };
        let remembered = mean(|q| q.0);
        let observed = mean(|q| q.1);
        // Rotation (2-D Procrustes about the centroids) when the pairs span enough.
        let span_sq = pairs
            .iter()
            .map(|q| q.1.dist_sq(observed))
            .fold(0.0f32, math::max);
        let mut rotation = 0.0;
        if pairs.len() >= 2
            && span_sq >= 0.25 * config.min_rotation_span_m * config.min_rotation_span_m
        {
            let (mut cross, mut dot) = (0.0f32, 0.0f32);
            for q in &pairs {
                let a = q.1.sub(observed);
                let b = q.0.sub(remembered);
                cross += q.2 * a.cross(b);
                dot += q.2 * a.dot(b);
            }
            rotation = math::atan2(cross, dot) * gain;
        }
        // Rotate the vehicle about the observed centroid, then shift it.
        let about = observed;
        let v = self.vehicle_local.translation().sub(about);
        let (s, c) = math::sin_cos(rotation);
        let rotated = Point2::new(c * v.x_m - s * v.y_m, s * v.x_m + c * v.y_m).add(about);
        let shift = remembered.sub(observed).scale(gain);
        let corrected = Pose2::new(
            rotated.x_m + shift.x_m,
            rotated.y_m + shift.y_m,
            self.vehicle_local.theta_rad + rotation,
        );
        if corrected.is_finite() {
            self.vehicle_local = corrected;
        }
    }
}

/// The foot of a cluster centroid (vehicle frame) on the nearer fitted wall, with the
/// wall's direction there; `None` without a wall, or for a centroid more than half a metre
/// off it, less than `min_height_m` or behind it (not a landmark on the wall).
fn foot(strip: &StripSummary, centroid: Point2, min_height_m: f32) -> Option<Foot> {
    let distance = |w: &crate::strip::WallFit| math::abs(w.cubic.signed_distance_m(centroid));
    let (wall, left) = match (&strip.left, &strip.right) {
        (Some(l), Some(r)) => {
            if distance(l) <= distance(r) {
                (l, true)
            } else {
                (r, false)
            }
        }
        (Some(l), None) => (l, true),
        (None, Some(r)) => (r, false),
        (None, None) => return None,
    };
    let x = centroid.x_m;
    let y_wall = wall.cubic.eval(x);
    // Inward: a left landmark stands below its wall (smaller y), a right one above.
    let inward = if left {
        y_wall - centroid.y_m
    } else {
        centroid.y_m - y_wall
    };
    if !(min_height_m..=0.5).contains(&inward) {
        return None;
    }
    let foot = Point2::new(x, y_wall);
    let tangent = wall.cubic.tangent(x);
    (foot.is_finite() && tangent.is_finite()).then_some(Foot {
        foot,
        weight: sighting_weight(centroid.norm()),
        tangent,
        left,
    })
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::landmark::LandmarkModel;
    use crate::map::TunnelMap;
    use crate::scan::{Scan, SensorSetup, LMS511_MAX_BEAMS};
    use crate::strip::{strip_walls, StripConfig};
    use crate::testkit::{LandmarkLayout, ScanSimulator, TunnelSpec};

    /// Drives 30 m along a straight test-kit tunnel with odometry 3 % long and turning
    /// 1 mrad per metre too much, feeding every scan (every 0.1 m) to `seen`.
    fn drive(seen: &mut SeenLandmarks) -> std::boxed::Box<TunnelMap> {
        let mut map = std::boxed::Box::new(TunnelMap::new());
        TunnelSpec::straight(200.0)
            .with_landmarks(LandmarkLayout::paper(LandmarkModel::P1Triangle, 4))
            .build_into(&mut *map)
            .unwrap();
        let mut sim = ScanSimulator::new(8);
        let mut scan = std::boxed::Box::new(Scan::new());
        let mut labels = std::vec![PointLabel::Outlier; LMS511_MAX_BEAMS];
        let config = RelocaliseConfig::DEFAULT;
        for k in 0..300 {
            let truth = Pose2::new(50.0 + 0.1 * k as f32, 0.4, 0.0);
            if k > 0 {
                seen.advance(&OdometryIncrement {
                    dx_m: 0.103,
                    dy_m: 0.0,
                    dtheta_rad: 1e-4,
                });
            }
            sim.simulate_scan(
                &*map,
                &truth,
                &SensorSetup::default(),
                LMS511_MAX_BEAMS,
                &mut scan,
            );
            let n = scan.points().len();
            let strip = strip_walls(scan.points(), &StripConfig::default(), &mut labels[..n]);
            seen.observe(scan.points(), &labels[..n], &strip, &config, true);
        }
        map
    }

    #[test]
    fn the_local_landmark_map_is_as_rigid_as_the_scanner_despite_odometry_drift() {
        let mut seen = SeenLandmarks::NEW;
        let map = drive(&mut seen);
        let established: std::vec::Vec<&SeenLandmark> = seen
            .landmarks()
            .iter()
            .filter(|s| s.sightings >= RelocaliseConfig::DEFAULT.min_sightings)
            .collect();
        // 30 m driven with a 20 m reach: the landmarks of ≈ 50 m on both walls.
        assert!(established.len() >= 8, "{}", established.len());
        // Each seen landmark's true counterpart: the map landmark on its wall nearest to
        // where the first one maps it (the local frame starts at the first true pose).
        let start = Pose2::new(50.0, 0.4, 0.0);
        let truth: std::vec::Vec<Point2> = established
            .iter()
            .map(|s| {
                let w = start.transform_point(s.foot_local);
                map.landmarks()
                    .iter()
                    .map(|l| l.frame.anchor)
                    .min_by(|a, b| a.dist(w).partial_cmp(&b.dist(w)).unwrap())
                    .unwrap()
            })
            .collect();
        // Distances between seen landmarks are the map's within the spread the search
        // allows for them (5 cm + 0.3 % of the span: ≈ 0.1 m over 40 m), though the
        // odometry alone would be 3 % (up to 1.5 m) off over these spans: the landmarks
        // seen again hold the local frame.
        let c = RelocaliseConfig::DEFAULT;
        let mut worst = 0.0f32;
        for i in 0..established.len() {
            for j in i + 1..established.len() {
                let d_seen = established[i].foot_local.dist(established[j].foot_local);
                let d_true = truth[i].dist(truth[j]);
                let sigma = c.sigma_m + c.sigma_per_m * d_true;
                worst = worst.max((d_seen - d_true).abs() / sigma);
            }
        }
        assert!(worst < 1.5, "worst spacing error {worst:.2} σ");
    }

    #[test]
    fn a_full_list_says_so_and_adds_nothing() {
        let mut seen = SeenLandmarks::NEW;
        for i in 0..MAX_SEEN {
            let _ = seen.list.push(SeenLandmark {
                foot_local: Point2::new(-1000.0 - 10.0 * i as f32, 2.5),
                tangent_local: Point2::new(1.0, 0.0),
                left: true,
                sightings: 10,
                weight: 1.0,
                last_seen_m: 0.0,
            });
        }
        assert!(!seen.overflowed());
        drive(&mut seen);
        assert_eq!(seen.landmarks().len(), MAX_SEEN);
        assert!(seen.overflowed());
    }
}
