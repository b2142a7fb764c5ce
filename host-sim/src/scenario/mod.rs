//! A run's complete description: tunnel, landmarks, lidar, vehicle, odometry, drive and
//! localiser settings, and the seed. Read from a TOML file (every key optional except
//! the tunnel's shape; unknown keys are errors naming the key and line) or taken from a
//! named scenario ([`named`]) and adjusted by command-line flags.
//!
//! ```toml
//! name = "my-tunnel"
//! seed = 7
//! [tunnel]
//! width_m = 5.0
//! roughness_sigma_m = 0.01
//! pieces = [ { length_m = 200.0 }, { length_m = 150.0, radius_m = -300.0 } ]
//! [landmarks]
//! model = "p1"          # none, p1..p4, f1..f4
//! genes = [0.5, 0.25, 9.0]
//! missing_every = 5
//! [localizer]
//! matcher = "hausdorff" # or "icp"
//! ```

pub mod named;
pub mod overrides;

use std::fmt;
use std::path::{Path, PathBuf};

use loc_core::rng::Pcg32;
use serde::{Deserialize, Serialize};

use crate::landmarks::{LandmarkChoice, LandmarkChoiceError};
use crate::lidar::LidarSpec;
use crate::traffic::TrafficSpec;
use crate::vehicle::odometry::OdometrySpec;
use crate::vehicle::path_follower::DriveSpec;
use crate::vehicle::skid_steer::SkidSteerSpec;
use crate::world::centerline::{CenterLine, CurvePiece};
use crate::world::centerline_check;
use crate::world::layout::{Damage, DamageKind, LayoutSpec, Omission, WallChoice};
use crate::world::{TunnelSpec, World};

/// One piece of the centre line in a scenario file.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PieceConfig {
    /// Length along the curve, metres.
    pub length_m: f64,
    /// Turn radius, metres: positive turns left, negative right, absent is straight.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius_m: Option<f64>,
}

/// The tunnel section of a scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TunnelConfig {
    /// Wall-to-wall width, metres.
    #[serde(default = "default_width")]
    pub width_m: f64,
    /// Wall roughness standard deviation, metres.
    #[serde(default = "default_roughness")]
    pub roughness_sigma_m: f64,
    /// Wall roughness correlation length, metres.
    #[serde(default = "default_correlation")]
    pub roughness_correlation_m: f64,
    /// Centre line as constant-curvature pieces from the origin heading +x.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub pieces: Vec<PieceConfig>,
    /// Or: centre line from a CSV file of `x,y` metres (relative to the scenario file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub csv: Option<PathBuf>,
}

fn default_width() -> f64 {
    5.0
}
fn default_roughness() -> f64 {
    0.01
}
fn default_correlation() -> f64 {
    1.0
}

/// How damaged landmarks are damaged, in a scenario file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DamageKindConfig {
    /// Bent by `bend_deg`.
    Bent,
    /// Only `keep_fraction` of the width remains.
    PartlyMissing,
}

/// The landmark section of a scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LandmarkConfig {
    /// `none`, `p1`…`p4`, `f1`…`f4`.
    #[serde(default = "default_model")]
    pub model: String,
    /// Genes W,H,D[,h1..h6]; absent: the model's paper-optimum default.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub genes: Option<Vec<f64>>,
    /// Walls that carry landmarks: `left`, `right`, `both`.
    #[serde(default)]
    pub walls: WallChoice,
    /// Chainage of the first landmark on the left wall, metres.
    #[serde(default = "default_first")]
    pub first_m: f64,
    /// Start the right wall's sequence D/2 later than the left's.
    #[serde(default = "default_true")]
    pub stagger: bool,
    /// Every n-th landmark of each wall is missing in the true tunnel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub missing_every: Option<u32>,
    /// Or: each landmark is missing with this probability.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub missing_fraction: Option<f64>,
    /// Fraction of the present landmarks that are damaged (0: none).
    #[serde(default)]
    pub damage_fraction: f64,
    /// Kind of damage.
    #[serde(default = "default_damage_kind")]
    pub damage: DamageKindConfig,
    /// Bend angle of bent landmarks, degrees.
    #[serde(default = "default_bend")]
    pub bend_deg: f64,
    /// Remaining width fraction of partly missing landmarks.
    #[serde(default = "default_keep")]
    pub keep_fraction: f64,
    /// Installation error: σ of each landmark's mounting position along its wall against
    /// its design mark, metres (0: installed exactly on the marks). The design map keeps
    /// the marks; the true tunnel has the landmarks where they were mounted.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub install_sd_m: f64,
    /// Installation error: σ of each landmark's stand-off from the wall surface, metres
    /// (folded to be non-negative).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub install_standoff_sd_m: f64,
    /// Landmarks moved along their wall after the map was made (knocked, remounted): in
    /// the true tunnel only, on top of the installation error.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub moved: Vec<MovedLandmark>,
    /// Fraction of the landmarks moved at random after the map was made (true tunnel
    /// only), each by `moved_range_m` along its wall, either way (0: none).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub moved_fraction: f64,
    /// How far those move, `[min_m, max_m]`, metres.
    #[serde(default = "default_moved_range")]
    pub moved_range_m: [f64; 2],
    /// Every landmark with its centre in this chainage stretch `[from_m, to_m]` is missing
    /// from the true tunnel (never installed, or torn off by a blast): a stretch without
    /// landmarks that the design still has.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub missing_stretch_m: Option<[f64; 2]>,
}

/// One landmark moved along its wall in the true tunnel.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MovedLandmark {
    /// Its index in the layout (as in `export-map --format json`).
    pub index: usize,
    /// How far it moved along the wall, metres (+: increasing chainage).
    pub along_m: f64,
}

fn default_moved_range() -> [f64; 2] {
    [0.1, 0.3]
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

fn default_model() -> String {
    "p1".into()
}
fn default_first() -> f64 {
    2.0
}
fn default_true() -> bool {
    true
}
fn default_damage_kind() -> DamageKindConfig {
    DamageKindConfig::Bent
}
fn default_bend() -> f64 {
    15.0
}
fn default_keep() -> f64 {
    0.5
}

impl Default for LandmarkConfig {
    fn default() -> Self {
        Self {
            model: default_model(),
            genes: None,
            walls: WallChoice::Both,
            first_m: default_first(),
            stagger: true,
            missing_every: None,
            missing_fraction: None,
            damage_fraction: 0.0,
            damage: default_damage_kind(),
            bend_deg: default_bend(),
            keep_fraction: default_keep(),
            install_sd_m: 0.0,
            install_standoff_sd_m: 0.0,
            moved: Vec::new(),
            moved_fraction: 0.0,
            moved_range_m: default_moved_range(),
            missing_stretch_m: None,
        }
    }
}

/// Which scan matcher the localiser uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MatcherChoice {
    /// Modified Hausdorff distance over the K best points (the paper's).
    #[default]
    Hausdorff,
    /// Point-to-line ICP.
    Icp,
}

impl MatcherChoice {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            MatcherChoice::Hausdorff => "hausdorff",
            MatcherChoice::Icp => "icp",
        }
    }
}

/// Which echo of each beam the localiser's scan input takes (scan-input's
/// [`scan_input::EchoSelection`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum EchoChoice {
    /// The first echo (`DIST1`): dust in front of the wall is taken as the range.
    First,
    /// The last echo: the wall behind dust or spray (scan-input's default).
    #[default]
    Last,
}

impl EchoChoice {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            EchoChoice::First => "first",
            EchoChoice::Last => "last",
        }
    }

    /// The scan input's selection.
    pub fn selection(self) -> scan_input::EchoSelection {
        match self {
            EchoChoice::First => scan_input::EchoSelection::First,
            EchoChoice::Last => scan_input::EchoSelection::Last,
        }
    }
}

fn is_default_echo(e: &EchoChoice) -> bool {
    *e == EchoChoice::default()
}

/// The localiser section of a scenario.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LocalizerConfig {
    /// Scan matcher.
    pub matcher: MatcherChoice,
    /// Standard deviation of the initial position error given to the localiser, metres
    /// (the initial estimate is the true start pose shifted by a draw of it).
    pub initial_sigma_m: f64,
    /// Standard deviation of the initial heading error, radians.
    pub initial_sigma_rad: f64,
    /// Random odometry drift the localiser is told to expect: 1σ along-track error as a
    /// fraction of `odometry_drift_length_m` driven (loc-core's `OdometryNoise`; the scale
    /// error is the localiser's state, below).
    pub odometry_drift_fraction: f64,
    /// Distance over which `odometry_drift_fraction` holds, metres (a random walk whose
    /// variance reaches `(fraction · length)²` after `length`).
    pub odometry_drift_length_m: f64,
    /// Heading drift the localiser is told to expect, radians per metre over the same length.
    pub odometry_heading_drift_rad_per_m: f64,
    /// 1σ of the odometry's scale error before the landmarks calibrate it (dimensionless).
    pub odometry_scale_sd: f64,
    /// 1σ change of the odometry's scale error over `odometry_scale_drift_length_m`.
    pub odometry_scale_drift_sd: f64,
    /// Distance over which `odometry_scale_drift_sd` holds, metres.
    pub odometry_scale_drift_length_m: f64,
    /// Which echo of each beam the scan input takes (`first` or `last`).
    #[serde(skip_serializing_if = "is_default_echo")]
    pub echo: EchoChoice,
}

impl Default for LocalizerConfig {
    /// loc-core's defaults (Hausdorff, its odometry noise model), an initial estimate 5 cm
    /// and 0.01 rad off.
    fn default() -> Self {
        let odometry = loc_core::filter::OdometryNoise::default();
        // The f32's shortest decimal (0.01, not 0.009999999776…) in scenario files.
        let decimal = |v: f32| v.to_string().parse().unwrap_or(f64::from(v));
        Self {
            matcher: MatcherChoice::Hausdorff,
            initial_sigma_m: 0.05,
            initial_sigma_rad: 0.01,
            odometry_drift_fraction: decimal(odometry.drift_fraction),
            odometry_drift_length_m: decimal(odometry.drift_length_m),
            odometry_heading_drift_rad_per_m: decimal(odometry.heading_drift_rad_per_m),
            odometry_scale_sd: decimal(odometry.scale_sd),
            odometry_scale_drift_sd: decimal(odometry.scale_drift_sd),
            odometry_scale_drift_length_m: decimal(odometry.scale_drift_length_m),
            echo: EchoChoice::Last,
        }
    }
}

/// A complete run description.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Name for reports.
    #[serde(default = "default_name")]
    pub name: String,
    /// Seed of every random draw of the run (world, noise, slip).
    #[serde(default)]
    pub seed: u64,
    /// Tunnel shape and walls.
    pub tunnel: TunnelConfig,
    /// Landmarks.
    #[serde(default)]
    pub landmarks: LandmarkConfig,
    /// The LMS511.
    #[serde(default)]
    pub lidar: LidarSpec,
    /// The loader.
    #[serde(default)]
    pub vehicle: SkidSteerSpec,
    /// Its odometry.
    #[serde(default)]
    pub odometry: OdometrySpec,
    /// The drive.
    #[serde(default)]
    pub drive: DriveSpec,
    /// The localiser.
    #[serde(default)]
    pub localizer: LocalizerConfig,
    /// People and vehicles moving through the tunnel (in the scans, not in the map).
    #[serde(default, skip_serializing_if = "TrafficSpec::is_empty")]
    pub traffic: TrafficSpec,
    /// Directory that relative paths in the file are relative to (not a key).
    #[serde(skip)]
    pub base_dir: PathBuf,
}

/// The name [`Scenario::write_self_contained`] gives the copy of a CSV centre line.
pub const CENTERLINE_COPY: &str = "centerline.csv";

fn default_name() -> String {
    "scenario".into()
}

/// Why a scenario could not be used.
#[derive(Debug)]
pub enum ScenarioError {
    /// The file could not be read.
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The file is not valid TOML for a scenario (the message names the key and line).
    Parse {
        /// The file.
        path: PathBuf,
        /// toml's message, with line, column and key.
        message: String,
    },
    /// A value is out of its range.
    Invalid {
        /// Dotted key, e.g. `tunnel.width_m`.
        key: &'static str,
        /// What is wrong and what is allowed.
        reason: String,
    },
    /// A value of a scenario file is out of its range.
    InvalidAt {
        /// The file.
        path: PathBuf,
        /// The line of the key.
        line: usize,
        /// Dotted key.
        key: &'static str,
        /// What is wrong and what is allowed.
        reason: String,
    },
    /// The landmark model or genes are wrong.
    Landmarks(LandmarkChoiceError),
    /// No scenario of that name.
    UnknownName(String),
}

impl fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ScenarioError::Io { path, source } => {
                write!(f, "cannot read scenario {}: {source}", path.display())
            }
            ScenarioError::Parse { path, message } => {
                write!(f, "scenario {} is not valid: {message}", path.display())
            }
            ScenarioError::Invalid { key, reason } => write!(f, "scenario key `{key}`: {reason}"),
            ScenarioError::InvalidAt {
                path,
                line,
                key,
                reason,
            } => write!(
                f,
                "scenario {} line {line}, key `{key}`: {reason}",
                path.display()
            ),
            ScenarioError::Landmarks(e) => write!(f, "scenario key `landmarks`: {e}"),
            ScenarioError::UnknownName(n) => write!(
                f,
                "no scenario named `{n}`: use one of {}",
                named::NAMES.join(", ")
            ),
        }
    }
}

impl std::error::Error for ScenarioError {}

impl From<LandmarkChoiceError> for ScenarioError {
    fn from(e: LandmarkChoiceError) -> Self {
        ScenarioError::Landmarks(e)
    }
}

/// The line (1-based) of a dotted key in TOML text: `tunnel.width_m` is `width_m` under
/// `[tunnel]`, `tunnel.pieces.length_m` the `pieces` line there, `seed` a top-level key.
fn line_of_key(text: &str, dotted: &str) -> Option<usize> {
    let mut parts = dotted.split('.');
    let (table, field) = match (parts.next(), parts.next()) {
        (Some(t), Some(f)) => (t, f),
        (Some(f), None) => ("", f),
        _ => return None,
    };
    let mut current = "";
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if let Some(name) = t.strip_prefix('[').and_then(|r| r.split(']').next()) {
            current = name.trim();
            continue;
        }
        let key = t.split('=').next().unwrap_or("").trim();
        if current == table && key == field && t.contains('=') {
            return Some(i + 1);
        }
    }
    None
}

fn check(ok: bool, key: &'static str, reason: &str) -> Result<(), ScenarioError> {
    if ok {
        Ok(())
    } else {
        Err(ScenarioError::Invalid {
            key,
            reason: reason.to_string(),
        })
    }
}

impl Scenario {
    /// Reads and validates a scenario file.
    pub fn from_file(path: &Path) -> Result<Self, ScenarioError> {
        let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let at_line = |e| match e {
            ScenarioError::Parse { message, .. } => ScenarioError::Parse {
                path: path.to_path_buf(),
                message,
            },
            ScenarioError::Invalid { key, reason } => match line_of_key(&text, key) {
                Some(line) => ScenarioError::InvalidAt {
                    path: path.to_path_buf(),
                    line,
                    key,
                    reason,
                },
                None => ScenarioError::Invalid { key, reason },
            },
            other => other,
        };
        let mut s = Self::from_toml(&text).map_err(at_line)?;
        s.base_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        // The centre line's geometry too, before any simulation.
        s.centerline().map_err(at_line)?;
        Ok(s)
    }

    /// Parses and validates scenario TOML text.
    pub fn from_toml(text: &str) -> Result<Self, ScenarioError> {
        let s: Scenario = toml::from_str(text).map_err(|e| ScenarioError::Parse {
            path: PathBuf::from("<text>"),
            message: e.to_string(),
        })?;
        s.validate()?;
        Ok(s)
    }

    /// The scenario as TOML (what `--out` writes next to the results, to rerun it).
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_default()
    }

    /// Writes the scenario into `dir` so that it stands on its own: `{prefix}scenario.toml`,
    /// and a CSV centre line copied beside it as `{prefix}centerline.csv` (the TOML then
    /// names that copy), so the directory reruns or replays without the original files.
    /// Returns the files written.
    pub fn write_self_contained(&self, dir: &Path, prefix: &str) -> std::io::Result<Vec<PathBuf>> {
        let mut s = self.clone();
        let mut written = Vec::new();
        if let Some(csv) = &self.tunnel.csv {
            let name = format!("{prefix}{CENTERLINE_COPY}");
            let copy = dir.join(&name);
            std::fs::copy(self.base_dir.join(csv), &copy)?;
            s.tunnel.csv = Some(PathBuf::from(name));
            written.push(copy);
        }
        let toml = dir.join(format!("{prefix}scenario.toml"));
        std::fs::write(&toml, s.to_toml())?;
        written.insert(0, toml);
        Ok(written)
    }

    /// Checks every value's range; the error names the key.
    pub fn validate(&self) -> Result<(), ScenarioError> {
        let t = &self.tunnel;
        check(
            t.width_m.is_finite() && t.width_m > 0.5,
            "tunnel.width_m",
            "must be a width above 0.5 m",
        )?;
        check(
            t.roughness_sigma_m.is_finite() && (0.0..=0.2).contains(&t.roughness_sigma_m),
            "tunnel.roughness_sigma_m",
            "must lie in [0, 0.2] m",
        )?;
        check(
            t.roughness_correlation_m.is_finite() && t.roughness_correlation_m >= 0.0,
            "tunnel.roughness_correlation_m",
            "must be ≥ 0 m",
        )?;
        check(
            t.pieces.is_empty() != t.csv.is_none(),
            "tunnel.pieces",
            "give either `pieces` or `csv` for the centre line (exactly one)",
        )?;
        for p in &t.pieces {
            check(
                p.length_m.is_finite() && p.length_m > 0.0,
                "tunnel.pieces.length_m",
                "must be > 0 m",
            )?;
            if let Some(r) = p.radius_m {
                check(
                    r.is_finite() && r.abs() >= 5.0,
                    "tunnel.pieces.radius_m",
                    "must be at least 5 m in magnitude",
                )?;
            }
        }
        let l = &self.landmarks;
        let choice = LandmarkChoice::parse(&l.model, l.genes.as_deref())?;
        // Spacing draws U[D − 0.625, D + 0.625]: the nearest neighbour's base must clear
        // this landmark's.
        let profile = choice.profile();
        let (lo, hi) = profile
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p.0), hi.max(p.0))
            });
        let width_m = hi - lo;
        let closest_m = choice.spacing_m() - crate::world::layout::SPACING_JITTER_M;
        check(
            profile.is_empty() || width_m < closest_m,
            "landmarks.genes",
            &format!(
                "landmarks {width_m:.3} m wide at a spacing D = {:.3} m (neighbours as close as D − {} m = {closest_m:.3} m) overlap their neighbours: make D at least {:.3} m",
                choice.spacing_m(),
                crate::world::layout::SPACING_JITTER_M,
                width_m + crate::world::layout::SPACING_JITTER_M
            ),
        )?;
        check(
            l.first_m.is_finite(),
            "landmarks.first_m",
            "must be a finite chainage",
        )?;
        if let Some(n) = l.missing_every {
            check(
                n >= 2,
                "landmarks.missing_every",
                "must be ≥ 2 (2 = every second missing)",
            )?;
        }
        if let Some(f) = l.missing_fraction {
            check(
                (0.0..=1.0).contains(&f),
                "landmarks.missing_fraction",
                "must lie in [0, 1]",
            )?;
        }
        check(
            l.missing_every.is_none() || l.missing_fraction.is_none(),
            "landmarks.missing_every",
            "give missing_every or missing_fraction, not both",
        )?;
        check(
            (0.0..=1.0).contains(&l.damage_fraction),
            "landmarks.damage_fraction",
            "must lie in [0, 1]",
        )?;
        check(
            (0.0..=1.0).contains(&l.keep_fraction),
            "landmarks.keep_fraction",
            "must lie in [0, 1]",
        )?;
        check(
            l.install_sd_m.is_finite() && (0.0..=0.5).contains(&l.install_sd_m),
            "landmarks.install_sd_m",
            "must lie in [0, 0.5] m",
        )?;
        check(
            l.install_standoff_sd_m.is_finite() && (0.0..=0.2).contains(&l.install_standoff_sd_m),
            "landmarks.install_standoff_sd_m",
            "must lie in [0, 0.2] m",
        )?;
        check(
            l.missing_stretch_m
                .is_none_or(|[a, b]| a.is_finite() && b.is_finite() && a <= b),
            "landmarks.missing_stretch_m",
            "must be [from_m, to_m] with from_m <= to_m",
        )?;
        check(
            l.moved
                .iter()
                .all(|m| m.along_m.is_finite() && m.along_m.abs() <= 5.0),
            "landmarks.moved",
            "each along_m must lie in [-5, 5] m",
        )?;
        check(
            (0.0..=1.0).contains(&l.moved_fraction),
            "landmarks.moved_fraction",
            "must lie in [0, 1]",
        )?;
        check(
            l.moved_range_m
                .iter()
                .all(|v| v.is_finite() && (0.0..=5.0).contains(v))
                && l.moved_range_m[0] <= l.moved_range_m[1],
            "landmarks.moved_range_m",
            "must be [min_m, max_m] within [0, 5] m with min_m <= max_m",
        )?;
        check(
            l.bend_deg.is_finite() && l.bend_deg.abs() <= 90.0,
            "landmarks.bend_deg",
            "must lie in [-90, 90]",
        )?;
        let d = &self.lidar;
        check(
            d.range_noise_m.is_finite() && (0.0..=0.5).contains(&d.range_noise_m),
            "lidar.range_noise_m",
            "must lie in [0, 0.5] m",
        )?;
        check(
            d.systematic_error_m.is_finite() && d.systematic_error_m.abs() <= 0.5,
            "lidar.systematic_error_m",
            "must lie in [-0.5, 0.5] m",
        )?;
        check(
            d.max_range_m > 0.0 && d.max_range_m <= 80.0,
            "lidar.max_range_m",
            "must lie in (0, 80] m",
        )?;
        let problems = [d.dust.problem(), self.traffic.problem(self.tunnel.width_m)];
        if let Some((key, reason)) = problems.into_iter().flatten().next() {
            return Err(ScenarioError::Invalid {
                key,
                reason: reason.to_string(),
            });
        }
        let v = &self.vehicle;
        check(
            v.track_width_m > 0.1 && v.track_width_m.is_finite(),
            "vehicle.track_width_m",
            "must be > 0.1 m",
        )?;
        check(
            v.icr_expansion >= 1.0 && v.icr_expansion < 5.0,
            "vehicle.icr_expansion",
            "must lie in [1, 5)",
        )?;
        check(
            (0.0..0.5).contains(&v.slip_mean),
            "vehicle.slip_mean",
            "must lie in [0, 0.5)",
        )?;
        check(
            v.slip_std >= 0.0 && v.slip_std < 0.2,
            "vehicle.slip_std",
            "must lie in [0, 0.2)",
        )?;
        let o = &self.odometry;
        check(
            o.rate_hz >= 1.0 && o.rate_hz <= 1000.0,
            "odometry.rate_hz",
            "must lie in [1, 1000] Hz",
        )?;
        check(
            o.scale_error.abs() < 0.5,
            "odometry.scale_error",
            "must lie in (-0.5, 0.5)",
        )?;
        check(
            o.calibrated_icr_expansion >= 0.5 && o.calibrated_icr_expansion < 5.0,
            "odometry.calibrated_icr_expansion",
            "must lie in [0.5, 5)",
        )?;
        check(
            o.speed_noise_mps >= 0.0 && o.speed_noise_mps < 1.0,
            "odometry.speed_noise_mps",
            "must lie in [0, 1) m/s",
        )?;
        let r = &self.drive;
        check(
            r.cruise_speed_mps > 0.0 && r.cruise_speed_mps <= 15.0,
            "drive.cruise_speed_mps",
            "must lie in (0, 15] m/s",
        )?;
        check(r.accel_mps2 > 0.0, "drive.accel_mps2", "must be > 0")?;
        check(
            r.lateral_accel_mps2 > 0.0,
            "drive.lateral_accel_mps2",
            "must be > 0",
        )?;
        check(
            r.lateral_offset_m.abs() < t.width_m / 2.0,
            "drive.lateral_offset_m",
            "must keep the path inside the tunnel",
        )?;
        check(
            r.start_m >= 0.0 && r.start_m < r.end_m,
            "drive.start_m",
            "must be ≥ 0 and before drive.end_m",
        )?;
        let c = &self.localizer;
        check(
            c.initial_sigma_m >= 0.0 && c.initial_sigma_m < 5.0,
            "localizer.initial_sigma_m",
            "must lie in [0, 5) m",
        )?;
        check(
            c.initial_sigma_rad >= 0.0 && c.initial_sigma_rad < 1.0,
            "localizer.initial_sigma_rad",
            "must lie in [0, 1) rad",
        )?;
        let fraction = |v: f64| v.is_finite() && (0.0..1.0).contains(&v);
        let length = |v: f64| v.is_finite() && v > 0.0 && v <= 1.0e4;
        for (v, key) in [
            (
                c.odometry_drift_fraction,
                "localizer.odometry_drift_fraction",
            ),
            (c.odometry_scale_sd, "localizer.odometry_scale_sd"),
            (
                c.odometry_scale_drift_sd,
                "localizer.odometry_scale_drift_sd",
            ),
        ] {
            check(
                fraction(v),
                key,
                "must lie in [0, 1) (a fraction, 0.01 = 1 %)",
            )?;
        }
        for (v, key) in [
            (
                c.odometry_drift_length_m,
                "localizer.odometry_drift_length_m",
            ),
            (
                c.odometry_scale_drift_length_m,
                "localizer.odometry_scale_drift_length_m",
            ),
        ] {
            check(length(v), key, "must lie in (0, 10 000] m")?;
        }
        check(
            c.odometry_heading_drift_rad_per_m.is_finite()
                && (0.0..1.0).contains(&c.odometry_heading_drift_rad_per_m),
            "localizer.odometry_heading_drift_rad_per_m",
            "must lie in [0, 1) rad/m",
        )?;
        Ok(())
    }

    /// The landmark design.
    pub fn landmark_choice(&self) -> Result<LandmarkChoice, ScenarioError> {
        Ok(LandmarkChoice::parse(
            &self.landmarks.model,
            self.landmarks.genes.as_deref(),
        )?)
    }

    /// The centre line (reads the CSV file if the scenario names one), checked: a tunnel of
    /// the scenario's width can follow it ([`centerline_check`]), and the drive stays on it.
    pub fn centerline(&self) -> Result<CenterLine, ScenarioError> {
        let (line, key) = self.unchecked_centerline()?;
        centerline_check::check(&line, self.tunnel.width_m).map_err(|e| {
            ScenarioError::Invalid {
                key,
                reason: e.to_string(),
            }
        })?;
        let length_m = line.length_m();
        let d = &self.drive;
        check(
            d.start_m < length_m,
            "drive.start_m",
            &format!(
                "the drive starts at chainage {} m, past the tunnel's end ({length_m:.2} m)",
                d.start_m
            ),
        )?;
        check(
            d.end_m.is_infinite() || d.end_m <= length_m + 1e-6,
            "drive.end_m",
            &format!(
                "the drive ends at chainage {} m, past the tunnel's end ({length_m:.2} m): drive at most {:.2} m from drive.start_m (--length), or leave drive.end_m out to drive to the end",
                d.end_m,
                length_m - d.start_m
            ),
        )?;
        Ok(line)
    }

    /// The centre line as given, and the key it came from.
    fn unchecked_centerline(&self) -> Result<(CenterLine, &'static str), ScenarioError> {
        if let Some(csv) = &self.tunnel.csv {
            let path = self.base_dir.join(csv);
            let text = std::fs::read_to_string(&path).map_err(|source| ScenarioError::Io {
                path: path.clone(),
                source,
            })?;
            return CenterLine::parse_csv(&text)
                .map(|l| (l, "tunnel.csv"))
                .map_err(|e| ScenarioError::Invalid {
                    key: "tunnel.csv",
                    reason: format!("{}: {e}", path.display()),
                });
        }
        let pieces: Vec<CurvePiece> = self
            .tunnel
            .pieces
            .iter()
            .map(|p| CurvePiece {
                length_m: p.length_m,
                curvature_per_m: p.radius_m.map_or(0.0, |r| 1.0 / r),
            })
            .collect();
        CenterLine::from_pieces(&pieces)
            .map(|l| (l, "tunnel.pieces"))
            .map_err(|e| ScenarioError::Invalid {
                key: "tunnel.pieces",
                reason: e.to_string(),
            })
    }

    /// The tunnel's geometry: centre line, width, wall roughness.
    pub fn tunnel_spec(&self) -> Result<TunnelSpec, ScenarioError> {
        Ok(TunnelSpec {
            centerline: self.centerline()?,
            width_m: self.tunnel.width_m,
            roughness_sigma_m: self.tunnel.roughness_sigma_m,
            roughness_correlation_m: self.tunnel.roughness_correlation_m,
        })
    }

    /// Builds the world (true geometry and design) from the scenario's seed.
    pub fn build_world(&self) -> Result<World, ScenarioError> {
        let tunnel = self.tunnel_spec()?;
        let choice = self.landmark_choice()?;
        let len = tunnel.centerline.length_m();
        let l = &self.landmarks;
        let omission = match (l.missing_every, l.missing_fraction) {
            (Some(n), _) => Omission::EveryNth(n),
            (None, Some(f)) => Omission::RandomFraction(f),
            (None, None) => Omission::None,
        };
        let damage = (l.damage_fraction > 0.0).then(|| Damage {
            fraction: l.damage_fraction,
            kind: match l.damage {
                DamageKindConfig::Bent => DamageKind::Bent {
                    angle_rad: l.bend_deg.to_radians(),
                },
                DamageKindConfig::PartlyMissing => DamageKind::PartlyMissing {
                    keep_fraction: l.keep_fraction,
                },
            },
        });
        let spacing = choice.spacing_m();
        let half_width = match choice {
            LandmarkChoice::None => 0.0,
            LandmarkChoice::Shape(s) => f64::from(s.genome.width_m) / 2.0,
        };
        let mut rng = Pcg32::new(self.seed, 0x3a11);
        let base = LayoutSpec {
            spacing_m: spacing,
            first_m: l.first_m,
            last_m: len - half_width,
            walls: l.walls,
            omission,
            damage,
        };
        let profile = choice.profile();
        // The right wall's sequence starts D/2 later when staggered: lay out each wall on
        // its own and merge, left first.
        let world = if l.stagger && l.walls == WallChoice::Both {
            let left = LayoutSpec {
                walls: WallChoice::Left,
                ..base
            };
            let right = LayoutSpec {
                walls: WallChoice::Right,
                first_m: l.first_m + spacing / 2.0,
                ..base
            };
            World::build(&tunnel, &[left, right], profile, &mut rng)
        } else {
            World::build(&tunnel, &[base], profile, &mut rng)
        };
        let mut world = world;
        // A stream of its own: worlds without installation errors stay as they were.
        world.install_with_errors(
            l.install_sd_m,
            l.install_standoff_sd_m,
            &mut Pcg32::new(self.seed, 0x1257),
        );
        if let Some([from, to]) = l.missing_stretch_m {
            world.remove_landmarks_between(from, to);
        }
        if l.moved_fraction > 0.0 {
            // A stream of its own: the other draws stay as they were.
            let mut rng = Pcg32::new(self.seed, 0x30fe);
            let [lo, hi] = l.moved_range_m;
            for i in 0..world.placements().len() {
                if f64::from(rng.uniform01()) < l.moved_fraction {
                    let d = lo + f64::from(rng.uniform01()) * (hi - lo);
                    let sign = if rng.uniform01() < 0.5 { -1.0 } else { 1.0 };
                    world.move_landmark(i, sign * d);
                }
            }
        }
        for m in &l.moved {
            let count = world.placements().len();
            if !world.move_landmark(m.index, m.along_m) {
                return Err(ScenarioError::Invalid {
                    key: "landmarks.moved",
                    reason: format!(
                        "landmark {} does not exist (the layout has {count}, indices from 0)",
                        m.index
                    ),
                });
            }
        }
        Ok(world)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
name = "t"
seed = 3
[tunnel]
width_m = 4.0
pieces = [ { length_m = 50.0 }, { length_m = 30.0, radius_m = -100.0 } ]
[landmarks]
model = "p1"
missing_every = 5
[drive]
cruise_speed_mps = 2.0
"#;

    #[test]
    fn a_moved_fraction_moves_that_share_of_the_true_landmarks_by_the_range() {
        let mut s = crate::scenario::named::named("tunnel-1km").unwrap();
        s.landmarks.model = "p1".into();
        let before = s.build_world().unwrap();
        s.landmarks.moved_fraction = 0.2;
        let after = s.build_world().unwrap();
        let n = before.placements().len();
        let mut moved = 0;
        for i in 0..n {
            // The design stays; the built landmark moves along its wall by 0.1-0.3 m.
            assert_eq!(
                before.landmark_polyline(i, false),
                after.landmark_polyline(i, false)
            );
            let (a, b) = (
                before.landmark_polyline(i, true)[0],
                after.landmark_polyline(i, true)[0],
            );
            let d = (a.0 - b.0).hypot(a.1 - b.1);
            if d > 1e-6 {
                assert!((0.09..=0.31).contains(&d), "landmark {i} moved {d} m");
                moved += 1;
            }
        }
        let share = moved as f64 / n as f64;
        assert!((0.12..=0.28).contains(&share), "{moved} of {n}");
        // Refused out of range.
        s.landmarks.moved_fraction = 1.5;
        assert!(s.validate().is_err());
    }

    #[test]
    fn parses_defaults_and_builds_a_world() {
        let s = Scenario::from_toml(GOOD).unwrap();
        assert_eq!(s.seed, 3);
        assert_eq!(s.lidar, LidarSpec::default());
        let w = s.build_world().unwrap();
        assert!((w.centerline().length_m() - 80.0).abs() < 1e-9);
        assert!(w.placements().len() >= 14);
        // Round trip through TOML.
        let again = Scenario::from_toml(&s.to_toml()).unwrap();
        assert_eq!(again, s);
    }

    #[test]
    fn errors_name_the_key_and_line() {
        let bad = GOOD.replace("cruise_speed_mps", "cruise_speed");
        let e = Scenario::from_toml(&bad).unwrap_err().to_string();
        assert!(e.contains("cruise_speed") && e.contains("line 11"), "{e}");
        let bad = GOOD.replace("width_m = 4.0", "width_m = -4.0");
        let e = Scenario::from_toml(&bad).unwrap_err().to_string();
        assert!(e.contains("tunnel.width_m"), "{e}");
        let bad = GOOD.replace("\"p1\"", "\"p7\"");
        let e = Scenario::from_toml(&bad).unwrap_err().to_string();
        assert!(e.contains("p7"), "{e}");
        let bad = GOOD.replace("width_m = 4.0", "width_m = \"wide\"");
        let e = Scenario::from_toml(&bad).unwrap_err().to_string();
        assert!(e.contains("line 5") && e.contains("width_m"), "{e}");
    }

    /// Impossible geometry is refused before any simulation, naming the line of the file:
    /// the TOML key's, or the CSV point's.
    #[test]
    fn impossible_geometry_is_refused_with_its_line() {
        let dir = tempfile::tempdir().unwrap();
        let write = |name: &str, text: &str| {
            let p = dir.path().join(name);
            std::fs::write(&p, text).unwrap();
            p
        };
        let refused = |text: &str| {
            Scenario::from_file(&write("s.toml", text))
                .unwrap_err()
                .to_string()
        };
        // A 6 m bend in a 20 m wide tunnel.
        let e = refused(
            "name = \"x\"\n[tunnel]\nwidth_m = 20.0\npieces = [ { length_m = 20.0 }, { length_m = 15.0, radius_m = 6.0 }, { length_m = 20.0 } ]\n",
        );
        assert!(
            e.contains("line 4") && e.contains("tighter than half"),
            "{e}"
        );
        // A survey that turns back at its fourth point (line 5 of the CSV).
        write("spike.csv", "x,y\n0,0\n10,0\n20,0\n15,0\n30,0\n40,0\n");
        let e = refused("[tunnel]\ncsv = \"spike.csv\"\n");
        assert!(e.contains("CSV line 4") && e.contains("turns back"), "{e}");
        // A loop closed twice.
        let circle: String = (0..=80)
            .map(|k| {
                let a = f64::from(k) * std::f64::consts::TAU / 72.0;
                format!("{},{}\n", 30.0 * a.sin(), 30.0 - 30.0 * a.cos())
            })
            .collect();
        write("loop.csv", &circle);
        let e = refused("[tunnel]\ncsv = \"loop.csv\"\n");
        assert!(e.contains("walls would cross"), "{e}");
        // A drive past the end of the tunnel.
        let e = refused(
            "[tunnel]\npieces = [ { length_m = 50.0 } ]\n[drive]\nstart_m = 5.0\nend_m = 80.0\n",
        );
        assert!(
            e.contains("line 5") && e.contains("past the tunnel's end"),
            "{e}"
        );
        // Landmarks wider than their closest spacing.
        let e = refused(
            "[tunnel]\npieces = [ { length_m = 50.0 } ]\n[landmarks]\nmodel = \"f4\"\ngenes = [1.5, 0.2, 1.25, 1, 1, 1, 1, 1, 1]\n",
        );
        assert!(
            e.contains("line 5") && e.contains("overlap their neighbours"),
            "{e}"
        );
        // --length past the end is refused, not clipped.
        let mut s = named::named("paper-10m").unwrap();
        overrides::Overrides {
            drive_length_m: Some(5000.0),
            ..overrides::Overrides::default()
        }
        .apply(&mut s)
        .unwrap();
        let e = s.build_world().unwrap_err().to_string();
        assert!(
            e.contains("drive.end_m") && e.contains("past the tunnel's end"),
            "{e}"
        );
    }

    #[test]
    fn the_shipped_example_builds() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/s-bend-400m.toml");
        let s = Scenario::from_file(&path).unwrap();
        let w = s.build_world().unwrap();
        assert!((w.centerline().length_m() - 400.0).abs() < 1.0);
        assert!(w.placements().len() > 80);
        assert_eq!(s.landmark_choice().unwrap().code(), "F4");
    }

    #[test]
    fn csv_centre_line_relative_to_the_file() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("line.csv"), "x,y\n0,0\n30,0\n60,5\n").unwrap();
        let file = dir.path().join("s.toml");
        std::fs::write(
            &file,
            "[tunnel]\ncsv = \"line.csv\"\n[landmarks]\nmodel = \"none\"\n",
        )
        .unwrap();
        let s = Scenario::from_file(&file).unwrap();
        let w = s.build_world().unwrap();
        assert!(w.centerline().length_m() > 60.0);
        assert!(w.placements().is_empty());
        let missing = Scenario::from_file(&dir.path().join("nope.toml")).unwrap_err();
        assert!(missing.to_string().contains("nope.toml"));
    }
}
