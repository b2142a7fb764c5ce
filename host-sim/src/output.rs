//! Files a run leaves in `--out DIR`: the trajectories as CSV, the metrics as JSON, and the
//! scenario as TOML (to rerun it exactly). Also the flat JSON metrics object that `--json`
//! prints.

use std::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::closed_loop::{RunLog, WorldSummary};
use crate::metrics::Metrics;

/// Why an output file (CSV, JSON, plot, MCAP) could not be written.
#[derive(Debug)]
pub struct OutputError {
    /// The file or directory.
    pub path: PathBuf,
    /// What went wrong (the OS's or the writer's message).
    pub reason: String,
}

impl OutputError {
    /// The error of writing `path`, for `reason`.
    pub fn new(path: &Path, reason: impl fmt::Display) -> Self {
        Self {
            path: path.to_path_buf(),
            reason: reason.to_string(),
        }
    }
}

impl fmt::Display for OutputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "cannot write {}: {} (check that the directory is writable)",
            self.path.display(),
            self.reason
        )
    }
}

impl std::error::Error for OutputError {}

/// The metrics of one run as one flat JSON object (the `--json` output and
/// `metrics.json`): the run's identity, the localiser's [`crate::metrics::Accuracy`] figures under their own
/// names, odometry alone's under `odometry_…`, the rest of [`Metrics`], times and counts.
/// Lengths in metres, angles in radians, times in microseconds or seconds.
#[derive(Debug, Clone, Serialize)]
pub struct MetricsJson {
    /// Scenario name.
    pub scenario: String,
    /// Landmark model code or "none".
    pub landmarks: String,
    /// Landmark genes W,H,D[,h1..h6].
    pub genes: Vec<f64>,
    /// Matcher name.
    pub matcher: String,
    /// Estimator name.
    pub estimator: String,
    /// Seed.
    pub seed: u64,
    /// The figures (localiser accuracy flat, odometry's with the `odometry_` prefix).
    #[serde(flatten)]
    pub metrics: Metrics,
    /// Wall-clock time of the run, seconds.
    pub wall_time_s: f64,
    /// Of which ray casting, seconds.
    pub raycast_time_s: f64,
    /// Simulated over wall-clock time.
    pub real_time_factor: f64,
    /// Simulated time over the CPU time of lidar simulation + localiser.
    pub scan_cpu_real_time_factor: f64,
    /// CPU time of the whole run on its one thread, seconds (when measured).
    pub cpu_time_s: Option<f64>,
    /// Simulated time over that CPU time: how much faster than real time the simulation
    /// with localisation runs on one core.
    pub cpu_real_time_factor: Option<f64>,
    /// World summary.
    pub world: WorldSummary,
    /// Count of scans per estimator status.
    pub status_counts: std::collections::BTreeMap<String, usize>,
    /// The worst error in σ on a scan reported tracking (`null` when none was): above 5
    /// the localiser was confidently wrong.
    pub tracking_worst_error_sigmas: Option<f64>,
    /// How the protection levels held against the truth (`null`: the estimator gives
    /// none).
    pub protection: Option<crate::metrics::ProtectionSummary>,
    /// What looked wrong in the inputs but did not stop the run (a replay's damaged scans,
    /// odometry gaps, …); empty when nothing did.
    pub warnings: Vec<String>,
    /// A replay's per-scan Cramér–Rao bound beside its error (`replay --bound`); absent
    /// otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cramer_rao: Option<crate::replay::bound::BoundSummary>,
}

impl MetricsJson {
    /// A run's metrics with its identity and times.
    pub fn new(log: &RunLog, m: &Metrics) -> Self {
        let choice = log.scenario.landmark_choice().ok();
        let mut status_counts = std::collections::BTreeMap::new();
        for s in &log.statuses {
            *status_counts.entry(s.label().to_string()).or_insert(0) += 1;
        }
        Self {
            scenario: log.scenario.name.clone(),
            landmarks: choice.map_or_else(|| "?".into(), |c| c.code().to_string()),
            genes: choice.map(|c| c.genes()).unwrap_or_default(),
            matcher: log.scenario.localizer.matcher.name().into(),
            estimator: log.estimator.clone(),
            seed: log.scenario.seed,
            metrics: m.clone(),
            wall_time_s: log.wall_time_s,
            raycast_time_s: log.raycast_time_s,
            real_time_factor: log.real_time_factor(),
            cpu_time_s: None,
            cpu_real_time_factor: None,
            scan_cpu_real_time_factor: log.scan_cpu_real_time_factor(),
            world: log.world,
            status_counts,
            tracking_worst_error_sigmas: log.worst_tracking_sigmas().map(|w| w.error_sigmas),
            protection: crate::metrics::ProtectionSummary::of(&log.samples),
            warnings: Vec::new(),
            cramer_rao: None,
        }
    }

    /// Adds the warnings of the run or replay.
    pub fn with_warnings(mut self, warnings: &[String]) -> Self {
        self.warnings = warnings.to_vec();
        self
    }

    /// Adds a replay's Cramér–Rao summary.
    pub fn with_bound(mut self, bound: Option<crate::replay::bound::BoundSummary>) -> Self {
        self.cramer_rao = bound;
        self
    }

    /// Adds the run's CPU time (from [`crate::session::run_scenario_timed`]).
    pub fn with_cpu_time(mut self, cpu_time_s: f64) -> Self {
        self.cpu_time_s = Some(cpu_time_s);
        self.cpu_real_time_factor =
            (cpu_time_s > 0.0).then(|| self.metrics.sim_time_s / cpu_time_s);
        self
    }

    /// As one line of JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
    }
}

/// Writes the trajectories CSV: one row per scan with time, distance, chainage, the true,
/// estimated and odometry poses, the estimate's σ, the status and the update time.
pub fn write_trajectories_csv(log: &RunLog, w: &mut dyn Write) -> std::io::Result<()> {
    writeln!(
        w,
        "t_s,distance_m,chainage_m,true_x_m,true_y_m,true_theta_rad,est_x_m,est_y_m,est_theta_rad,odo_x_m,odo_y_m,odo_theta_rad,sigma_x_m,sigma_y_m,sigma_theta_rad,status,update_us,protection_m,availability"
    )?;
    for (s, status) in log.samples.iter().zip(&log.statuses) {
        writeln!(
            w,
            "{:.3},{:.4},{:.4},{:.5},{:.5},{:.6},{:.5},{:.5},{:.6},{:.5},{:.5},{:.6},{:.5},{:.5},{:.6},{},{:.1},{},{}",
            s.t_s,
            s.distance_m,
            s.chainage_m,
            s.truth.x_m,
            s.truth.y_m,
            s.truth.theta_rad,
            s.estimate.x_m,
            s.estimate.y_m,
            s.estimate.theta_rad,
            s.odometry.x_m,
            s.odometry.y_m,
            s.odometry.theta_rad,
            s.sigma.0,
            s.sigma.1,
            s.sigma.2,
            status,
            s.update_us,
            s.protection
                .and_then(|p| p.level_m)
                .map_or(String::new(), |l| format!("{l:.4}")),
            s.protection
                .map_or(String::new(), |p| availability_label(p.availability).to_string()),
        )?;
    }
    Ok(())
}

/// The availability as one word for the CSV (`available`, `above-alert-limit`,
/// `fault-detected`, `no-pose`).
fn availability_label(a: loc_core::localizer::Availability) -> &'static str {
    use loc_core::localizer::Availability as A;
    match a {
        A::Available => "available",
        A::AboveAlertLimit => "above-alert-limit",
        A::FaultDetected => "fault-detected",
        _ => "no-pose",
    }
}

fn write_file(
    path: &Path,
    f: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), OutputError> {
    let err = |e| OutputError::new(path, e);
    let file = std::fs::File::create(path).map_err(err)?;
    let mut w = std::io::BufWriter::new(file);
    f(&mut w).map_err(err)?;
    w.flush().map_err(err)
}

/// Writes `trajectories.csv`, `metrics.json` and `scenario.toml` (with a copy of a CSV
/// centre line) into `dir` (created if
/// needed); `prefix` is prepended to each name (e.g. `"p1-"`). Returns the paths written.
pub fn write_run(
    dir: &Path,
    prefix: &str,
    log: &RunLog,
    m: &Metrics,
) -> Result<Vec<PathBuf>, OutputError> {
    std::fs::create_dir_all(dir).map_err(|e| OutputError::new(dir, e))?;
    let csv = dir.join(format!("{prefix}trajectories.csv"));
    write_file(&csv, |w| write_trajectories_csv(log, w))?;
    let json = dir.join(format!("{prefix}metrics.json"));
    let body = serde_json::to_string_pretty(&MetricsJson::new(log, m)).unwrap_or_default();
    write_file(&json, |w| w.write_all(body.as_bytes()))?;
    let toml = dir.join(format!("{prefix}scenario.toml"));
    let scenario = log
        .scenario
        .write_self_contained(dir, prefix)
        .map_err(|e| OutputError::new(&toml, e))?;
    Ok([csv, json].into_iter().chain(scenario).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::named::named;
    use crate::scenario::Scenario;

    #[test]
    fn writes_csv_json_and_a_scenario_that_reruns() {
        let s = named("paper-10m").unwrap();
        let log = crate::session::odometry_run(&s);
        let m = log.metrics();
        let dir = tempfile::tempdir().unwrap();
        let files = write_run(dir.path(), "", &log, &m).unwrap();
        let csv = std::fs::read_to_string(&files[0]).unwrap();
        assert_eq!(csv.lines().count(), log.samples.len() + 1);
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&files[1]).unwrap()).unwrap();
        for key in [
            "position_rms_m",
            "heading_rms_rad",
            "mse_eq2",
            "max_position_error_m",
            "odometry_position_rms_m",
            "first_100m_position_rms_m",
            "last_100m_position_rms_m",
            "scans",
            "mean_us_per_scan",
        ] {
            assert!(json.get(key).is_some(), "missing {key}");
        }
        assert_eq!(json["scans"], log.samples.len());
        let again = Scenario::from_file(&files[2]).unwrap();
        assert_eq!(again.seed, s.seed);
        assert_eq!(again.tunnel, s.tunnel);
    }
}
