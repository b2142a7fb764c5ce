//! Which map landmark each scan saw, and where: the prior map's landmarks as fit models,
//! and per keyframe one fitted landmark pose ([`super::landmark_fit`]) for every landmark
//! of the prior map in range.
//!
//! A landmark is identified by where the localiser's pose against the prior map predicts
//! it: landmarks are metres apart (§4.4 spacing, every window of them unique) and the
//! prediction is centimetres off, so a fit that lands more than its `max_shift_m` away is
//! not that landmark and is dropped. Landmark points no prior landmark explains are
//! counted per keyframe: a landmark installed but not in the design shows up there.

use loc_core::map::{TunnelMap, WallSide};
use loc_core::strip::PointLabel;

use super::graph::Relative;
use super::keyframes::Keyframe;
use super::landmark_fit::{fit_in_scan, FitConfig, FitModel};
use crate::vehicle::SimPose;

/// One landmark of the prior map, ready to be fitted.
#[derive(Debug, Clone)]
pub struct PriorLandmark {
    /// Its frame in the prior map (origin: centre of its base on the wall; x along the
    /// wall), world frame.
    pub frame: SimPose,
    /// The wall it is on.
    pub wall: WallSide,
    /// What is fitted to the scans.
    pub model: FitModel,
}

/// The prior map's landmarks as fit models, in map order.
pub fn prior_landmarks(map: &TunnelMap, config: &FitConfig) -> Vec<PriorLandmark> {
    map.landmarks()
        .iter()
        .map(|lm| {
            let f = lm.frame;
            let profile: Vec<(f64, f64)> = crate::stored_map::landmark_vertices(map, lm)
                .iter()
                .map(|&p| {
                    let q = f.to_landmark(p);
                    (f64::from(q.x_m), f64::from(q.y_m))
                })
                .collect();
            let inward_left =
                f.tangent.x_m * f.inward_normal.y_m - f.tangent.y_m * f.inward_normal.x_m > 0.0;
            PriorLandmark {
                frame: SimPose::new(
                    f64::from(f.anchor.x_m),
                    f64::from(f.anchor.y_m),
                    f64::from(f.tangent.y_m).atan2(f64::from(f.tangent.x_m)),
                ),
                wall: lm.placement.wall,
                model: FitModel::new(&profile, inward_left, config.wall_run_m),
            }
        })
        .collect()
}

/// What one keyframe saw.
#[derive(Debug, Clone, Default)]
pub struct Seen {
    /// One fitted landmark each (`from` = the keyframe, `to` = the landmark).
    pub fixes: Vec<Relative>,
    /// Prior landmarks in range whose fit failed (hidden, missing, moved away).
    pub failed: Vec<usize>,
    /// Landmark-labelled points within range no prior landmark covers, world frame (at the
    /// localiser's pose).
    pub unexplained: Vec<(f64, f64)>,
}

/// Fits every prior landmark within `range_m` of keyframe `k`'s pose.
pub fn observe(
    kf: &Keyframe,
    k: usize,
    landmarks: &[PriorLandmark],
    range_m: f64,
    config: &FitConfig,
) -> Seen {
    let mut seen = Seen::default();
    let near: Vec<(usize, SimPose)> = landmarks
        .iter()
        .enumerate()
        .filter(|(_, l)| (l.frame.x_m - kf.guess.x_m).hypot(l.frame.y_m - kf.guess.y_m) <= range_m)
        .map(|(j, l)| (j, kf.guess.between(l.frame)))
        .collect();
    let mut covered = vec![false; kf.points.len()];
    for &(j, t0) in &near {
        let model = &landmarks[j].model;
        match fit_in_scan(model, &kf.points, t0, config) {
            Some(f) => {
                // Explained: what lies on the landmark where it was fitted (not the wall
                // runs around it, where a landmark moved a little way off its mark shows).
                for (p, c) in kf.points.iter().zip(covered.iter_mut()) {
                    *c |= model.covers_landmark(f.pose.apply_inverse(*p));
                }
                seen.fixes.push(Relative {
                    from: k,
                    to: j,
                    z: f.pose,
                    covariance: f.covariance,
                });
            }
            None => seen.failed.push(j),
        }
    }
    seen.unexplained = kf
        .points
        .iter()
        .zip(&kf.labels)
        .zip(&covered)
        .filter(|((p, l), c)| **l == PointLabel::Landmark && !**c && p.0.hypot(p.1) <= range_m)
        .map(|((p, _), _)| kf.guess.apply(*p))
        .collect();
    seen
}
