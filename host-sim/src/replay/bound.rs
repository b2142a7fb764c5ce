//! The per-scan Cramér–Rao bound of a replay (`host-sim replay --bound`): each scan's
//! Fisher information at the TRUE pose (loc-core's [`scan_information`], every point of the
//! scan, the localiser's own measurement model: range noise and wall roughness as the
//! scenario configures it), inverted, beside the localiser's error on the same scans.
//!
//! The bound is what the best unbiased estimate from that one scan could reach; a filter
//! with odometry can do better where consecutive scans see independent errors, worse where
//! it lags. Their ratio says how much of each scan's information the localiser uses.

use loc_core::geometry::Pose2;
use loc_core::map::TunnelMap;
use loc_core::matching::{scan_information, MatchConfig};
use loc_core::scan::{Scan, SensorSetup};
use nalgebra::Matrix3;
use serde::Serialize;

use crate::estimator::localizer_config;
use crate::lidar::LidarScan;
use crate::metrics::Sample;
use crate::scenario::Scenario;
use crate::vehicle::SimPose;
use crate::world::centerline::{wrap_pi, CenterLine};

/// Points farther than this from map geometry carry nothing for the bound, metres (beyond
/// any roughness, closer than anything that is not the tunnel).
const GATE_M: f32 = 0.3;

/// Computes scan bounds against one map with one scenario's measurement model.
pub struct ScanBound<'m> {
    map: &'m TunnelMap,
    matching: MatchConfig,
    sensor: SensorSetup,
    /// Which echo of each beam is taken (the scenario's, as the localiser does).
    echo: scan_input::EchoSelection,
    scan: Box<Scan>,
}

impl<'m> ScanBound<'m> {
    /// Bounds against `map` with the localiser configuration a replay of `scenario` uses.
    pub fn new(map: &'m TunnelMap, scenario: &Scenario) -> Self {
        let cfg = localizer_config(scenario);
        Self {
            map,
            matching: cfg.matching,
            sensor: cfg.sensor,
            echo: scenario.localizer.echo.selection(),
            scan: Box::default(),
        }
    }

    /// The same bound with smooth walls in the model: what the range noise alone leaves
    /// (the walls' roughness counted as known).
    pub fn noise_only(mut self) -> Self {
        self.matching.roughness = loc_core::matching::RoughnessModel::SMOOTH;
        self
    }

    /// The bound (covariance of `(x_m, y_m, theta_rad)`, world frame) of `scan` taken at
    /// `truth`; `None` when the scan cannot be loaded or leaves a direction unobserved.
    pub fn at(&mut self, scan: &LidarScan, truth: SimPose) -> Option<Matrix3<f64>> {
        scan_input::load_values(
            &scan.layout,
            scan.selected(self.echo),
            scan.scale_factor,
            scan.scale_offset_mm,
            &self.sensor,
            &mut self.scan,
        )
        .ok()?;
        let pose = Pose2::new(truth.x_m as f32, truth.y_m as f32, truth.theta_rad as f32);
        let info = scan_information(self.map, self.scan.points(), pose, &self.matching, GATE_M);
        info.bound().map(|b| b.cast::<f64>())
    }
}

/// The bound beside the error over a replay's scored scans.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BoundSummary {
    /// Scans with a finite bound (the others leave a direction unobserved).
    pub scans: usize,
    /// RMS over those scans of the bound's position 1σ (`√(σx² + σy²)`), metres.
    pub position_rms_m: f64,
    /// …of its 1σ along the tunnel (the centre line's direction at the scan), metres.
    pub along_rms_m: f64,
    /// …of its 1σ across the tunnel, metres.
    pub across_rms_m: f64,
    /// …of its heading 1σ, radians.
    pub heading_rms_rad: f64,
    /// The localiser's position RMS over the same scans, over `position_rms_m`.
    pub position_ratio: f64,
    /// Its along-tunnel RMS over the bound's.
    pub along_ratio: f64,
    /// Its across-tunnel RMS over the bound's.
    pub across_ratio: f64,
    /// Its heading RMS over the bound's.
    pub heading_ratio: f64,
}

/// The variances along and across a tunnel heading `heading_rad` (world frame) of the
/// position block of covariance `b` (`(x_m, y_m, theta_rad)`, world frame), m².
pub fn along_across_variances(b: &Matrix3<f64>, heading_rad: f64) -> (f64, f64) {
    let (sn, cs) = heading_rad.sin_cos();
    (
        cs * cs * b[(0, 0)] + 2.0 * cs * sn * b[(0, 1)] + sn * sn * b[(1, 1)],
        sn * sn * b[(0, 0)] - 2.0 * cs * sn * b[(0, 1)] + cs * cs * b[(1, 1)],
    )
}

/// Summarises `bounds[i]` (the bound of sample `i`'s scan) against the samples' errors.
pub fn summarise(
    line: &CenterLine,
    samples: &[Sample],
    bounds: &[Option<Matrix3<f64>>],
) -> Option<BoundSummary> {
    let mut n = 0usize;
    let mut sum = [0.0f64; 8];
    for (s, b) in samples.iter().zip(bounds) {
        let Some(b) = b else { continue };
        let (_, _, heading) = line.pose_at(s.chainage_m);
        let (sn, cs) = heading.sin_cos();
        let ex = s.estimate.x_m - s.truth.x_m;
        let ey = s.estimate.y_m - s.truth.y_m;
        let along_e = cs * ex + sn * ey;
        let across_e = -sn * ex + cs * ey;
        let head_e = wrap_pi(s.estimate.theta_rad - s.truth.theta_rad);
        let (var_along, var_across) = along_across_variances(b, heading);
        let terms = [
            b[(0, 0)] + b[(1, 1)],
            var_along,
            var_across,
            b[(2, 2)],
            ex * ex + ey * ey,
            along_e * along_e,
            across_e * across_e,
            head_e * head_e,
        ];
        if terms.iter().all(|v| v.is_finite()) {
            n += 1;
            for (acc, v) in sum.iter_mut().zip(terms) {
                *acc += v;
            }
        }
    }
    if n == 0 {
        return None;
    }
    let rms = sum.map(|v| (v / n as f64).sqrt());
    Some(BoundSummary {
        scans: n,
        position_rms_m: rms[0],
        along_rms_m: rms[1],
        across_rms_m: rms[2],
        heading_rms_rad: rms[3],
        position_ratio: rms[4] / rms[0],
        along_ratio: rms[5] / rms[1],
        across_ratio: rms[6] / rms[2],
        heading_ratio: rms[7] / rms[3],
    })
}
