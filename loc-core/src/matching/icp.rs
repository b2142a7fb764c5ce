//! Point-to-line ICP (after Censi's PL-ICP): associate every point within a shrinking gate
//! with its nearest map segment, take the Gauss–Newton step of the summed squared
//! point-to-line distances, repeat (see the module docs of [`super`]).

use super::association::{Association, AssociationSchedule};
use super::information::{truncated_step, NormalEquations};
use super::landmark_offsets::{LandmarkAnchors, LandmarkOffsets, OffsetPriors};
use super::roughness::RoughWalls;
use super::{
    apply_step, conclude, out_of_work, step_size, MatchConfig, MatchError, Outcome, Steps,
};
use crate::geometry::{Point2, Pose2};
use crate::map::MapQuery;
use crate::math;

pub(super) fn run<M: MapQuery>(
    map: &M,
    points: &[Point2],
    initial: Pose2,
    config: &MatchConfig,
    schedule: &mut AssociationSchedule,
    assoc: &mut [Association],
    offsets: &LandmarkOffsets,
) -> Result<Outcome, MatchError> {
    let m = points.len().min(assoc.len());
    let assoc = assoc.get_mut(..m).unwrap_or_default();
    let required = usize::from(config.min_points.max(3));
    let min_gate = math::max(config.icp_min_gate_m, 1.0e-3);
    let mut gate = math::max(config.association_gate_m, min_gate);

    let mut pose = initial;
    let mut last = None;
    let mut steps = Steps::new();
    let mut iterations = 0u16;
    let mut converged = false;
    // Each landmark's anchor, looked up once for the whole match.
    let mut anchors = LandmarkAnchors::new(initial);
    for it in 1..=config.max_iterations.max(1) {
        iterations = it;
        schedule.run(map, points, pose, gate, assoc);
        let mut eq = NormalEquations::default();
        let mut walls = RoughWalls::new(
            &config.roughness,
            config.range_noise_sigma_m,
            pose.theta_rad,
        );
        let inliers = assoc
            .iter()
            .filter(|a| a.associated() && a.distance_m <= gate);
        let t = pose.translation();
        match walls.as_mut() {
            None => {
                for a in inliers {
                    eq.add(a.world, t, a.normal, a.residual_m(), 1.0);
                }
            }
            Some(rw) => {
                let mut priors = OffsetPriors::new(offsets);
                anchors.place(pose);
                for a in inliers {
                    let p = points.get(usize::from(a.point)).copied();
                    let p = anchors.point(map, a.landmark(), p.unwrap_or(Point2::ORIGIN));
                    priors.before_point(rw, &mut eq, a.landmark(), p, 1.0);
                    rw.add(&mut eq, p, a.world, t, a.normal, a.residual_m(), 1.0, 1.0);
                }
            }
        }
        if (eq.count as usize) < required {
            return Err(MatchError::TooFewAssociations {
                associated: crate::math::saturating_u16(eq.count),
                required: crate::math::saturating_u16(required),
            });
        }
        let step = truncated_step(
            &eq,
            config.min_information_points,
            config.rotation_scale_m,
            0.0,
        );
        let (small, len) = step_size(&step, config);
        steps.record(len);
        let rms = eq.rms_m();
        last = Some((pose, rms, eq));
        converged = small;
        if small || out_of_work(schedule.work(), config) {
            break;
        }
        pose = apply_step(pose, &step);
        // Outliers beyond 3× the current RMS drop out as the fit tightens.
        gate = (3.0 * rms).clamp(min_gate, gate);
    }
    conclude(
        last,
        iterations,
        schedule.work(),
        &steps,
        converged,
        required,
        config,
    )
}
