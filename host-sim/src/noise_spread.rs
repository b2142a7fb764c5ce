//! How much of one scan's match error is the range noise's and how much the walls'
//! (`host-sim spread`): the vehicle stands at a true pose and the scanner scans it again
//! and again, each time with fresh range noise; loc-core matches every scan from the true
//! pose. Over the draws, the **mean** of the match's error is what the walls (their
//! roughness against the smooth map, the landmarks as mounted) do to it there, the
//! **spread** what the noise does. Beside them, the scan's Cramér–Rao bound under the
//! localiser's own model (noise and roughness; [`ScanBound`]) and the same bound with the
//! roughness taken as known (noise only): an estimator that used the noise as well as it
//! can would spread no more than the noise-only bound.
//!
//! The match is the localiser's whole chain (strip, select, match) of a fresh
//! [`Localizer`] initialised at the true pose, as [`Localizer::update_scan`] runs it on a
//! vehicle; landmark offsets learnt over earlier scans are not there.

use std::fmt::Write as _;

use loc_core::geometry::Pose2;
use loc_core::localizer::Localizer;
use loc_core::scan::Scan;
use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

use crate::estimator::localizer_config;
use crate::lidar::Lms511;
use crate::replay::bound::{along_across_variances, ScanBound};
use crate::scenario::Scenario;
use crate::session::SimError;
use crate::stored_map;
use crate::vehicle::SimPose;
use crate::world::centerline::wrap_pi;

/// 1σ of the pose the localiser is initialised at (the true pose), metres and radians:
/// tight, so the match starts where the truth is, as a tracking match nearly does.
const START_SIGMA: (f32, f32) = (0.01, 0.001);

/// What a study runs.
#[derive(Debug, Clone, PartialEq)]
pub struct SpreadSpec {
    /// Chainages of the poses, metres (the vehicle at the drive's lateral offset, heading
    /// along the centre line).
    pub chainages_m: Vec<f64>,
    /// Scans per pose, each with fresh range noise (at least 2).
    pub draws: u32,
    /// Seed of the scanner's noise (the scenario's seed draws the walls).
    pub seed: u64,
    /// Scan walls that are exactly the map's (no roughness) while the localiser keeps the
    /// scenario's roughness model: what the estimator itself makes of the noise, without
    /// the rough walls' part in its decisions (labels, trimming, weights).
    pub smooth_walls: bool,
}

/// Mean and standard deviation of one error component over a pose's draws.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MeanSd {
    /// Mean over the draws: the walls' part.
    pub mean: f64,
    /// Standard deviation over the draws: the noise's part.
    pub sd: f64,
}

impl MeanSd {
    fn of(values: &[f64]) -> Option<Self> {
        let n = values.len();
        if n < 2 {
            return None;
        }
        let mean = values.iter().sum::<f64>() / n as f64;
        let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1) as f64;
        Some(Self {
            mean,
            sd: var.sqrt(),
        })
    }
}

/// A bound's 1σ along and across the tunnel and in heading.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BoundSd {
    /// Along the tunnel, millimetres.
    pub along_mm: f64,
    /// Across the tunnel, millimetres.
    pub across_mm: f64,
    /// Heading, milliradians.
    pub heading_mrad: f64,
}

impl BoundSd {
    fn of(b: &Matrix3<f64>, heading_rad: f64) -> Option<Self> {
        let (along, across) = along_across_variances(b, heading_rad);
        let sd = |v: f64| (v.is_finite() && v >= 0.0).then(|| v.sqrt());
        Some(Self {
            along_mm: sd(along)? * 1e3,
            across_mm: sd(across)? * 1e3,
            heading_mrad: sd(b[(2, 2)])? * 1e3,
        })
    }
}

/// One pose's draws.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PoseSpread {
    /// Chainage, metres.
    pub chainage_m: f64,
    /// Draws whose scan matched (the others are left out).
    pub matched: u32,
    /// The match's error along the tunnel, millimetres.
    pub along_mm: MeanSd,
    /// …across it (positive to the left), millimetres.
    pub across_mm: MeanSd,
    /// …in heading, milliradians.
    pub heading_mrad: MeanSd,
    /// The first draw's Cramér–Rao bound, noise and roughness as the localiser models them.
    pub bound: Option<BoundSd>,
    /// The same with the roughness known: the noise's share of it.
    pub bound_noise_only: Option<BoundSd>,
    /// The largest position error of a draw's match in the σ of its own claimed
    /// covariance (the Mahalanobis distance of its `x, y` error): above 3, a match here
    /// claims more than it knows.
    pub worst_claim_sigmas: f64,
}

/// A study's poses and their RMS over them.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SpreadStudy {
    /// Scenario name.
    pub scenario: String,
    /// Whether the scanned walls were smooth ([`SpreadSpec::smooth_walls`]).
    pub smooth_walls: bool,
    /// Scans per pose.
    pub draws: u32,
    /// Every pose with at least two matched draws.
    pub poses: Vec<PoseSpread>,
}

/// RMS over poses of `f`.
fn rms(poses: &[PoseSpread], f: impl Fn(&PoseSpread) -> Option<f64>) -> Option<f64> {
    let v: Vec<f64> = poses.iter().filter_map(f).collect();
    (!v.is_empty()).then(|| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt())
}

impl SpreadStudy {
    /// The study as a table, with the RMS over the poses.
    pub fn report(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{}: the match from the true pose, {} scans per pose with fresh range noise{}",
            self.scenario,
            self.draws,
            if self.smooth_walls {
                " (walls scanned smooth, the roughness model kept)"
            } else {
                ""
            }
        );
        let _ = writeln!(
            s,
            "  mean = the walls' part, sd = the noise's; bounds: model (noise and roughness) / noise only"
        );
        let _ = writeln!(
            s,
            "  chainage m | heading mrad mean, sd | bound | across mm mean, sd | bound | along mm mean, sd | bound | worst claim σ"
        );
        let b = |v: Option<BoundSd>, f: fn(&BoundSd) -> f64| {
            v.map_or("-".to_string(), |b| format!("{:.3}", f(&b)))
        };
        for p in &self.poses {
            let _ = writeln!(
                s,
                "  {:9.1} | {:+.3}, {:.3} | {} / {} | {:+.2}, {:.2} | {} / {} | {:+.2}, {:.2} | {} / {} | {:.1}",
                p.chainage_m,
                p.heading_mrad.mean,
                p.heading_mrad.sd,
                b(p.bound, |b| b.heading_mrad),
                b(p.bound_noise_only, |b| b.heading_mrad),
                p.across_mm.mean,
                p.across_mm.sd,
                b(p.bound, |b| b.across_mm),
                b(p.bound_noise_only, |b| b.across_mm),
                p.along_mm.mean,
                p.along_mm.sd,
                b(p.bound, |b| b.along_mm),
                b(p.bound_noise_only, |b| b.along_mm),
                p.worst_claim_sigmas,
            );
        }
        let f = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3}"));
        let _ = writeln!(
            s,
            "  RMS over the poses: heading mean {} sd {} (bound {} / {}); across mean {} sd {} (bound {} / {})",
            f(rms(&self.poses, |p| Some(p.heading_mrad.mean))),
            f(rms(&self.poses, |p| Some(p.heading_mrad.sd))),
            f(rms(&self.poses, |p| p.bound.map(|b| b.heading_mrad))),
            f(rms(&self.poses, |p| p.bound_noise_only.map(|b| b.heading_mrad))),
            f(rms(&self.poses, |p| Some(p.across_mm.mean))),
            f(rms(&self.poses, |p| Some(p.across_mm.sd))),
            f(rms(&self.poses, |p| p.bound.map(|b| b.across_mm))),
            f(rms(&self.poses, |p| p.bound_noise_only.map(|b| b.across_mm))),
        );
        s
    }
}

/// The Mahalanobis distance of the position error `(ex, ey)` (metres, world frame) in the
/// position block of a match's claimed covariance; 0 when the block is singular.
fn claim_sigmas(c: &Matrix3<f32>, ex: f64, ey: f64) -> f64 {
    let (a, b, d) = (
        f64::from(c[(0, 0)]),
        f64::from(c[(0, 1)]),
        f64::from(c[(1, 1)]),
    );
    let det = a * d - b * b;
    if !(det.is_finite() && det > 0.0) {
        return 0.0;
    }
    ((d * ex * ex - 2.0 * b * ex * ey + a * ey * ey) / det).sqrt()
}

/// Runs the study on `scenario` (its seed draws the walls and landmarks).
pub fn run_spread(scenario: &Scenario, spec: &SpreadSpec) -> Result<SpreadStudy, SimError> {
    scenario.validate()?;
    let world = if spec.smooth_walls {
        let mut smooth = scenario.clone();
        smooth.tunnel.roughness_sigma_m = 0.0;
        smooth.build_world()?
    } else {
        scenario.build_world()?
    };
    let map = stored_map::build(&world, &scenario.landmark_choice()?).map_err(SimError::Map)?;
    let line = scenario.centerline()?;
    let cfg = localizer_config(scenario);
    let echo = scenario.localizer.echo.selection();
    let mut bound = ScanBound::new(&map, scenario);
    let mut noise_bound = ScanBound::new(&map, scenario).noise_only();
    let mut scan = Box::new(Scan::new());
    let mut poses = Vec::new();
    for (pose_index, &s_m) in spec.chainages_m.iter().enumerate() {
        let (_, _, heading) = line.pose_at(s_m);
        let (x, y) = line.offset_point(s_m, scenario.drive.lateral_offset_m);
        let truth = SimPose {
            x_m: x,
            y_m: y,
            theta_rad: heading,
        };
        let (mut along, mut across, mut head) = (Vec::new(), Vec::new(), Vec::new());
        let mut worst_claim_sigmas = 0.0f64;
        let (mut b_model, mut b_noise) = (None, None);
        for draw in 0..spec.draws {
            let noise_seed = spec
                .seed
                .wrapping_mul(1_000_003)
                .wrapping_add((pose_index as u64).wrapping_mul(100_000))
                .wrapping_add(u64::from(draw));
            let taken =
                Lms511::new(scenario.lidar, noise_seed).scan(world.grid(), (x, y, heading), 0.0);
            if draw == 0 {
                b_model = bound
                    .at(&taken, truth)
                    .and_then(|b| BoundSd::of(&b, heading));
                b_noise = noise_bound
                    .at(&taken, truth)
                    .and_then(|b| BoundSd::of(&b, heading));
            }
            if scan_input::load_values(
                &taken.layout,
                taken.selected(echo),
                taken.scale_factor,
                taken.scale_offset_mm,
                &cfg.sensor,
                &mut scan,
            )
            .is_err()
            {
                continue;
            }
            let mut localizer = Localizer::uninitialised(&*map, cfg);
            let start = Pose2::new(x as f32, y as f32, heading as f32);
            let (sd_m, sd_rad) = START_SIGMA;
            let cov =
                Matrix3::from_diagonal(&Vector3::new(sd_m * sd_m, sd_m * sd_m, sd_rad * sd_rad));
            if localizer.initialise(start, cov).is_err() {
                continue;
            }
            localizer.update_scan(&mut scan);
            let Some(m) = localizer.last_match() else {
                continue;
            };
            let (sn, cs) = heading.sin_cos();
            let ex = f64::from(m.pose.x_m) - x;
            let ey = f64::from(m.pose.y_m) - y;
            along.push((cs * ex + sn * ey) * 1e3);
            across.push((-sn * ex + cs * ey) * 1e3);
            head.push(wrap_pi(f64::from(m.pose.theta_rad) - heading) * 1e3);
            worst_claim_sigmas = worst_claim_sigmas.max(claim_sigmas(&m.covariance, ex, ey));
        }
        let (Some(along_mm), Some(across_mm), Some(heading_mrad)) =
            (MeanSd::of(&along), MeanSd::of(&across), MeanSd::of(&head))
        else {
            continue;
        };
        poses.push(PoseSpread {
            chainage_m: s_m,
            matched: head.len() as u32,
            along_mm,
            across_mm,
            heading_mrad,
            bound: b_model,
            bound_noise_only: b_noise,
            worst_claim_sigmas,
        });
    }
    Ok(SpreadStudy {
        scenario: scenario.name.clone(),
        smooth_walls: spec.smooth_walls,
        draws: spec.draws,
        poses,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::named::named;

    fn study(smooth: bool) -> SpreadStudy {
        let s = named("paper-10m").unwrap();
        let spec = SpreadSpec {
            chainages_m: vec![3.0, 6.0],
            draws: 6,
            seed: 1,
            smooth_walls: smooth,
        };
        run_spread(&s, &spec).unwrap()
    }

    #[test]
    fn smooth_walls_leave_the_noise_alone_and_rough_walls_add_their_part() {
        let smooth = study(true);
        let rough = study(false);
        assert_eq!(smooth.poses.len(), 2);
        assert_eq!(rough.poses.len(), 2);
        for p in smooth.poses.iter().chain(&rough.poses) {
            assert_eq!(p.matched, 6);
            let (b, n) = (p.bound.unwrap(), p.bound_noise_only.unwrap());
            // Roughness only adds to what the noise leaves.
            assert!(b.across_mm >= n.across_mm && b.heading_mrad >= n.heading_mrad);
            // The noise moves a scan's match by about its bound, not by centimetres.
            assert!(
                p.across_mm.sd > 0.0 && p.across_mm.sd < 5.0 * b.across_mm,
                "{p:?}"
            );
        }
        // Smooth walls: no walls' part beyond what 6 draws leave of the noise's.
        let bias = rms(&smooth.poses, |p| {
            Some(p.across_mm.mean / p.across_mm.sd.max(1e-3))
        })
        .unwrap();
        assert!(bias < 3.0, "smooth walls bias {bias:.2} sd");
        // Rough walls: the walls' part shows.
        let walls = |st: &SpreadStudy| rms(&st.poses, |p| Some(p.across_mm.mean)).unwrap();
        assert!(
            walls(&rough) > walls(&smooth),
            "{} vs {}",
            walls(&rough),
            walls(&smooth)
        );
        let report = rough.report();
        assert!(report.contains("RMS over the poses"), "{report}");
    }

    /// The S-bend with its F4 landmarks on the right wall only, seed 5: the vehicle starts
    /// 0.5 m short of a landmark bent 10°, with the next one 8 m ahead. A match left the bent
    /// one out and then ran out of work on its way back; it claimed its last few steps'
    /// millimetres while still 27 mm off (4.0 σ of its claim). It now claims how far it is
    /// from where it started.
    #[test]
    fn matches_beside_a_bent_landmark_claim_what_covers_them() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/s-bend-400m.toml");
        let mut s = Scenario::from_file(std::path::Path::new(path)).unwrap();
        s.seed = 5;
        s.landmarks.walls = crate::world::layout::WallChoice::Right;
        let spec = SpreadSpec {
            chainages_m: vec![1.0],
            draws: 12,
            seed: 1,
            smooth_walls: false,
        };
        let study = run_spread(&s, &spec).unwrap();
        let p = &study.poses[0];
        assert_eq!(p.matched, 12);
        assert!(p.worst_claim_sigmas < 3.5, "{p:?}");
    }

    #[test]
    fn a_single_draw_is_no_spread() {
        assert!(MeanSd::of(&[1.0]).is_none());
        let m = MeanSd::of(&[1.0, 3.0]).unwrap();
        assert!((m.mean - 2.0).abs() < 1e-12 && (m.sd - 2f64.sqrt()).abs() < 1e-12);
    }
}
