//! The modified-Hausdorff matcher: iteratively reweighted Gauss–Newton on the K best
//! point-to-map distances with re-association and re-selection every iteration, and
//! Levenberg damping on the Hausdorff cost (see the module docs of [`super`]).

use super::association::{select_k_best, AssociationSchedule};
use super::information::{truncated_step, NormalEquations};
use super::landmark_gate;
use super::landmark_offsets::{LandmarkAnchors, OffsetPriors};
use super::misfit::{unpair_landmarks, Misfits};
use super::roughness::RoughWalls;
use super::{
    apply_step, conclude, out_of_work, step_size, KBest, MatchConfig, MatchError, MatchWorkspace,
    Outcome, Steps, MAX_MATCH_POINTS,
};
use crate::geometry::{Point2, Pose2};
use crate::map::MapQuery;
use crate::math;
use nalgebra::Vector3;

pub(super) fn run<M: MapQuery>(
    map: &M,
    points: &[Point2],
    initial: Pose2,
    config: &MatchConfig,
    schedule: &mut AssociationSchedule,
    workspace: &mut MatchWorkspace,
) -> Result<Outcome, MatchError> {
    let MatchWorkspace {
        assoc,
        keys,
        landmark_offsets: offsets,
        landmark_gate: gate,
        gate_memory,
        fitted_landmarks,
        ..
    } = workspace;
    let m = points.len().min(assoc.len());
    let assoc = assoc.get_mut(..m).unwrap_or_default();
    let k_fraction = if config.k_fraction.is_finite() {
        config.k_fraction.clamp(0.05, 1.0)
    } else {
        0.8
    };
    let mut k = ((k_fraction * m as f32 + 0.5) as usize).clamp(1, m.max(1));
    let explained_m = config.explained_distance_m();
    let required = usize::from(config.min_points.max(3));
    // IRLS floor: residuals below the noise all weigh the same.
    let delta_m = math::max(config.range_noise_sigma_m, 1.0e-3);

    let mut pose = initial;
    let mut best: Option<(Pose2, f32, NormalEquations)> = None;
    let mut damping = 0.0f32;
    let mut last_accepted_step: Option<Vector3<f32>> = None;
    let mut steps = Steps::new();
    let mut iterations = 0u16;
    // Whether the loop ended at an optimum rather than by running out of work or iterations.
    let mut converged = false;
    // Landmarks left out once the match had converged (see `misfit`); judged once.
    let mut misfits: Option<Misfits> = None;
    // How far misfits found too late to leave out may have drawn the match, metres.
    let mut misfit_pull_m = 0.0f32;
    // Each landmark's anchor, looked up once for the whole match.
    let mut anchors = LandmarkAnchors::new(initial);
    for it in 1..=config.max_iterations.max(1) {
        iterations = it;
        let mut associated = schedule.run(map, points, pose, config.association_gate_m, assoc);
        if let Some(m) = misfits.as_ref() {
            let left_out = m.unpair(assoc, config.association_gate_m);
            associated = associated.saturating_sub(left_out);
        }
        if gate.is_some() {
            // Landmarks an earlier gated match found not as mapped.
            let left_out = unpair_landmarks(assoc, gate_memory.ids(), config.association_gate_m);
            associated = associated.saturating_sub(left_out);
        }
        if it == 1 && explained_m > 0.0 {
            // Fixed for the whole match, so that the costs compared stay comparable.
            let within = assoc
                .iter()
                .filter(|a| a.associated() && a.distance_m <= explained_m)
                .count();
            k = k.max(within).min(m.max(1));
        }
        let kth = select_k_best(assoc, keys, k).unwrap_or(config.association_gate_m);
        let best_k = keys.get(..k).unwrap_or_default();
        let cost = match config.k_best {
            KBest::TrimmedMean => best_k.iter().map(|key| key.0).sum::<f32>() / k as f32,
            KBest::KthRanked => kth,
        };
        // Re-selecting the K best makes the cost jitter at the noise level near the optimum:
        // a step that raises it by less than 1 % of σ still counts as progress.
        let slack = 0.01 * delta_m;
        let improved = best.as_ref().is_none_or(|(_, c, _)| cost <= *c + slack);
        if improved {
            if associated < required {
                if best.is_none() {
                    return Err(MatchError::TooFewAssociations {
                        associated: crate::math::saturating_u16(associated),
                        required: crate::math::saturating_u16(required),
                    });
                }
            } else {
                let mut eq = NormalEquations::default();
                let mut walls = RoughWalls::new(
                    &config.roughness,
                    config.range_noise_sigma_m,
                    pose.theta_rad,
                );
                let w_unit = match config.k_best {
                    KBest::TrimmedMean => 1.0 / delta_m,
                    KBest::KthRanked => 1.0,
                };
                let weight = |r: f32| match config.k_best {
                    KBest::TrimmedMean => 1.0 / math::max(math::abs(r), delta_m),
                    KBest::KthRanked => 1.0,
                };
                let t = pose.translation();
                // Smooth walls take the plain loop, in any order: the firmware's budget has no
                // room for the rough walls' bookkeeping when it models nothing.
                match walls.as_mut() {
                    None => {
                        let selected = best_k
                            .iter()
                            .filter_map(|key| assoc.get(usize::from(key.1)))
                            .filter(|a| a.associated());
                        for a in selected {
                            let r = a.residual_m();
                            eq.add(a.world, t, a.normal, r, weight(r));
                        }
                    }
                    Some(rw) => {
                        // In scan order, which runs along each wall (the introselect
                        // left the K best in no order).
                        let mut chosen = [0u32; MAX_MATCH_POINTS / 32];
                        for key in best_k {
                            let i = usize::from(key.1);
                            if let Some(bits) = chosen.get_mut(i / 32) {
                                *bits |= 1 << (i % 32);
                            }
                        }
                        let is_chosen = |i: usize| {
                            chosen
                                .get(i / 32)
                                .is_some_and(|bits| bits & (1 << (i % 32)) != 0)
                        };
                        let selected = assoc
                            .iter()
                            .enumerate()
                            .filter(|&(i, a)| a.associated() && is_chosen(i));
                        let mut priors = OffsetPriors::new(offsets);
                        anchors.place(pose);
                        for (_, a) in selected {
                            let r = a.residual_m();
                            let p = points.get(usize::from(a.point)).copied();
                            let p = anchors.point(map, a.landmark(), p.unwrap_or(Point2::ORIGIN));
                            priors.before_point(rw, &mut eq, a.landmark(), p, w_unit);
                            rw.add(&mut eq, p, a.world, t, a.normal, r, weight(r), w_unit);
                        }
                    }
                }
                best = Some((pose, cost, eq));
                damping *= 0.25;
            }
        } else {
            damping = math::max(damping * 4.0, 1.0);
        }
        let Some((best_pose, _, eq)) = best.as_ref() else {
            continue;
        };
        if (eq.count as usize) < required {
            return Err(MatchError::TooFewAssociations {
                associated: crate::math::saturating_u16(eq.count),
                required: crate::math::saturating_u16(required),
            });
        }
        let step = truncated_step(
            eq,
            config.min_information_points,
            config.rotation_scale_m,
            damping,
        );
        // Convergence is judged on the undamped step: a step shrunk by damping after a
        // rejection is not a sign of having arrived.
        let (small, len) = step_size(&(step * (1.0 + damping)), config);
        steps.record(len);
        // (A damping this high means no step lowers the cost any more: an optimum.)
        converged = small || damping > 1.0e3;
        if converged && misfits.is_none() && explained_m > 0.0 {
            // At the optimum, a landmark not as mapped shows: converge again without it
            // (iterations and work permitting; the budget holds whatever it finds).
            let mut found = Misfits::find(assoc, explained_m);
            if let Some(gate) = gate.as_ref() {
                landmark_gate::disagreeing(
                    assoc,
                    points,
                    *best_pose,
                    gate,
                    config.range_noise_sigma_m,
                    config.roughness.sigma_m,
                    &mut |id| {
                        found.leave_out(id);
                        gate_memory.remember(id);
                    },
                );
            }
            let room = it < config.max_iterations && !out_of_work(schedule.work(), config);
            let left_out = if room {
                found.unpair(assoc, config.association_gate_m)
            } else {
                0
            };
            if !room && !found.is_empty() {
                // No work left to converge without the misfits: the optimum is theirs as
                // much as the map's, and the match is trusted only to within how far it
                // moved from where it started.
                misfit_pull_m = pose_distance_m(&initial, best_pose, config);
            }
            misfits = Some(found);
            if left_out > 0 {
                k = k.min(m.saturating_sub(left_out)).max(1);
                pose = *best_pose;
                best = None;
                damping = 0.0;
                last_accepted_step = None;
                converged = false;
                continue;
            }
        }
        if converged || out_of_work(schedule.work(), config) {
            break;
        }
        // Two association sets can each pull the pose to the other's side: the steps then
        // flip back and forth, every cost within the slack, until the iterations run out
        // (2 % of tunnel-1km's scans did, some for 30 iterations). The optimum lies between
        // the two poses: take the middle and stop.
        if improved && damping == 0.0 {
            if last_accepted_step.is_some_and(|prev| reverses(&prev, &step, config)) {
                let middle = apply_step(*best_pose, &(step * 0.5));
                if let Some(b) = best.as_mut() {
                    b.0 = middle;
                }
                converged = true;
                break;
            }
            last_accepted_step = Some(step);
        }
        pose = apply_step(*best_pose, &step);
    }
    // Judged at the optimum, or (never reached) where the match stopped.
    let misfits_unjudged = misfits.is_none();
    let judged = match misfits {
        Some(m) => Some(m),
        None if explained_m > 0.0 => Some(Misfits::find(assoc, explained_m)),
        None => None,
    };
    let left_out = judged.as_ref().map_or(0, Misfits::len);
    // A misfit never judged at an optimum, or one left out when the work ran out before
    // the match converged again: it stopped on its way back from where the misfits had
    // drawn it, and its last steps (small, the misfit-free optimum still far) do not say
    // how far that is.
    if left_out > 0 && (misfits_unjudged || !converged) {
        // Stopped before its optimum with a landmark not as mapped in it (the check runs at
        // the optimum), or before its optimum without it: as above.
        if let Some((best_pose, _, _)) = best.as_ref() {
            misfit_pull_m = math::max(misfit_pull_m, pose_distance_m(&initial, best_pose, config));
        }
    }
    let mut outcome = conclude(
        best,
        iterations,
        schedule.work(),
        &steps,
        converged,
        required,
        config,
    )?;
    outcome.unconverged_sd_m = math::hypot(outcome.unconverged_sd_m, misfit_pull_m);
    outcome.landmarks_left_out = u8::try_from(left_out).unwrap_or(u8::MAX);
    if let Some(j) = judged.as_ref() {
        let stopped_fitting = fitted_landmarks.record(j);
        outcome.landmarks_stopped_fitting = u8::try_from(stopped_fitting).unwrap_or(u8::MAX);
    }
    Ok(outcome)
}

/// The distance between two poses, metres, the rotation counted at the configuration's
/// `rotation_scale_m` (as a step's length is).
fn pose_distance_m(a: &Pose2, b: &Pose2, config: &MatchConfig) -> f32 {
    let step = Vector3::new(
        b.x_m - a.x_m,
        b.y_m - a.y_m,
        math::wrap_angle(b.theta_rad - a.theta_rad),
    );
    step_size(&step, config).1
}

/// Whether `step` goes back the way `previous` came: their directions more than ~145°
/// apart, the rotation counted at the configuration's `rotation_scale_m`.
fn reverses(previous: &Vector3<f32>, step: &Vector3<f32>, config: &MatchConfig) -> bool {
    let scale = Vector3::new(1.0, 1.0, config.rotation_scale_m);
    let (a, b) = (previous.component_mul(&scale), step.component_mul(&scale));
    let dot = a.dot(&b);
    dot < 0.0 && dot * dot > 0.64 * a.norm_squared() * b.norm_squared()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_step_back_is_a_reversal_and_a_turn_is_not() {
        let c = MatchConfig::default();
        let a = Vector3::new(4.8e-4, 4.0e-5, 6.6e-7);
        assert!(reverses(&a, &(-a * 0.99), &c));
        assert!(!reverses(&a, &(a * 0.5), &c));
        // At right angles (rotation counted at 10 m per radian): not a reversal.
        assert!(!reverses(&a, &Vector3::new(-4.0e-5, 4.8e-4, 0.0), &c));
        // A rotation-only step against a translation-only one: orthogonal, not a reversal.
        assert!(!reverses(
            &Vector3::new(1.0e-3, 0.0, 0.0),
            &Vector3::new(0.0, 0.0, -1.0e-4),
            &c
        ));
        assert!(!reverses(&Vector3::zeros(), &a, &c));
    }
}
