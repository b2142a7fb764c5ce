//! The modified-Hausdorff matcher: iteratively reweighted Gauss–Newton on the K best
//! point-to-map distances with re-association and re-selection every iteration, and
//! Levenberg damping on the Hausdorff cost (see the module docs of [`super`]).

use super::association::{select_k_best, Association, AssociationSchedule, DistanceKey};
use super::information::{truncated_step, NormalEquations};
use super::patches::PatchSums;
use super::{apply_step, conclude, step_size, KBest, MatchConfig, MatchError, Outcome};
use crate::geometry::{Point2, Pose2};
use crate::map::MapQuery;
use crate::math;

pub(super) fn run<M: MapQuery>(
    map: &M,
    points: &[Point2],
    initial: Pose2,
    config: &MatchConfig,
    assoc: &mut [Association],
    keys: &mut [DistanceKey],
) -> Result<Outcome, MatchError> {
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
    let mut last_step_m = f32::INFINITY;
    let mut iterations = 0u16;
    let mut schedule = AssociationSchedule::new();
    for it in 1..=config.max_iterations.max(1) {
        iterations = it;
        let associated = schedule.run(map, points, pose, config.association_gate_m, assoc);
        if it == 1 && explained_m > 0.0 {
            // Fixed for the whole match, so that the costs compared stay comparable.
            let within = assoc
                .iter()
                .filter(|a| a.associated && a.distance_m <= explained_m)
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
                let mut patches = PatchSums::new(
                    &config.roughness,
                    config.range_noise_sigma_m,
                    pose.theta_rad,
                );
                let w_unit = match config.k_best {
                    KBest::TrimmedMean => 1.0 / delta_m,
                    KBest::KthRanked => 1.0,
                };
                let selected = best_k
                    .iter()
                    .filter_map(|key| assoc.get(usize::from(key.1)))
                    .filter(|a| a.associated);
                let weight = |r: f32| match config.k_best {
                    KBest::TrimmedMean => 1.0 / math::max(math::abs(r), delta_m),
                    KBest::KthRanked => 1.0,
                };
                let t = pose.translation();
                // Smooth walls take the plain loop: the firmware's budget has no room for
                // the patches' bookkeeping when it models nothing.
                match patches.as_mut() {
                    None => {
                        for a in selected {
                            let r = a.residual_m();
                            eq.add(a.world, t, a.normal, r, weight(r));
                        }
                    }
                    Some(ps) => {
                        for a in selected {
                            let r = a.residual_m();
                            let p = points.get(usize::from(a.point)).copied();
                            let p = p.unwrap_or(Point2::ORIGIN);
                            ps.add(&mut eq, p, a.world, t, a.normal, r, weight(r), w_unit);
                        }
                        ps.apply(&mut eq, w_unit);
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
        last_step_m = len;
        if small || damping > 1.0e3 {
            break;
        }
        pose = apply_step(*best_pose, &step);
    }
    conclude(best, iterations, last_step_m, required, config)
}
