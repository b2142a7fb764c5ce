//! `host-sim`: the engineer's command line.
//!
//! - `host-sim demo`: a short drive with and without landmarks, side by side.
//! - `host-sim run [FILE] [--scenario NAME] [flags]`: one closed-loop run, a report or
//!   `--json`, and files in `--out DIR`.
//! - `host-sim export-map`: the stored map the localiser gets (postcard bytes or JSON).
//! - `host-sim replay DIR`: localises from a recording (`run --record DIR`, or a real
//!   vehicle's) and prints the same metrics.
//! - `host-sim optimize --model M --out DIR`: the paper's GA for a landmark design (resume,
//!   cluster shards, Fisher objective); `host-sim table2`: its Table 2;
//!   `host-sim compare-objectives`: GA/CMA-ES × simulation/Fisher.
//! - `host-sim design --model M --out DIR`: schedule, cutting template, bill of materials,
//!   map file and predicted accuracy of a layout.
//! - `host-sim survey DIR --out OUT`: the as-built map from one recorded drive.

mod survey_cli;

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use clap::{Args, Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};

use host_sim::closed_loop::{RunLog, RunOptions};
use host_sim::lidar::ScanRate;
use host_sim::map_export;
use host_sim::optimize::fitness::ObjectiveKind;
use host_sim::optimize::{
    self, ga::Halt, ga::Outcome, search, store::GenerationRow, store::SearchSpec, store::Shard,
    store::Store,
};
use host_sim::output::{self, MetricsJson};
use host_sim::record;
use host_sim::replay::{self, ReplaySources};
use host_sim::report::{self, Column};
use host_sim::scenario::named::{named, NAMES};
use host_sim::scenario::overrides::Overrides;
use host_sim::scenario::{EchoChoice, MatcherChoice, Scenario};
use host_sim::session::{run_scenario, EstimatorChoice};
use host_sim::stored_map;
use host_sim::visuals;
use loc_core::localizer::StartPose;

#[derive(Parser)]
#[command(
    name = "host-sim",
    version,
    about = "Tunnel, loader and LMS511 simulator running loc-core's localiser in closed loop"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// A short drive through a curved, rough tunnel with and without landmarks, side by side.
    Demo {
        /// Seed of every random draw.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// One closed-loop run: report (or --json) and files in --out.
    Run(RunArgs),
    /// The firmware in the loop: the scenario's drive fed to the controller under QEMU
    /// (emulated LMS511 on UART0, odometry in and poses out on UART1) in simulated time,
    /// scored with the same metrics as run.
    Hil(HilArgs),
    /// Writes the stored map of a scenario: postcard bytes (firmware) or JSON (people).
    ExportMap(ExportArgs),
    /// Localises from a recording (run --record DIR, or a real vehicle's) and reports the metrics.
    Replay(ReplayArgs),
    /// The paper's genetic algorithm: the landmark genes (shape and spacing) of one model that
    /// minimise the localisation MSE of simulated runs (files, figures and report.html in --out).
    Optimize(OptimizeArgs),
    /// The paper's Table 2: a GA search for each model with each matcher, each optimum
    /// validated on fresh seeds, beside the paper's values (table2.md in --out).
    Table2(Table2Args),
    /// GA + simulated MSE, GA + Fisher bound and CMA-ES + Fisher bound for one model, each
    /// optimum validated by simulation (comparison.md in --out).
    CompareObjectives(CompareArgs),
    /// What an engineer takes underground: installation schedule, 1:1 cutting template,
    /// bill of materials, the map file and the predicted accuracy along the tunnel.
    Design(DesignArgs),
    /// The stored map as built, from one recorded drive: walls and every landmark's pose
    /// estimated jointly with the trajectory, each landmark's uncertainty, what could not be
    /// surveyed (map, survey.json, landmarks.csv, report.txt and plots in --out).
    Survey(survey_cli::SurveyArgs),
    /// Global relocalisation: power-up at random places without a pose (or, with --kidnap,
    /// the vehicle moved 5-50 m where its odometry does not see), each run scored against
    /// the truth: metres to tracking, wrong locks.
    Relocalise(RelocaliseArgs),
    /// One scan's match error split into the walls' part and the range noise's: the vehicle
    /// at fixed poses, scanned again and again with fresh noise, each scan matched from the
    /// true pose; beside them the Cramér–Rao bound with and without the walls' roughness.
    Spread(SpreadArgs),
}

#[derive(Clone, Copy, ValueEnum)]
enum MatcherArg {
    Hausdorff,
    Icp,
}

#[derive(Clone, Copy, ValueEnum)]
enum EstimatorArg {
    /// loc-core's localiser.
    Localizer,
    /// Odometry alone (baseline).
    Odometry,
}

#[derive(Clone, Copy, ValueEnum)]
enum RateArg {
    #[value(name = "25")]
    Hz25,
    #[value(name = "35")]
    Hz35,
    #[value(name = "50")]
    Hz50,
    #[value(name = "75")]
    Hz75,
    #[value(name = "100")]
    Hz100,
}

#[derive(Clone, Copy, ValueEnum)]
enum EchoArg {
    /// The first echo (DIST1): dust in front of the wall is taken as the range.
    First,
    /// The last echo: the wall behind dust or spray.
    Last,
}

impl EchoArg {
    fn choice(self) -> EchoChoice {
        match self {
            EchoArg::First => EchoChoice::First,
            EchoArg::Last => EchoChoice::Last,
        }
    }
}

#[derive(Args)]
struct ScenarioArgs {
    /// Scenario file (TOML); see host-sim's README for the keys.
    file: Option<PathBuf>,
    /// Named scenario: paper-10m, tunnel-1km, demo-200m.
    #[arg(long, conflicts_with = "file")]
    scenario: Option<String>,
    /// Landmark model: none, p1, p2, p3, p4, f1, f2, f3, f4 (default genes: the paper's optimum).
    #[arg(long)]
    landmarks: Option<String>,
    /// Landmark genes W,H,D[,h1..h6] in metres (h as multiples of H).
    #[arg(long, allow_hyphen_values = true)]
    genes: Option<String>,
    /// Scan matcher.
    #[arg(long, value_enum)]
    matcher: Option<MatcherArg>,
    /// Seed of every random draw.
    #[arg(long)]
    seed: Option<u64>,
    /// Every N-th landmark of each wall is missing in the true tunnel.
    #[arg(long)]
    missing_every: Option<u32>,
    /// Fraction of landmarks missing at random (0–1).
    #[arg(long)]
    missing_fraction: Option<f64>,
    /// Fraction of present landmarks damaged (0–1; kind from the scenario, default bent 15°).
    #[arg(long)]
    damage_fraction: Option<f64>,
    /// Landmarks mounted off their design marks: σ along the wall, metres (the design map
    /// keeps the marks).
    #[arg(long)]
    install_sd: Option<f64>,
    /// A landmark moved along its wall after the map was made, `INDEX,ALONG_M` (true
    /// tunnel only; repeatable): what a survey refresh must detect.
    #[arg(long, value_name = "INDEX,ALONG_M")]
    move_landmark: Vec<String>,
    /// Fraction of the landmarks moved at random after the map was made, each 0.1-0.3 m
    /// along its wall either way (true tunnel only; `landmarks.moved_range_m` sets the
    /// range).
    #[arg(long)]
    moved_fraction: Option<f64>,
    /// Give the vehicle a yaw-rate gyro fused with the track encoders (STIM300-like: 4°/h
    /// bias, 0.15°/√h random walk; scenario key `odometry.gyro`): heading from the gyro,
    /// distance from the tracks.
    #[arg(long)]
    gyro: bool,
    /// No landmarks in the true tunnel between these chainages, `FROM_M,TO_M` (the design
    /// keeps them).
    #[arg(long, value_name = "FROM_M,TO_M")]
    missing_stretch: Option<String>,
    /// Drive only this many metres from the start.
    #[arg(long)]
    length: Option<f64>,
    /// Cruise speed, m/s.
    #[arg(long)]
    speed: Option<f64>,
    /// LMS511 scan rate in Hz (25, 35, 50, 75, 100; resolution follows).
    #[arg(long, value_enum)]
    rate: Option<RateArg>,
    /// Model the scanner's sweep, as a real LMS511 takes its beams (scenario `lidar.sweep`):
    /// each beam from where the vehicle was when the mirror passed it (21 ms over a 25 Hz
    /// scan); the localiser then carries each echo to the scan's last beam.
    #[arg(long)]
    sweep: bool,
    /// Dust or spray: this share of the beams (0–1) returns an early echo from a cloud,
    /// the wall on the next echo (scenario `[lidar.dust]`: range, blocked share, patches).
    #[arg(long, value_name = "FRACTION")]
    dust: Option<f64>,
    /// People walking through the tunnel (scenario `[traffic]`).
    #[arg(long, value_name = "N")]
    people: Option<u32>,
    /// Vehicles driving through the tunnel (scenario `[traffic]`).
    #[arg(long, value_name = "N")]
    vehicles: Option<u32>,
    /// Which echo of each beam the localiser takes (scenario `localizer.echo`; default
    /// last).
    #[arg(long, value_enum)]
    echo: Option<EchoArg>,
}

#[derive(Args)]
struct RunArgs {
    #[command(flatten)]
    scenario: ScenarioArgs,
    /// Estimator under test.
    #[arg(long, value_enum, default_value = "localizer")]
    estimator: EstimatorArg,
    /// Directory for trajectories.csv, metrics.json, scenario.toml, the plots (PNG, SVG) and run.mcap.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Record the drive as the vehicle would log it (LMS511 CoLa-B stream, odometry, ground
    /// truth, map) into this directory, for `host-sim replay`.
    #[arg(long)]
    record: Option<PathBuf>,
    /// Localise against this loc-core map file (e.g. `host-sim survey`'s survey.postcard)
    /// instead of the design's map; the simulated tunnel stays the scenario's.
    #[arg(long)]
    map: Option<PathBuf>,
    /// Print the metrics as one JSON object instead of the report.
    #[arg(long)]
    json: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Kidnap the vehicle: after AT_M driven, move it JUMP_M along the tunnel (negative:
    /// back) without odometry of the move (a tow, wheels sliding on mud). Repeatable.
    #[arg(long, value_name = "AT_M,JUMP_M", allow_hyphen_values = true)]
    kidnap: Vec<String>,
    /// Blank the lidar: no scan reaches the localiser for SECONDS from FROM_M driven (the
    /// odometry goes on). Repeatable.
    #[arg(long, value_name = "FROM_M,SECONDS")]
    blind: Vec<String>,
}

#[derive(Args)]
struct RelocaliseArgs {
    #[command(flatten)]
    scenario: ScenarioArgs,
    /// Runs, each from its own random place.
    #[arg(long, default_value_t = 100)]
    runs: u32,
    /// Metres driven per run (after the kidnapping, with --kidnap).
    #[arg(long, default_value_t = 40.0)]
    drive: f64,
    /// Kidnapping runs: start with the true pose, then move the vehicle along the tunnel.
    #[arg(long)]
    kidnap: bool,
    /// Metres driven before the kidnapping.
    #[arg(long, default_value_t = 10.0)]
    kidnap_after: f64,
    /// Shortest and longest kidnapping, metres: `MIN,MAX`.
    #[arg(long, default_value = "5,50")]
    jump: String,
    /// Seed of the start places and jumps.
    #[arg(long, default_value_t = 1)]
    study_seed: u64,
    /// Print the study as JSON (every run) instead of the report.
    #[arg(long)]
    json: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

#[derive(Args)]
struct SpreadArgs {
    #[command(flatten)]
    scenario: ScenarioArgs,
    /// Chainages of the poses, metres (the drive's lateral offset, heading along the centre
    /// line); e.g. `--at 30 50 70`.
    #[arg(long, num_args = 1.., required = true)]
    at: Vec<f64>,
    /// Scans per pose, each with fresh range noise.
    #[arg(long, default_value_t = 30)]
    draws: u32,
    /// Seed of the scanner's noise (the scenario's --seed draws the walls).
    #[arg(long, default_value_t = 1)]
    noise_seed: u64,
    /// Scan smooth walls (the map's) with the localiser's roughness model kept: the
    /// estimator's own noise propagation, without the rough walls in its decisions.
    #[arg(long)]
    smooth_walls: bool,
    /// Print the study as JSON instead of the table.
    #[arg(long)]
    json: bool,
}

#[derive(Clone, Copy, ValueEnum)]
enum DialectArg {
    /// CoLa-B (binary).
    B,
    /// CoLa-A (ASCII).
    A,
}

#[derive(Args)]
struct HilArgs {
    #[command(flatten)]
    scenario: ScenarioArgs,
    /// The dialect the emulated LMS511 speaks (the controller probes CoLa-B, then CoLa-A).
    #[arg(long, value_enum, default_value = "b")]
    dialect: DialectArg,
    /// The controller ELF (default: the firmware workspace's release build; build it with
    /// `cd firmware && cargo build --release --bin controller`).
    #[arg(long)]
    elf: Option<PathBuf>,
    /// Directory for the recording fed to the firmware, the flashed files, its estimates and
    /// its defmt log (default: a temporary directory, removed afterwards).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Longest wait for one pose frame, seconds.
    #[arg(long, default_value_t = 60.0)]
    timeout_s: f64,
    /// Run QEMU without `-icount` (its virtual clock follows the host's): the per-scan work
    /// is then not instructions, and `instructions_per_scan_*` are left out.
    #[arg(long)]
    no_icount: bool,
    /// When the controller restarts (a watchdog reset), the vehicle drives on for this many
    /// seconds before the controller takes scans again (watchdog time-out, boot, scanner
    /// start-up); those scans are lost.
    #[arg(long, default_value_t = 1.5)]
    restart_outage_s: f64,
    /// Print the metrics as one JSON object (run's keys) instead of the report.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct ReplayArgs {
    /// Recording directory (files by their standard names; see its README.txt).
    dir: PathBuf,
    /// Scanner recording instead of DIR/scanner.colab.bin: raw CoLa bytes, pcapng, pcap or .pcapng.json.
    #[arg(long)]
    scanner: Option<PathBuf>,
    /// Scan times CSV (index,t_s) instead of DIR/scanner.colab.times.csv.
    #[arg(long)]
    scanner_times: Option<PathBuf>,
    /// Odometry CSV instead of DIR/odometry.csv.
    #[arg(long)]
    odometry: Option<PathBuf>,
    /// loc-core map file instead of DIR/map.postcard.
    #[arg(long)]
    map: Option<PathBuf>,
    /// Scenario TOML instead of DIR/scenario.toml (sensor mounting, localiser settings, tunnel).
    #[arg(long)]
    scenario: Option<PathBuf>,
    /// Ground-truth CSV instead of DIR/ground_truth.csv.
    #[arg(long)]
    truth: Option<PathBuf>,
    /// Initial pose CSV instead of DIR/initial_pose.csv.
    #[arg(long)]
    initial_pose: Option<PathBuf>,
    /// Estimator to replay.
    #[arg(long, value_enum, default_value = "localizer")]
    estimator: EstimatorArg,
    /// Score another localiser's poses instead of running --estimator: a CSV with t_s,
    /// est_x_m, est_y_m, est_theta_rad (world frame, one row per scan at its time) and
    /// optionally sigma_x_m, sigma_y_m, sigma_theta_rad and update_us.
    #[arg(long)]
    estimates: Option<PathBuf>,
    /// Also compute each scan's Cramér–Rao bound at the true pose and report it beside the
    /// error (needs ground truth; `cramer_rao` in --json).
    #[arg(long)]
    bound: bool,
    /// Directory for estimates.csv and, with ground truth, trajectories.csv, metrics.json, plots and run.mcap.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the metrics as one JSON object instead of the report.
    #[arg(long)]
    json: bool,
    /// Which echo of each beam the localiser takes (default: the scenario's
    /// `localizer.echo`, last unless it says otherwise).
    #[arg(long, value_enum)]
    echo: Option<EchoArg>,
}

#[derive(Clone, Copy, ValueEnum)]
enum ObjectiveArg {
    Simulation,
    Fisher,
}

#[derive(Args)]
struct OptimizeArgs {
    /// Scenario file (TOML) to evaluate in (default: --scenario paper-10m).
    #[arg(conflicts_with = "resume")]
    file: Option<PathBuf>,
    /// Named scenario: paper-10m, tunnel-1km, demo-200m.
    #[arg(long, conflicts_with = "file")]
    scenario: Option<String>,
    /// Landmark model whose genes are searched: p1, p2, p3, p4, f1, f2, f3, f4.
    #[arg(long, required_unless_present = "resume")]
    model: Option<String>,
    /// Scan matcher of the evaluations.
    #[arg(long, conflicts_with = "resume", value_enum)]
    matcher: Option<MatcherArg>,
    /// Drive only this many metres of the scenario.
    #[arg(long, conflicts_with = "resume")]
    length: Option<f64>,
    /// Individuals per generation (the paper: 100).
    #[arg(long, conflicts_with = "resume", default_value_t = 100)]
    population: usize,
    /// Generations at most (the paper: 100).
    #[arg(long, conflicts_with = "resume", default_value_t = 100)]
    generations: usize,
    /// Generations the stopping rule averages the relative decrease of the best fitness over.
    #[arg(long, conflicts_with = "resume", default_value_t = 10)]
    stall_generations: usize,
    /// Stop when that average falls below this (the paper: 0.001 = 0.1 %).
    #[arg(long, conflicts_with = "resume", default_value_t = 0.001)]
    tolerance: f64,
    /// Seed of the GA's draws and of every evaluation.
    #[arg(long, conflicts_with = "resume", default_value_t = 1)]
    seed: u64,
    /// Fresh seeds the best genome (and generation 1's median) is validated on at the end
    /// (at least 2).
    #[arg(long, conflicts_with = "resume", default_value_t = 15)]
    validation_seeds: usize,
    /// What the GA minimises: the simulated runs' MSE (the paper's) or the deterministic
    /// worst-case along-tunnel Cramér–Rao variance of one scan.
    #[arg(
        long,
        conflicts_with = "resume",
        value_enum,
        default_value = "simulation"
    )]
    objective: ObjectiveArg,
    /// Simulated runs averaged in each fitness (1: the paper's; 3 penalises designs that
    /// fail on some seeds, at three times the cost).
    #[arg(long, conflicts_with = "resume", default_value_t = 1)]
    runs_per_evaluation: usize,
    /// Directory of a new search (generations, evaluations, figures, report.html).
    #[arg(long, conflicts_with = "resume", required_unless_present = "resume")]
    out: Option<PathBuf>,
    /// Continue the search in this directory (after Ctrl-C, or a cluster step).
    #[arg(long)]
    resume: Option<PathBuf>,
    /// Cluster: advance with the evaluations already made and write the next generation's
    /// missing ones to DIR/pending.csv, instead of evaluating here.
    #[arg(long, conflicts_with_all = ["shard", "merge"])]
    pending_only: bool,
    /// Cluster: evaluate shard I of N of DIR/pending.csv (`I/N`); with --shard-count N alone,
    /// I is $SLURM_ARRAY_TASK_ID.
    #[arg(long, requires = "resume", conflicts_with = "merge")]
    shard: Option<String>,
    /// Cluster: the shard count N when the index comes from $SLURM_ARRAY_TASK_ID.
    #[arg(long, requires = "resume", conflicts_with = "shard")]
    shard_count: Option<usize>,
    /// Cluster: merge DIR/shards/*.csv into the search's evaluations.
    #[arg(long, requires = "resume")]
    merge: bool,
    /// Print the result as one JSON object.
    #[arg(long)]
    json: bool,
    /// No progress output.
    #[arg(long)]
    quiet: bool,
}

#[derive(Args)]
struct Table2Args {
    /// Scenario file (TOML) to evaluate in (default: --scenario paper-10m).
    file: Option<PathBuf>,
    /// Named scenario: paper-10m, tunnel-1km, demo-200m.
    #[arg(long, conflicts_with = "file")]
    scenario: Option<String>,
    /// A small budget (10 individuals, 3 generations, 4 m, 3 validation runs): checks that
    /// the table is produced; its numbers are not results.
    #[arg(long)]
    quick: bool,
    /// Seed of every search.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Simulated runs averaged in each fitness (the paper: 1).
    #[arg(long, default_value_t = 1)]
    runs_per_evaluation: usize,
    /// Directory of the sixteen searches, table2.md and table2.json; running the command
    /// again continues the searches not finished.
    #[arg(long)]
    out: PathBuf,
    /// Print the rows as JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct CompareArgs {
    /// Landmark model: p1, p2, p3, p4, f1, f2, f3, f4.
    #[arg(long, default_value = "p1")]
    model: String,
    /// Named scenario (default paper-10m).
    #[arg(long, default_value = "paper-10m")]
    scenario: String,
    /// Seed of the searches and of CMA-ES.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Evaluations CMA-ES may make.
    #[arg(long, default_value_t = 3000)]
    cmaes_evaluations: usize,
    /// Directory of the two GA searches, comparison.md and comparison.json.
    #[arg(long)]
    out: PathBuf,
    /// Print the comparison as JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct DesignArgs {
    /// Scenario file (TOML) with the tunnel (default: --scenario tunnel-1km).
    file: Option<PathBuf>,
    /// Named scenario: paper-10m, tunnel-1km, demo-200m.
    #[arg(long, conflicts_with_all = ["file", "centerline"])]
    scenario: Option<String>,
    /// A surveyed centre line instead: CSV of x,y in metres (with --width).
    #[arg(long, conflicts_with = "file")]
    centerline: Option<PathBuf>,
    /// Tunnel width for --centerline, metres.
    #[arg(long, default_value_t = 5.0)]
    width: f64,
    /// Landmark model: p1…f4 (default: the search's with --from-search).
    #[arg(long)]
    model: Option<String>,
    /// Genes W,H,D[,h1..h6] (default: the paper's optimum of the model).
    #[arg(long, allow_hyphen_values = true, conflicts_with = "from_search")]
    genes: Option<String>,
    /// Take the model and genes from a finished `optimize` search directory.
    #[arg(long)]
    from_search: Option<PathBuf>,
    /// Target 1σ along-tunnel accuracy of one scan, millimetres.
    #[arg(long, default_value_t = 10.0)]
    target_mm: f64,
    /// Consecutive spacings that must identify every position.
    #[arg(long, default_value_t = 3)]
    window: usize,
    /// Spacings closer than this cannot be told apart, millimetres.
    #[arg(long, default_value_t = 50.0)]
    spacing_tolerance_mm: f64,
    /// Height of the lidar's scan plane above the floor, where landmarks are mounted, metres.
    #[arg(long, default_value_t = 1.2)]
    mounting_height: f64,
    /// Vertical extent of each landmark, metres (for the sheet area).
    #[arg(long, default_value_t = 0.3)]
    depth: f64,
    /// Chainage step of the predicted accuracy, metres.
    #[arg(long, default_value_t = 1.0)]
    step: f64,
    /// Seed of the spacing draw.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Clone, Copy, ValueEnum)]
enum MapFormat {
    /// The map file (`LCMP`): compact, what `replay --map` and `run --map` read.
    Postcard,
    /// Every wall vertex and landmark polyline, for other tools.
    Json,
    /// The flash image (`LCMI`) the controller queries in place, to be flashed at the start
    /// of the board's map region.
    Image,
}

#[derive(Args)]
struct ExportArgs {
    #[command(flatten)]
    scenario: ScenarioArgs,
    /// Output format.
    #[arg(long, value_enum, default_value = "postcard")]
    format: MapFormat,
    /// Output file (default: stdout for JSON, map.postcard for postcard).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Also write the start-pose record the controller reads beside the map (loc-core's
    /// `StartPose`, 32 bytes): the scenario's drive start, or --start-pose.
    #[arg(long)]
    start_pose_out: Option<PathBuf>,
    /// The start pose to write, `X,Y,THETA[,SIGMA_M,SIGMA_RAD]` (world frame, metres and
    /// radians; σ default: the scenario's initial σ).
    #[arg(long, value_delimiter = ',', requires = "start_pose_out")]
    start_pose: Option<Vec<f64>>,
    /// The true as-built map instead of the design: walls as built (a vertex every metre),
    /// landmarks where they were installed, missing ones left out (simulation only: the
    /// yardstick of `host-sim survey`).
    #[arg(long)]
    as_built: bool,
    /// Convert this map file (`LCMP`, e.g. a survey's `survey.postcard`) instead of
    /// building the scenario's map.
    #[arg(long, conflicts_with = "as_built")]
    map: Option<PathBuf>,
    /// Also write the localiser's configuration record the controller reads from its map
    /// flash region (loc-core's `LocalizerConfig`, `LCCF`): the scenario's sensor layout and
    /// mounting, matcher, range noise, wall roughness and odometry noise, and the sweep's
    /// de-skew on (a vehicle's scanner sweeps, whether the scenario simulates it or not).
    #[arg(long)]
    config_out: Option<PathBuf>,
}

impl ScenarioArgs {
    /// A scenario file or name (`default_name` when neither is given) without overrides.
    fn base(file: &Option<PathBuf>, scenario: &Option<String>, default_name: &str) -> Self {
        Self {
            file: file.clone(),
            scenario: match (file, scenario) {
                (None, None) => Some(default_name.to_string()),
                (_, s) => s.clone(),
            },
            landmarks: None,
            genes: None,
            matcher: None,
            seed: None,
            missing_every: None,
            missing_fraction: None,
            damage_fraction: None,
            install_sd: None,
            move_landmark: Vec::new(),
            moved_fraction: None,
            gyro: false,
            missing_stretch: None,
            length: None,
            speed: None,
            rate: None,
            sweep: false,
            dust: None,
            people: None,
            vehicles: None,
            echo: None,
        }
    }
}

fn load_scenario(a: &ScenarioArgs) -> Result<Scenario, String> {
    let mut s = match (&a.file, &a.scenario) {
        (Some(f), _) => Scenario::from_file(f).map_err(|e| e.to_string())?,
        (None, Some(n)) => named(n).map_err(|e| e.to_string())?,
        (None, None) => {
            return Err(format!(
                "give a scenario file or --scenario NAME ({})",
                NAMES.join(", ")
            ))
        }
    };
    let o = Overrides {
        landmarks: a.landmarks.clone(),
        genes: a.genes.clone(),
        matcher: a.matcher.map(|m| match m {
            MatcherArg::Hausdorff => MatcherChoice::Hausdorff,
            MatcherArg::Icp => MatcherChoice::Icp,
        }),
        seed: a.seed,
        missing_every: a.missing_every,
        missing_fraction: a.missing_fraction,
        damage_fraction: a.damage_fraction,
        install_sd_m: a.install_sd,
        moved_fraction: a.moved_fraction,
        gyro: a.gyro,
        sweep: a.sweep,
        moved: a
            .move_landmark
            .iter()
            .map(|t| parse_moved(t))
            .collect::<Result<_, _>>()?,
        missing_stretch_m: a
            .missing_stretch
            .as_deref()
            .map(parse_stretch)
            .transpose()?,
        drive_length_m: a.length,
        speed_mps: a.speed,
        rate: a.rate.map(|r| match r {
            RateArg::Hz25 => ScanRate::Hz25,
            RateArg::Hz35 => ScanRate::Hz35,
            RateArg::Hz50 => ScanRate::Hz50,
            RateArg::Hz75 => ScanRate::Hz75,
            RateArg::Hz100 => ScanRate::Hz100,
        }),
        range_noise_m: None,
        dust_fraction: a.dust,
        people: a.people,
        vehicles: a.vehicles,
        echo: a.echo.map(EchoArg::choice),
    };
    o.apply(&mut s).map_err(|e| e.to_string())?;
    Ok(s)
}

/// A progress bar on stderr, shown only when the run lasts more than a moment.
fn progress_bar(label: &str, enabled: bool) -> Option<ProgressBar> {
    if !enabled {
        return None;
    }
    let bar = ProgressBar::new(1000);
    bar.set_style(
        ProgressStyle::with_template("{msg:>14} [{bar:40}] {percent:>3}% {elapsed}/{eta} left")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_message(label.to_string());
    // Hidden for the first seconds: short runs never show a bar.
    bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    Some(bar)
}

/// `FROM_M,TO_M` of `--missing-stretch`.
fn parse_stretch(text: &str) -> Result<[f64; 2], String> {
    let bad = || format!("--missing-stretch {text}: expected FROM_M,TO_M (e.g. 80,120)");
    let (a, b) = text.split_once(',').ok_or_else(bad)?;
    Ok([
        a.trim().parse().map_err(|_| bad())?,
        b.trim().parse().map_err(|_| bad())?,
    ])
}

/// `INDEX,ALONG_M` of `--move-landmark`.
fn parse_moved(text: &str) -> Result<host_sim::scenario::MovedLandmark, String> {
    let bad = || format!("--move-landmark {text}: expected INDEX,ALONG_M (e.g. 20,0.08)");
    let (i, d) = text.split_once(',').ok_or_else(bad)?;
    Ok(host_sim::scenario::MovedLandmark {
        index: i.trim().parse().map_err(|_| bad())?,
        along_m: d.trim().parse().map_err(|_| bad())?,
    })
}

fn run_with_progress(
    s: &Scenario,
    est: EstimatorChoice,
    label: &str,
    show: bool,
    keep_scans: bool,
) -> Result<RunLog, String> {
    run_with_progress_on(s, est, None, label, show, keep_scans, &Faults::default())
}

/// Faults injected into a run (`run --kidnap`, `--blind`).
#[derive(Default)]
struct Faults {
    teleports: Vec<host_sim::closed_loop::Teleport>,
    blind: Vec<host_sim::closed_loop::Blind>,
}

impl Faults {
    fn parse(kidnap: &[String], blind: &[String]) -> Result<Self, String> {
        let pair = |flag: &str, what: &str, text: &str| -> Result<(f64, f64), String> {
            let bad = || format!("{flag} {text}: expected {what} (e.g. 100,25)");
            let (a, b) = text.split_once(',').ok_or_else(bad)?;
            let a: f64 = a.trim().parse().map_err(|_| bad())?;
            let b: f64 = b.trim().parse().map_err(|_| bad())?;
            if !(a.is_finite() && b.is_finite() && a >= 0.0) {
                return Err(bad());
            }
            Ok((a, b))
        };
        let mut teleports = kidnap
            .iter()
            .map(|k| {
                pair("--kidnap", "AT_M,JUMP_M", k).map(|(at_distance_m, jump_m)| {
                    host_sim::closed_loop::Teleport {
                        at_distance_m,
                        jump_m,
                    }
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        teleports.sort_by(|a, b| a.at_distance_m.total_cmp(&b.at_distance_m));
        let blind = blind
            .iter()
            .map(|b| {
                let (from_m, seconds) = pair("--blind", "FROM_M,SECONDS", b)?;
                if seconds <= 0.0 {
                    return Err(format!("--blind {b}: SECONDS must be positive"));
                }
                Ok(host_sim::closed_loop::Blind { from_m, seconds })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self { teleports, blind })
    }
}

/// [`run_with_progress`], against `map` instead of the design's when given.
fn run_with_progress_on(
    s: &Scenario,
    est: EstimatorChoice,
    map: Option<&loc_core::map::TunnelMap>,
    label: &str,
    show: bool,
    keep_scans: bool,
    faults: &Faults,
) -> Result<RunLog, String> {
    let bar = progress_bar(label, show);
    let started = std::time::Instant::now();
    let shown = std::cell::Cell::new(false);
    let cb = |f: f64| {
        if let Some(b) = &bar {
            if !shown.get() && started.elapsed() > Duration::from_secs(2) {
                b.set_draw_target(indicatif::ProgressDrawTarget::stderr());
                shown.set(true);
            }
            b.set_position((f * 1000.0) as u64);
        }
    };
    let options = RunOptions {
        keep_scans,
        progress: Some(&cb),
        teleports: &faults.teleports,
        blind: &faults.blind,
    };
    let log = match map {
        Some(map) => host_sim::session::run_scenario_with_map(s, map, &options),
        None => run_scenario(s, est, &options),
    }
    .map_err(|e| e.to_string());
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    log
}

fn cmd_run(a: &RunArgs) -> Result<(), String> {
    check_output_dir("--out", a.out.as_deref())?;
    check_output_dir("--record", a.record.as_deref())?;
    let s = load_scenario(&a.scenario)?;
    let est = match a.estimator {
        EstimatorArg::Localizer => EstimatorChoice::Localizer,
        EstimatorArg::Odometry => EstimatorChoice::OdometryOnly,
    };
    // Recordings, scans in run.mcap: the run keeps its scans (about 2.3 kB each).
    let keep = a.out.is_some() || a.record.is_some();
    let map = match &a.map {
        Some(path) => {
            if est != EstimatorChoice::Localizer {
                return Err("--map needs the localizer estimator (odometry uses no map)".into());
            }
            Some(host_sim::replay::read_map(path).map_err(|e| e.to_string())?)
        }
        None => None,
    };
    let faults = Faults::parse(&a.kidnap, &a.blind)?;
    let log = run_with_progress_on(&s, est, map.as_deref(), &s.name, !a.quiet, keep, &faults)?;
    let m = log.metrics();
    if a.json {
        out(&MetricsJson::new(&log, &m).to_json())?;
    } else {
        out(&report::run_report(&log, &m))?;
    }
    if let Some(dir) = &a.out {
        let mut files = output::write_run(dir, "", &log, &m).map_err(|e| e.to_string())?;
        let (map, _) = record::scenario_map(&s).map_err(|e| e.to_string())?;
        files.extend(visuals::write_visuals(dir, &log, &map)?);
        if !a.json {
            for f in files {
                out(&format!("wrote {}", f.display()))?;
            }
        }
    }
    if let Some(dir) = &a.record {
        let (_, map_file) = record::scenario_map(&s).map_err(|e| e.to_string())?;
        let as_built = record::scenario_as_built_map(&s).map_err(|e| e.to_string())?;
        let files = record::write_recording(dir, &log, &map_file, Some(&as_built))
            .map_err(|e| e.to_string())?;
        if !a.json {
            out(&format!(
                "recorded {} scans, {} odometry readings into {} ({} files; replay with `host-sim replay {}`)",
                log.scans.len(),
                log.odometry.len(),
                dir.display(),
                files.len(),
                dir.display()
            ))?;
        }
    }
    Ok(())
}

fn cmd_spread(a: &SpreadArgs) -> Result<(), String> {
    use host_sim::noise_spread::{run_spread, SpreadSpec};
    let s = load_scenario(&a.scenario)?;
    if a.draws < 2 {
        return Err("--draws must be at least 2 (a spread needs two scans)".into());
    }
    if let Some(bad) = a.at.iter().find(|c| !c.is_finite()) {
        return Err(format!("--at {bad}: chainages must be finite metres"));
    }
    let spec = SpreadSpec {
        chainages_m: a.at.clone(),
        draws: a.draws,
        seed: a.noise_seed,
        smooth_walls: a.smooth_walls,
    };
    let study = run_spread(&s, &spec).map_err(|e| e.to_string())?;
    if a.json {
        out(&serde_json::to_string_pretty(&study).map_err(|e| e.to_string())?)
    } else {
        out(&study.report())
    }
}

fn cmd_relocalise(a: &RelocaliseArgs) -> Result<(), String> {
    use host_sim::relocalise_study::{run_study, StudySpec};
    let s = load_scenario(&a.scenario)?;
    let bad = || format!("--jump {}: expected MIN,MAX in metres (e.g. 5,50)", a.jump);
    let (lo, hi) = a.jump.split_once(',').ok_or_else(bad)?;
    let jump_range_m: (f64, f64) = (
        lo.trim().parse().map_err(|_| bad())?,
        hi.trim().parse().map_err(|_| bad())?,
    );
    if !(jump_range_m.0 > 0.0 && jump_range_m.1 >= jump_range_m.0) {
        return Err(bad());
    }
    if !(a.drive > 0.0 && a.kidnap_after >= 0.0) || a.runs == 0 {
        return Err("--runs, --drive must be positive and --kidnap-after not negative".into());
    }
    let spec = StudySpec {
        runs: a.runs,
        drive_m: a.drive,
        kidnap: a.kidnap,
        kidnap_after_m: a.kidnap_after,
        jump_range_m,
        seed: a.study_seed,
    };
    let bar = progress_bar("relocalise", !a.quiet);
    if let Some(b) = &bar {
        b.set_draw_target(indicatif::ProgressDrawTarget::stderr());
    }
    let cb = |f: f64| {
        if let Some(b) = &bar {
            b.set_position((f * 1000.0) as u64);
        }
    };
    let result = run_study(&s, &spec, Some(&cb)).map_err(|e| e.to_string());
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let result = result?;
    if a.json {
        out(&serde_json::to_string_pretty(&result).map_err(|e| e.to_string())?)
    } else {
        out(&result.report())
    }
}

fn cmd_hil(a: &HilArgs) -> Result<(), String> {
    check_output_dir("--out", a.out.as_deref())?;
    let s = load_scenario(&a.scenario)?;
    // Without --out, a folder of its own under the system's temporary directory, removed
    // afterwards.
    let (dir, remove) = match &a.out {
        Some(d) => (d.clone(), false),
        None => (
            std::env::temp_dir().join(format!("host-sim-hil-{}", std::process::id())),
            true,
        ),
    };
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let options = host_sim::hil::HilOptions {
        elf: a.elf.clone().unwrap_or_else(host_sim::hil::default_elf),
        dialect: match a.dialect {
            DialectArg::A => lms5xx_emulator::DialectMode::Only(lidar_driver::Dialect::ColaA),
            DialectArg::B => lms5xx_emulator::DialectMode::Only(lidar_driver::Dialect::ColaB),
        },
        timeout: Duration::from_secs_f64(a.timeout_s.max(1.0)),
        icount: !a.no_icount,
        restart_outage_s: a.restart_outage_s,
    };
    let r = host_sim::hil::run(&s, &options, &dir).map_err(|e| e.to_string());
    if remove {
        let _ = std::fs::remove_dir_all(&dir);
    }
    let r = r?;
    let m = r.replay.log.metrics();
    let run_m = r.run.metrics();
    let ((work_mean, work_max), stage_work) = r.work_summary();
    if a.json {
        let mut j: serde_json::Value =
            serde_json::from_str(&MetricsJson::new(&r.replay.log, &m).to_json())
                .map_err(|e| e.to_string())?;
        if let (Some(o), false) = (j.as_object_mut(), a.no_icount) {
            o.insert(
                "instructions_per_scan_mean".into(),
                work_mean.round().into(),
            );
            o.insert("instructions_per_scan_max".into(), work_max.into());
            let stages: serde_json::Map<String, serde_json::Value> = controller_wire::STAGE_NAMES
                .iter()
                .zip(stage_work)
                .map(|(name, (mean, max))| {
                    (
                        (*name).to_string(),
                        serde_json::json!({ "mean": mean.round(), "max": max }),
                    )
                })
                .collect();
            o.insert("instructions_per_stage".into(), stages.into());
        }
        if let Some(o) = j.as_object_mut() {
            o.insert("restarts".into(), serde_json::json!(r.restarts));
        }
        out(&j.to_string())?;
    } else {
        if !a.no_icount {
            out(&format!(
                "instructions per scan (controller end to end, QEMU -icount): mean {work_mean:.0}, max {work_max}"
            ))?;
            for (name, (mean, max)) in controller_wire::STAGE_NAMES.iter().zip(stage_work) {
                out(&format!("  {name:<6} mean {mean:>9.0}, max {max:>9}"))?;
            }
        }
        let tracking = r
            .statuses
            .iter()
            .filter(|s| **s == controller_wire::PoseStatus::Tracking)
            .count();
        out(&format!(
            "firmware in the loop ({} scans, {} tracking, {} predicted with the vehicle's odometry): position RMS {:.2} mm, heading RMS {:.3} mrad, max {:.1} mm
host-sim run of the same drive: position RMS {:.2} mm, heading RMS {:.3} mrad, max {:.1} mm",
            r.statuses.len(),
            tracking,
            r.with_odometry,
            m.localizer.position_rms_m * 1e3,
            m.localizer.heading_rms_rad * 1e3,
            m.localizer.max_position_error_m * 1e3,
            run_m.localizer.position_rms_m * 1e3,
            run_m.localizer.heading_rms_rad * 1e3,
            run_m.localizer.max_position_error_m * 1e3,
        ))?;
        for restart in &r.restarts {
            out(&format!(
                "controller restarted at scan {}: {} scans lost to the outage; tracking again {}",
                restart.first_lost_scan,
                restart.lost_scans,
                restart
                    .scans_to_tracking
                    .map_or("not within the run".into(), |n| {
                        format!("within {n} scans after the outage")
                    })
            ))?;
        }
    }
    Ok(())
}

fn cmd_replay(a: &ReplayArgs) -> Result<(), String> {
    check_output_dir("--out", a.out.as_deref())?;
    let mut src = match ReplaySources::in_dir(&a.dir) {
        Ok(s) => s,
        // Every file given by flag: the directory only collects outputs.
        Err(_)
            if a.scanner.is_some()
                && a.odometry.is_some()
                && a.map.is_some()
                && a.scenario.is_some() =>
        {
            ReplaySources {
                scanner: PathBuf::new(),
                scanner_times: None,
                odometry: PathBuf::new(),
                map: PathBuf::new(),
                scenario: PathBuf::new(),
                initial_pose: None,
                ground_truth: None,
            }
        }
        Err(e) => return Err(e.to_string()),
    };
    let set = |slot: &mut PathBuf, v: &Option<PathBuf>| {
        if let Some(p) = v {
            *slot = p.clone();
        }
    };
    set(&mut src.scanner, &a.scanner);
    set(&mut src.odometry, &a.odometry);
    set(&mut src.map, &a.map);
    set(&mut src.scenario, &a.scenario);
    if a.scanner_times.is_some() || a.scanner.is_some() {
        src.scanner_times = a.scanner_times.clone();
    }
    if a.truth.is_some() {
        src.ground_truth = a.truth.clone();
    }
    if a.initial_pose.is_some() {
        src.initial_pose = a.initial_pose.clone();
    }
    let est = match a.estimator {
        EstimatorArg::Localizer => EstimatorChoice::Localizer,
        EstimatorArg::Odometry => EstimatorChoice::OdometryOnly,
    };
    // The scans are kept only for the MCAP file of --out: without it memory does not grow
    // with the recording.
    let options = replay::ReplayOptions {
        keep_scans: a.out.is_some(),
        estimates: a.estimates.clone(),
        bound: a.bound,
        echo: a.echo.map(EchoArg::choice),
        allow_missing_estimates: false,
    };
    if a.bound && src.ground_truth.is_none() {
        return Err("--bound needs ground truth (ground_truth.csv or --truth)".into());
    }
    let rep = replay::replay_with(&src, est, &options).map_err(|e| e.to_string())?;
    for w in &rep.warnings {
        eprintln!("host-sim: warning: {w}");
    }
    let has_truth = !rep.log.samples.is_empty();
    let m = rep.log.metrics();
    if a.json {
        if has_truth {
            out(&MetricsJson::new(&rep.log, &m)
                .with_warnings(&rep.warnings)
                .with_bound(rep.bound)
                .to_json())?;
        } else {
            return Err("no ground truth to score against: --json needs ground_truth.csv".into());
        }
    } else {
        let sc = &rep.source;
        out(&format!(
            "replayed {} scans ({:?} file, times from {:?}; {} other frames, {} damaged frames, {} damaged scan telegrams dropped, {} damaged file parts read around) with {} odometry readings ({} flagged, {} left out)",
            sc.scans,
            sc.format,
            sc.time_source,
            sc.other_frames,
            sc.bad_frames,
            sc.damaged_scans,
            sc.file_damage,
            sc.odometry_readings,
            sc.odometry_findings,
            sc.odometry_left_out
        ))?;
        if has_truth {
            out(&format!(
                "{} scans scored against ground truth\n",
                sc.scored_scans
            ))?;
            out(&report::run_report(&rep.log, &m))?;
            if let Some(b) = &rep.bound {
                out(&format!(
                    "Cramér–Rao bound of each scan at the true pose ({} scans): position {:.2} mm RMS (along {:.2}, across {:.2}), heading {:.3} mrad; the localiser's error over it: position {:.2}x, along {:.2}x, across {:.2}x, heading {:.2}x",
                    b.scans,
                    b.position_rms_m * 1e3,
                    b.along_rms_m * 1e3,
                    b.across_rms_m * 1e3,
                    b.heading_rms_rad * 1e3,
                    b.position_ratio,
                    b.along_ratio,
                    b.across_ratio,
                    b.heading_ratio
                ))?;
            }
        } else if let Some(last) = rep.steps.last() {
            out(&format!(
                "no ground truth: no metrics. Last estimate at t = {:.3} s: x {:.3} m, y {:.3} m, heading {:.4} rad, status {}",
                last.t_s, last.estimate.x_m, last.estimate.y_m, last.estimate.theta_rad, last.status
            ))?;
        }
    }
    if let Some(dir) = &a.out {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        let est_path = dir.join("estimates.csv");
        let mut buf = Vec::new();
        replay::write_estimates_csv(&rep.steps, &mut buf).map_err(|e| e.to_string())?;
        write_file(&est_path, &buf)?;
        let mut files = vec![est_path];
        if has_truth {
            files.extend(output::write_run(dir, "", &rep.log, &m).map_err(|e| e.to_string())?);
            files.extend(visuals::write_visuals(dir, &rep.log, &rep.map)?);
        }
        if !a.json {
            for f in files {
                out(&format!("wrote {}", f.display()))?;
            }
        }
    }
    Ok(())
}

fn cmd_demo(seed: u64) -> Result<(), String> {
    let started = std::time::Instant::now();
    let mut base = named("demo-200m").map_err(|e| e.to_string())?;
    base.seed = seed;
    let mut bare = base.clone();
    bare.landmarks.model = "none".into();
    bare.landmarks.genes = None;
    let mut missing = base.clone();
    missing.landmarks.missing_every = Some(5);
    let with = run_with_progress(
        &base,
        EstimatorChoice::Localizer,
        "P1 landmarks",
        true,
        false,
    )?;
    let holes = run_with_progress(
        &missing,
        EstimatorChoice::Localizer,
        "1 in 5 missing",
        true,
        false,
    )?;
    let without = run_with_progress(
        &bare,
        EstimatorChoice::Localizer,
        "no landmarks",
        true,
        false,
    )?;
    let (mw, mh, mo) = (with.metrics(), holes.metrics(), without.metrics());
    out("host-sim demo — loc-core's localiser driving through a simulated mining tunnel\n")?;
    out(&format!("{}\n", report::scenario_line(&with)))?;
    let cols = [
        Column {
            heading: "P1 landmarks".into(),
            log: &with,
            metrics: &mw,
            odometry: false,
        },
        Column {
            heading: "1 in 5 missing".into(),
            log: &holes,
            metrics: &mh,
            odometry: false,
        },
        Column {
            heading: "no landmarks".into(),
            log: &without,
            metrics: &mo,
            odometry: false,
        },
        Column {
            heading: "odometry alone".into(),
            log: &with,
            metrics: &mw,
            odometry: true,
        },
    ];
    out(&report::comparison_table(&cols))?;
    out(&format!(
        "Without landmarks the walls fix the lateral position and heading; the position along the\n\
         tunnel drifts with odometry on the straight and is fixed, to decimetres, where the tunnel\n\
         starts to curve (seen from tens of metres ahead). With landmarks every {:.1} m (±0.625 m)\n\
         the error stays at the lidar's noise level for the whole drive.",
        base.landmark_choice().map(|c| c.spacing_m()).unwrap_or(0.0)
    ))?;
    out(&format!(
        "\n(demo took {:.1} s)",
        started.elapsed().as_secs_f64()
    ))?;
    Ok(())
}

/// The start-pose record `export-map --start-pose-out` writes.
fn start_pose_record(
    s: &Scenario,
    world: &host_sim::world::World,
    given: Option<&[f64]>,
) -> Result<StartPose, String> {
    let c = &s.localizer;
    let (sigma_m, sigma_rad) = (c.initial_sigma_m.max(0.01), c.initial_sigma_rad.max(0.002));
    let (x, y, th, sm, sr) = match given {
        None => {
            let p = host_sim::vehicle::path_follower::PathFollower::new(
                s.drive,
                world.centerline().length_m(),
            )
            .start_pose(world.centerline());
            (p.x_m, p.y_m, p.theta_rad, sigma_m, sigma_rad)
        }
        Some([x, y, th]) => (*x, *y, *th, sigma_m, sigma_rad),
        Some([x, y, th, sm, sr]) => (*x, *y, *th, *sm, *sr),
        Some(v) => {
            return Err(format!(
                "--start-pose takes X,Y,THETA or X,Y,THETA,SIGMA_M,SIGMA_RAD, not {} numbers",
                v.len()
            ))
        }
    };
    let start = StartPose {
        pose: loc_core::geometry::Pose2::new(x as f32, y as f32, th as f32),
        sigma_xy_m: sm as f32,
        sigma_theta_rad: sr as f32,
    };
    // What the controller would refuse is refused here.
    StartPose::from_bytes(&start.to_bytes()).map_err(|e| format!("--start-pose: {e}"))
}

fn cmd_export(a: &ExportArgs) -> Result<(), String> {
    // A map file to convert needs no scenario (unless a start pose or configuration is asked
    // for too).
    let scenario = match (&a.map, a.start_pose_out.is_some() || a.config_out.is_some()) {
        (Some(_), false) => None,
        _ => {
            let s = load_scenario(&a.scenario)?;
            let world = s.build_world().map_err(|e| e.to_string())?;
            Some((s, world))
        }
    };
    if let (Some(path), Some((s, _))) = (&a.config_out, &scenario) {
        let mut buf = vec![0u8; loc_core::localizer::CONFIG_RECORD_MAX_BYTES];
        // The record is for a vehicle, whose LMS5xx sweeps whatever the scenario simulates.
        let mut config = host_sim::estimator::localizer_config(s);
        config.deskew = true;
        let n = config.to_record(&mut buf).map_err(|e| e.to_string())?;
        write_file(path, &buf[..n])?;
        eprintln!(
            "wrote {} (configuration record, {n} bytes); flash it in the 4 KiB before the start pose",
            path.display()
        );
    }
    if let (Some(path), Some((s, world))) = (&a.start_pose_out, &scenario) {
        let start = start_pose_record(s, world, a.start_pose.as_deref())?;
        write_file(path, &start.to_bytes())?;
        eprintln!(
            "wrote {} (start pose x {:.3} m, y {:.3} m, heading {:.4} rad, sigma {:.3} m / {:.4} rad)",
            path.display(),
            start.pose.x_m,
            start.pose.y_m,
            start.pose.theta_rad,
            start.sigma_xy_m,
            start.sigma_theta_rad
        );
    }
    let map = match (&a.map, &scenario) {
        (Some(path), _) => replay::read_map(path).map_err(|e| e.to_string())?,
        (None, Some((s, world))) => {
            let choice = s.landmark_choice().map_err(|e| e.to_string())?;
            if a.as_built {
                stored_map::build_as_built(world, &choice)
            } else {
                stored_map::build(world, &choice)
            }
            .map_err(|e| e.to_string())?
        }
        (None, None) => return Err("give a scenario or --map FILE".into()),
    };
    match a.format {
        MapFormat::Image => {
            let mut bytes = vec![0u8; map.image_len()];
            let n = map.write_image(&mut bytes).map_err(|e| e.to_string())?;
            bytes.truncate(n);
            let p = a.out.clone().unwrap_or_else(|| PathBuf::from("map.image"));
            write_file(&p, &bytes)?;
            eprintln!(
                "wrote {} ({} bytes of flash: {} segments, {} landmarks, {} index cells); flash it at the start of the board's map region",
                p.display(),
                bytes.len(),
                map.segments().len(),
                map.landmarks().len(),
                map.index_stats().cells
            );
        }
        MapFormat::Json => {
            let text = map_export::to_json(&map).to_pretty();
            match &a.out {
                Some(p) => write_file(p, text.as_bytes())?,
                None => out(&text)?,
            }
        }
        MapFormat::Postcard => {
            let bytes = stored_map::to_file_bytes(&map).map_err(|e| e.to_string())?;
            let p = a
                .out
                .clone()
                .unwrap_or_else(|| PathBuf::from("map.postcard"));
            write_file(&p, &bytes)?;
            eprintln!(
                "wrote {} ({} bytes: {} segments, {} landmarks)",
                p.display(),
                bytes.len(),
                map.segments().len(),
                map.landmarks().len()
            );
        }
    }
    Ok(())
}

/// Prints a line to stdout. A closed pipe (`| head`) ends output quietly; any other
/// failure (a full disk, `> /dev/full`) is an error: output asked for and lost is not a
/// success.
/// The search directory of `optimize`: a new one from the flags, or the one to resume.
fn open_search(a: &OptimizeArgs) -> Result<(Store, SearchSpec, Scenario), String> {
    if let Some(dir) = &a.resume {
        return Store::open(dir).map_err(|e| e.to_string());
    }
    let model = a.model.as_deref().unwrap_or_default();
    let code = loc_core::landmark::LandmarkModel::from_code(model)
        .ok_or_else(|| format!("--model `{model}`: use p1, p2, p3, p4, f1, f2, f3 or f4"))?
        .code();
    let s = load_scenario(&ScenarioArgs {
        landmarks: Some(code.to_ascii_lowercase()),
        matcher: a.matcher,
        seed: Some(a.seed),
        length: a.length,
        ..ScenarioArgs::base(&a.file, &a.scenario, "paper-10m")
    })?;
    if a.population < 2 {
        return Err("--population must be at least 2".into());
    }
    if !(a.tolerance.is_finite() && a.tolerance >= 0.0) {
        return Err("--tolerance must be a number ≥ 0".into());
    }
    let spec = SearchSpec {
        model: code.to_string(),
        population: a.population,
        elite_fraction: 0.05,
        crossover_fraction: 0.75,
        max_generations: a.generations.max(1),
        stall_generations: a.stall_generations,
        tolerance: a.tolerance,
        seed: a.seed,
        validation_seeds: a.validation_seeds.max(2),
        runs_per_evaluation: a.runs_per_evaluation.max(1),
        objective: match a.objective {
            ObjectiveArg::Simulation => ObjectiveKind::Simulation,
            ObjectiveArg::Fisher => ObjectiveKind::Fisher,
        },
    };
    let dir = a.out.as_deref().ok_or("give --out DIR (or --resume DIR)")?;
    Store::create(dir, &spec, &s).map_err(|e| e.to_string())?;
    // Every session reads the scenario back from the directory: the same values to the bit.
    Store::open(dir).map_err(|e| e.to_string())
}

/// The shard of this task: --shard I/N, or $SLURM_ARRAY_TASK_ID of --shard-count N.
fn shard_of(a: &OptimizeArgs) -> Result<Option<Shard>, String> {
    match (&a.shard, a.shard_count) {
        (Some(s), _) => Shard::parse(s).map(Some),
        (None, Some(n)) => {
            let id = std::env::var("SLURM_ARRAY_TASK_ID")
                .map_err(|_| "--shard-count needs $SLURM_ARRAY_TASK_ID (run it as a Slurm array task) or use --shard I/N".to_string())?;
            Shard::parse(&format!("{id}/{n}")).map(Some)
        }
        (None, None) => Ok(None),
    }
}

fn cmd_optimize(a: &OptimizeArgs) -> Result<(), String> {
    use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};
    static INTERRUPT: AtomicBool = AtomicBool::new(false);
    static PRESSES: AtomicU8 = AtomicU8::new(0);
    let (store, spec, scenario) = open_search(a)?;
    let obj = search::objective(&spec, &scenario)?;
    let dir = store.dir.display().to_string();
    // Ctrl-C: finish the running evaluations, keep everything; a second one quits at once.
    let _ = ctrlc::set_handler(move || {
        if PRESSES.fetch_add(1, Ordering::SeqCst) > 0 {
            std::process::exit(130);
        }
        INTERRUPT.store(true, Ordering::SeqCst);
        eprintln!("\nstopping after the running evaluations (Ctrl-C again to quit now)");
    });
    if a.merge {
        let n = store.merge_shards(obj.space()).map_err(|e| e.to_string())?;
        return out(&format!(
            "merged {n} evaluations into {dir}/evaluations.csv"
        ));
    }
    if let Some(shard) = shard_of(a)? {
        let n = search::run_shard(&store, &spec, &obj, shard, &INTERRUPT)?;
        return out(&format!(
            "shard {}/{}: {n} evaluations in {}",
            shard.index,
            shard.count,
            store.shard_path(shard).display()
        ));
    }
    let show = !a.quiet && !a.json;
    let bar = show.then(|| {
        let b = ProgressBar::new(1);
        b.set_style(
            ProgressStyle::with_template(
                "{msg:>14} [{bar:40}] {pos}/{len} runs {elapsed} ({eta} left)",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
        );
        b
    });
    let progress = |generation: usize, done: usize, total: usize| {
        if let Some(b) = &bar {
            b.set_message(format!("generation {}", generation + 1));
            b.set_length(total as u64);
            b.set_position(done as u64);
        }
    };
    let evaluator = if a.pending_only {
        search::Evaluator::CachedOnly
    } else {
        search::Evaluator::Local {
            interrupt: &INTERRUPT,
            progress: &progress,
        }
    };
    let space = obj.space().clone();
    let mut line = |r: &GenerationRow| {
        if let Some(b) = &bar {
            let genes: Vec<String> = r
                .best
                .iter()
                .enumerate()
                .map(|(i, v)| format!("{}={v:.3}", space.name(i)))
                .collect();
            b.println(format!(
                "generation {:>3}: best RMS {:.2} mm, median {:.2} mm, {} new runs; best {}",
                r.index + 1,
                r.best_fitness.sqrt() * 1e3,
                r.median_fitness.sqrt() * 1e3,
                r.new_evaluations,
                genes.join(" ")
            ));
        }
    };
    let state = search::run(&store, &spec, &obj, evaluator, &mut line)?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    match &state.outcome {
        Outcome::Halted(Halt::Interrupted) => Err(format!(
            "interrupted after {} generations and {} evaluations, all kept: continue with `host-sim optimize --resume {dir}`",
            state.generations.len(),
            state.evaluations
        )),
        Outcome::Halted(Halt::Failed(e)) => Err(format!("the search stopped: {e}")),
        Outcome::Halted(Halt::Pending(p)) => {
            if a.json {
                out(&format!("{{\"pending\":{},\"generation\":{}}}", p.len(), state.generations.len() + 1))
            } else {
                out(&format!(
                    "generation {}: {} evaluations pending in {dir}/pending.csv",
                    state.generations.len() + 1,
                    p.len()
                ))
            }
        }
        Outcome::Finished(reason) => {
            if show {
                eprintln!(
                    "validating the best genome on {} fresh seeds",
                    spec.validation_seeds
                );
            }
            let summary = optimize::finish(&store, &spec, &obj, &state, *reason)?;
            if a.json {
                out(&serde_json::to_string(&summary).map_err(|e| e.to_string())?)
            } else {
                out(&optimize_report(&summary))
            }
        }
    }
}

fn cmd_table2(a: &Table2Args) -> Result<(), String> {
    use optimize::table2::{self, Budget};
    use std::sync::atomic::{AtomicBool, Ordering};
    static INTERRUPT: AtomicBool = AtomicBool::new(false);
    let base = load_scenario(&ScenarioArgs {
        seed: Some(a.seed),
        ..ScenarioArgs::base(&a.file, &a.scenario, "paper-10m")
    })?;
    let _ = ctrlc::set_handler(|| {
        INTERRUPT.store(true, Ordering::SeqCst);
        eprintln!("\nstopping after the running evaluations; run the same command to continue");
    });
    let budget = if a.quick {
        Budget::QUICK
    } else {
        Budget::PAPER
    };
    let quiet = a.json;
    let rows = table2::run(&base, budget, a.seed, &a.out, &INTERRUPT, &mut |line| {
        if !quiet {
            eprintln!("{line}");
        }
    })?;
    let files = table2::write(&a.out, &rows)?;
    if a.json {
        out(&serde_json::to_string(&rows).map_err(|e| e.to_string())?)
    } else {
        out(&table2::markdown(&rows))?;
        for f in files {
            out(&format!("wrote {}", f.display()))?;
        }
        Ok(())
    }
}

fn cmd_compare(a: &CompareArgs) -> Result<(), String> {
    use optimize::comparison;
    use std::sync::atomic::{AtomicBool, Ordering};
    static INTERRUPT: AtomicBool = AtomicBool::new(false);
    let model = loc_core::landmark::LandmarkModel::from_code(&a.model).ok_or_else(|| {
        format!(
            "--model `{}`: use p1, p2, p3, p4, f1, f2, f3 or f4",
            a.model
        )
    })?;
    let scenario = named(&a.scenario).map_err(|e| e.to_string())?;
    let _ = ctrlc::set_handler(|| {
        INTERRUPT.store(true, Ordering::SeqCst);
        eprintln!("\nstopping after the running evaluations; run the same command to continue");
    });
    let quiet = a.json;
    let c = comparison::run(
        &scenario,
        model,
        a.seed,
        a.cmaes_evaluations,
        &a.out,
        &INTERRUPT,
        &mut |line| {
            if !quiet {
                eprintln!("{line}");
            }
        },
    )?;
    let md = a.out.join("comparison.md");
    write_file(&md, comparison::markdown(&c).as_bytes())?;
    let json = serde_json::to_string_pretty(&c).map_err(|e| e.to_string())?;
    write_file(&a.out.join("comparison.json"), json.as_bytes())?;
    if a.json {
        out(&json)
    } else {
        out(&comparison::markdown(&c))
    }
}

fn cmd_design(a: &DesignArgs) -> Result<(), String> {
    check_output_dir("--out", Some(&a.out))?;
    let mut scenario = match (&a.centerline, &a.file, &a.scenario) {
        (Some(csv), _, _) => {
            let mut s = named("tunnel-1km").map_err(|e| e.to_string())?;
            s.name = csv.display().to_string();
            s.tunnel.pieces.clear();
            s.tunnel.csv = Some(std::path::absolute(csv).map_err(|e| e.to_string())?);
            s.tunnel.width_m = a.width;
            s.drive.start_m = 0.0;
            // The whole line, once its length is known (below).
            s.drive.end_m = 1.0;
            s
        }
        (None, Some(f), _) => Scenario::from_file(f).map_err(|e| e.to_string())?,
        (None, None, n) => {
            named(n.as_deref().unwrap_or("tunnel-1km")).map_err(|e| e.to_string())?
        }
    };
    let line = scenario.centerline().map_err(|e| e.to_string())?;
    if a.centerline.is_some() {
        scenario.drive.end_m = line.length_m();
    }
    let (model, genes) = match &a.from_search {
        Some(dir) => {
            let p = dir.join("summary.json");
            let text = std::fs::read_to_string(&p).map_err(|e| {
                format!(
                    "{}: {e} (a finished `optimize` search has one)",
                    p.display()
                )
            })?;
            let v: serde_json::Value =
                serde_json::from_str(&text).map_err(|e| format!("{}: {e}", p.display()))?;
            let model = v["model"].as_str().unwrap_or_default().to_ascii_lowercase();
            let genes: Option<Vec<f64>> = v["best_genes"]
                .as_array()
                .map(|g| g.iter().filter_map(|x| x["value"].as_f64()).collect());
            (a.model.clone().unwrap_or(model), genes)
        }
        None => (
            a.model
                .clone()
                .ok_or("give --model p1…f4 or --from-search DIR")?,
            a.genes
                .as_deref()
                .map(host_sim::landmarks::LandmarkChoice::parse_genes)
                .transpose()
                .map_err(|e| e.to_string())?,
        ),
    };
    let choice = host_sim::landmarks::LandmarkChoice::parse(&model, genes.as_deref())
        .map_err(|e| e.to_string())?;
    if !(a.step > 0.0 && a.target_mm > 0.0 && a.spacing_tolerance_mm > 0.0 && a.window >= 1) {
        return Err(
            "--step, --target-mm and --spacing-tolerance-mm must be positive, --window at least 1"
                .into(),
        );
    }
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let req = host_sim::design::DesignRequest {
        scenario,
        choice,
        target_along_m: a.target_mm / 1e3,
        window: a.window,
        tolerance_m: a.spacing_tolerance_mm / 1e3,
        mounting_height_m: a.mounting_height,
        landmark_depth_m: a.depth,
        step_m: a.step,
        seed: a.seed,
    };
    let r = host_sim::design::design(&req, &a.out)?;
    if a.json {
        out(&serde_json::to_string(&r).map_err(|e| e.to_string())?)
    } else {
        out(&host_sim::design::text(&r))
    }
}

/// The text summary of a finished search.
fn optimize_report(s: &optimize::SearchSummary) -> String {
    let genes: Vec<String> = s
        .best_genes
        .iter()
        .map(|g| format!("{} = {:.4} {}", g.name, g.value, g.unit))
        .collect();
    let mut t = format!(
        "{} with {} in {}: {} generations, {} simulated runs, {:.1} s\n",
        s.model, s.matcher, s.scenario, s.generations, s.evaluations, s.wall_time_s
    );
    t += &format!("best genome: {}\n", genes.join(", "));
    t += &format!(
        "fitness (eq. 2 MSE): {:.3e} (RMS {:.2} mm)\n",
        s.best_fitness_mse,
        s.best_rms_eq2 * 1e3
    );
    t += &format!(
        "validated on {} fresh seeds: {:.2} ± {:.2} mm (95 %); generation 1's median genome {:.2} ± {:.2} mm; ratio {:.3}\n",
        s.validation_best.seeds.len(),
        s.validation_best.mean_position_rms_m * 1e3,
        s.validation_best.ci95_m * 1e3,
        s.validation_first_median.mean_position_rms_m * 1e3,
        s.validation_first_median.ci95_m * 1e3,
        s.best_over_random_median
    );
    for f in &s.files {
        t += &format!("wrote {}\n", f.display());
    }
    t.trim_end().to_string()
}

fn out(text: &str) -> Result<(), String> {
    use std::io::Write;
    let mut o = std::io::stdout().lock();
    match writeln!(o, "{text}").and_then(|()| o.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(format!("cannot write to standard output: {e}"))
        }
        _ => Ok(()),
    }
}

/// Writes `bytes` to the file `p`, or to standard output when `p` is `-`.
fn write_file(p: &Path, bytes: &[u8]) -> Result<(), String> {
    if p == Path::new("-") {
        use std::io::Write;
        let mut o = std::io::stdout().lock();
        return o
            .write_all(bytes)
            .and_then(|()| o.flush())
            .map_err(|e| format!("cannot write to standard output: {e}"));
    }
    std::fs::write(p, bytes).map_err(|e| format!("cannot write {}: {e}", p.display()))
}

/// Checks, before any work, that `dir` can be an output directory: not an existing file,
/// not `-` (a directory of several files cannot go to standard output).
fn check_output_dir(flag: &str, dir: Option<&Path>) -> Result<(), String> {
    let Some(dir) = dir else { return Ok(()) };
    if dir == Path::new("-") {
        return Err(format!(
            "{flag} - : {flag} writes a directory of several files; give a directory (standard output takes --json)"
        ));
    }
    if dir.exists() && !dir.is_dir() {
        return Err(format!(
            "{flag} {}: exists and is not a directory; give a new or an existing directory",
            dir.display()
        ));
    }
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Demo { seed } => cmd_demo(*seed),
        Command::Run(a) => cmd_run(a),
        Command::Hil(a) => cmd_hil(a),
        Command::ExportMap(a) => cmd_export(a),
        Command::Replay(a) => cmd_replay(a),
        Command::Optimize(a) => cmd_optimize(a),
        Command::Table2(a) => cmd_table2(a),
        Command::CompareObjectives(a) => cmd_compare(a),
        Command::Design(a) => cmd_design(a),
        Command::Survey(a) => survey_cli::cmd_survey(a),
        Command::Relocalise(a) => cmd_relocalise(a),
        Command::Spread(a) => cmd_spread(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("host-sim: {e}");
            ExitCode::from(2)
        }
    }
}
