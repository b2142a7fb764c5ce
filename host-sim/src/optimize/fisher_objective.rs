//! The deterministic objective of landmark design (issue 9, item 5): the Cramér–Rao bound on
//! the along-tunnel position that one scan allows, worst case over the vehicle's positions
//! between landmarks and across the tunnel. No simulated run, no noise draw.
//!
//! The geometry is the scenario's tunnel straightened (the design is for a straight bore):
//! walls at ±width/2, the genome's landmarks on both walls at exactly D (the right wall D/2
//! later, as the simulator staggers them), the LMS511's beams at the scenario's rate and
//! mounting. Each beam is traced to the nearest landmark segment it meets (landmarks hide
//! one another at grazing angles; a beam that meets none reaches the wall). The information
//! is loc-core's own accumulation ([`paired_information`], the one the replay's per-scan
//! bound uses): landmark points rigid, wall points with the localiser's roughness model, all
//! in units of its range noise. The wall points do not depend on the genome: their
//! information is computed once per lateral position. Landmark points count within the
//! wall stripper's fit range (30 m), as the localiser labels them. The K-best trimming keeps
//! every point of a noise-free scan (each is within 2σ of the map), so it does not enter.

use loc_core::geometry::{Point2, Pose2};
use loc_core::matching::{paired_information, MatchConfig, RoughnessModel};
use loc_core::strip::StripConfig;
use nalgebra::Matrix3;

use super::genes::GeneSpace;
use crate::estimator::localizer_config;
use crate::scenario::Scenario;

/// Vehicle positions per landmark period the worst case is taken over.
pub const ALONG_SAMPLES: usize = 8;

/// Lateral positions of the vehicle, as fractions of the half-width (left positive).
pub const LATERAL_FRACTIONS: [f64; 3] = [-0.5, 0.0, 0.5];

/// What the objective says of one genome.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FisherEvaluation {
    /// The largest along-tunnel 1σ bound over the positions, metres (+∞ where a position
    /// leaves the along direction unobserved).
    pub worst_along_sd_m: f64,
    /// The mean of the positions' along-tunnel 1σ bounds, metres.
    pub mean_along_sd_m: f64,
}

/// The objective for one scenario and model.
#[derive(Debug, Clone)]
pub struct FisherObjective {
    /// The model's genes.
    pub space: GeneSpace,
    half_width_m: f64,
    first_m: f64,
    landmark_range_m: f64,
    sensor_m: (f64, f64),
    /// Beam directions in the vehicle frame (heading 0): (cos, sin).
    beams: Vec<(f64, f64)>,
    first_beam_rad: f64,
    step_rad: f64,
    matching: MatchConfig,
    /// Per lateral position: the vehicle's y and the walls' information.
    laterals: Vec<(f64, Matrix3<f32>)>,
}

/// Where ray `o + t d` (t > 0) meets segment `a b`: `t` and the segment's unit normal
/// (the intersection is the ray caster's, [`crate::raycast`]).
fn ray_segment(
    o: (f64, f64),
    d: (f64, f64),
    a: (f64, f64),
    b: (f64, f64),
) -> Option<(f64, (f64, f64))> {
    let t = crate::raycast::ray_segment(o, d, a, b).filter(|&t| t > 1e-9)?;
    let e = (b.0 - a.0, b.1 - a.1);
    let len = e.0.hypot(e.1);
    Some((t, (-e.1 / len, e.0 / len)))
}

impl FisherObjective {
    /// The objective of `space`'s model in `scenario`'s tunnel, lidar and localiser.
    pub fn new(scenario: &Scenario, space: GeneSpace) -> Self {
        let cfg = localizer_config(scenario);
        let layout = scenario.lidar.rate.layout();
        let lidar = &scenario.lidar;
        let first_beam_rad = lidar.mount_yaw_rad + layout.beam_angle_rad(0);
        let step_rad = scenario.lidar.rate.step_rad();
        let beams: Vec<(f64, f64)> = (0..usize::from(layout.beams))
            .map(|i| {
                let a = lidar.mount_yaw_rad + layout.beam_angle_rad(i);
                (a.cos(), a.sin())
            })
            .collect();
        let half_width_m = scenario.tunnel.width_m / 2.0;
        let mut obj = Self {
            space,
            half_width_m,
            first_m: scenario.landmarks.first_m,
            landmark_range_m: f64::from(StripConfig::default().max_fit_range_m),
            sensor_m: (lidar.mount_x_m, lidar.mount_y_m),
            beams,
            first_beam_rad,
            step_rad,
            matching: cfg.matching,
            laterals: Vec::new(),
        };
        let far = lidar
            .max_range_m
            .min(f64::from(StripConfig::default().far_wall_range_m));
        obj.laterals = LATERAL_FRACTIONS
            .iter()
            .map(|f| {
                let y = f * half_width_m;
                (y, obj.wall_information(y, far))
            })
            .collect();
        obj
    }

    /// The sensor's origin for the vehicle at `(x, y)`, heading along the tunnel.
    fn origin(&self, x: f64, y: f64) -> (f64, f64) {
        (x + self.sensor_m.0, y + self.sensor_m.1)
    }

    /// The range along beam `d` from `o` to the walls, or `None` beyond `max_m`.
    fn wall_hit(&self, o: (f64, f64), d: (f64, f64), max_m: f64) -> Option<(f64, f64)> {
        let wall = if d.1 > 0.0 {
            self.half_width_m
        } else {
            -self.half_width_m
        };
        if d.1.abs() < 1e-12 {
            return None;
        }
        let t = (wall - o.1) / d.1;
        (t > 0.0 && t <= max_m).then_some((t, wall))
    }

    /// The information of every wall point of a bare scan at lateral position `y`.
    fn wall_information(&self, y: f64, max_m: f64) -> Matrix3<f32> {
        let o = self.origin(0.0, y);
        let pairs = self.beams.iter().filter_map(|&d| {
            let (t, _) = self.wall_hit(o, d, max_m)?;
            let p = Point2::new(
                (self.sensor_m.0 + t * d.0) as f32,
                (self.sensor_m.1 + t * d.1) as f32,
            );
            Some((p, Point2::new(0.0, 1.0)))
        });
        paired_information(pairs, Pose2::new(0.0, y as f32, 0.0), &self.matching).information
    }

    /// Evaluates `genes` (within the bounds).
    pub fn evaluate(&self, genes: &[f64]) -> Result<FisherEvaluation, String> {
        let choice = self.space.choice(genes).map_err(|e| e.to_string())?;
        let profile = choice.profile();
        let spacing = genes[GeneSpace::SPACING];
        let rigid = MatchConfig {
            roughness: RoughnessModel::SMOOTH,
            ..self.matching
        };
        // Landmarks within reach of any sampled position: centres on the left at
        // first + kD, on the right D/2 later, over a stretch around [0, D).
        let half_extent = profile.iter().map(|p| p.0.abs()).fold(0.0, f64::max);
        let reach = self.landmark_range_m + 2.0 * half_extent;
        let mut vertices: Vec<(f64, f64)> = Vec::with_capacity(profile.len());
        let k0 = ((-reach - self.first_m) / spacing).floor() as i64 - 1;
        let k1 = ((spacing + reach - self.first_m) / spacing).ceil() as i64 + 1;
        let mut worst = 0.0f64;
        let mut sum = 0.0;
        let mut n = 0usize;
        let mut nearest: Vec<Option<(f64, (f64, f64))>> = vec![None; self.beams.len()];
        let mut touched: Vec<usize> = Vec::new();
        for &(y, wall_info) in &self.laterals {
            for k in 0..ALONG_SAMPLES {
                let x = self.first_m + spacing * k as f64 / ALONG_SAMPLES as f64;
                let o = self.origin(x, y);
                for &i in &touched {
                    nearest[i] = None;
                }
                touched.clear();
                for (side, offset) in [(1.0, 0.0), (-1.0, spacing / 2.0)] {
                    for j in k0..=k1 {
                        let c = self.first_m + offset + j as f64 * spacing;
                        // Within reach ahead; behind the sensor only what the 190° fan
                        // still sees (5° past the perpendicular: well within a metre).
                        if c - o.0 > reach || o.0 - c > 1.0 + half_extent {
                            continue;
                        }
                        vertices.clear();
                        vertices.extend(
                            profile
                                .iter()
                                .map(|&(u, h)| (c + u, side * (self.half_width_m - h))),
                        );
                        self.trace_landmark(o, &vertices, &mut nearest, &mut touched);
                    }
                }
                let pairs = touched.iter().filter_map(|&i| {
                    let (t, nrm) = nearest[i]?;
                    let d = self.beams[i];
                    (t <= self.landmark_range_m).then(|| {
                        (
                            Point2::new(
                                (self.sensor_m.0 + t * d.0) as f32,
                                (self.sensor_m.1 + t * d.1) as f32,
                            ),
                            Point2::new(nrm.0 as f32, nrm.1 as f32),
                        )
                    })
                });
                let pose = Pose2::new(x as f32, y as f32, 0.0);
                let info = paired_information(pairs, pose, &rigid).information + wall_info;
                let sd = info
                    .cast::<f64>()
                    .try_inverse()
                    .map(|b| b[(0, 0)])
                    .filter(|v| v.is_finite() && *v > 0.0)
                    .map_or(f64::INFINITY, f64::sqrt);
                worst = worst.max(sd);
                sum += sd;
                n += 1;
            }
        }
        Ok(FisherEvaluation {
            worst_along_sd_m: worst,
            mean_along_sd_m: sum / n.max(1) as f64,
        })
    }

    /// Traces the beams that can meet the landmark polyline `v` (world) from `o`, keeping
    /// each beam's nearest hit.
    fn trace_landmark(
        &self,
        o: (f64, f64),
        v: &[(f64, f64)],
        nearest: &mut [Option<(f64, (f64, f64))>],
        touched: &mut Vec<usize>,
    ) {
        // The beams between the extreme directions to the polyline's vertices.
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in v {
            let a = (p.1 - o.1).atan2(p.0 - o.0);
            lo = lo.min(a);
            hi = hi.max(a);
        }
        let first = ((lo - self.first_beam_rad) / self.step_rad)
            .floor()
            .max(0.0) as usize;
        let last = (((hi - self.first_beam_rad) / self.step_rad).ceil().max(0.0) as usize)
            .min(self.beams.len().saturating_sub(1));
        let beams = self.beams.iter().zip(nearest.iter_mut()).enumerate();
        for (i, (&d, slot)) in beams.skip(first).take((last + 1).saturating_sub(first)) {
            let mut best: Option<(f64, (f64, f64))> = None;
            for s in v.windows(2) {
                if let Some(hit) = ray_segment(o, d, s[0], s[1]) {
                    if best.is_none_or(|b| hit.0 < b.0) {
                        best = Some(hit);
                    }
                }
            }
            if let Some(hit) = best {
                match *slot {
                    None => {
                        *slot = Some(hit);
                        touched.push(i);
                    }
                    Some(b) if hit.0 < b.0 => *slot = Some(hit),
                    _ => {}
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::named::named;
    use loc_core::landmark::LandmarkModel;

    fn objective() -> FisherObjective {
        FisherObjective::new(
            &named("paper-10m").unwrap(),
            GeneSpace::for_model(LandmarkModel::P1Triangle),
        )
    }

    #[test]
    fn bigger_and_denser_landmarks_bound_the_chainage_tighter() {
        let obj = objective();
        let paper = obj.evaluate(&[0.5, 0.25, 9.5]).unwrap();
        assert!(paper.worst_along_sd_m.is_finite(), "{paper:?}");
        assert!(paper.worst_along_sd_m >= paper.mean_along_sd_m);
        let small = obj.evaluate(&[0.1, 0.02, 9.5]).unwrap();
        assert!(
            small.worst_along_sd_m > paper.worst_along_sd_m,
            "{small:?} vs {paper:?}"
        );
        let dense = obj.evaluate(&[0.5, 0.25, 3.0]).unwrap();
        assert!(
            dense.worst_along_sd_m < paper.worst_along_sd_m,
            "{dense:?} vs {paper:?}"
        );
        // Deterministic.
        assert_eq!(obj.evaluate(&[0.5, 0.25, 9.5]).unwrap(), paper);
    }

    #[test]
    fn the_bound_agrees_with_the_cores_on_a_ray_cast_scan() {
        // The landmark points the objective traces are those the simulator's lidar sees:
        // their count at one position is within a few beams of a noise-free ray cast.
        let obj = objective();
        let o = obj.origin(obj.first_m + 1.0, 0.0);
        let v: Vec<(f64, f64)> = [(-0.25, 0.0), (0.0, 0.25), (0.25, 0.0)]
            .iter()
            .map(|&(u, h)| (obj.first_m + 3.0 + u, obj.half_width_m - h))
            .collect();
        let mut nearest = vec![None; obj.beams.len()];
        let mut touched = Vec::new();
        obj.trace_landmark(o, &v, &mut nearest, &mut touched);
        // A 0.5 m triangle 2 m beside and 2 m ahead of the sensor: every beam between its
        // base corners' directions meets it.
        let a0 = (v[0].1 - o.1).atan2(v[0].0 - o.0);
        let a2 = (v[2].1 - o.1).atan2(v[2].0 - o.0);
        let expected = ((a0 - a2).abs() / obj.step_rad) as usize;
        assert!(
            touched.len().abs_diff(expected) <= 2,
            "{} vs {expected}",
            touched.len()
        );
        for &i in &touched {
            let (t, n) = nearest[i].unwrap();
            let d = obj.beams[i];
            let q = (o.0 + t * d.0, o.1 + t * d.1);
            assert!(q.1 <= obj.half_width_m + 1e-9 && q.1 >= obj.half_width_m - 0.25 - 1e-9);
            assert!((n.0.hypot(n.1) - 1.0).abs() < 1e-9);
        }
    }
}
