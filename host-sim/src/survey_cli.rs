//! `host-sim survey DIR --out OUT`: the command line of [`host_sim::survey`].

use std::path::{Path, PathBuf};

use clap::Args;

use host_sim::landmarks::LandmarkChoice;
use host_sim::record::files;
use host_sim::replay::ReplaySources;
use host_sim::stored_map;
use host_sim::survey::graph::Solver;
use host_sim::survey::report::{self, AgainstTruth};
use host_sim::survey::{self, bootstrap, score, Anchor, PriorMap, Stage, SurveyOptions};

#[derive(Args)]
pub struct SurveyArgs {
    /// Recording directory (`host-sim run --record DIR`, or a vehicle's log with the same
    /// file names: the scanner stream, odometry.csv, scenario.toml and the design map).
    pub dir: PathBuf,
    /// Output directory: survey.postcard (the map), survey.json, landmarks.csv, report.txt.
    #[arg(long)]
    pub out: PathBuf,
    /// The prior map (the design) instead of DIR/map.postcard.
    #[arg(long)]
    pub design: Option<PathBuf>,
    /// Scanner recording instead of DIR/scanner.colab.bin (raw CoLa, pcapng, pcap, .pcapng.json).
    #[arg(long)]
    pub scanner: Option<PathBuf>,
    /// Scan times CSV instead of DIR/scanner.colab.times.csv.
    #[arg(long)]
    pub scanner_times: Option<PathBuf>,
    /// Odometry CSV instead of DIR/odometry.csv.
    #[arg(long)]
    pub odometry: Option<PathBuf>,
    /// Scenario TOML instead of DIR/scenario.toml (sensor mounting, odometry noise).
    #[arg(long)]
    pub scenario: Option<PathBuf>,
    /// Score the landmarks against this true as-built map (default: DIR/as_built.postcard
    /// when the recording is simulated).
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// Installation tolerance of the landmarks against the design's marks, 1σ along the
    /// wall in metres (half of it across): the design's pull on the survey.
    #[arg(long, default_value_t = 0.05)]
    pub tolerance: f64,
    /// Use the design only to pair scans with landmarks: the map is tied to the anchors, or
    /// relative to the first landmark.
    #[arg(long)]
    pub no_design_prior: bool,
    /// No prior map at all: the drive's own map (odometry, scan matches and the landmarks
    /// found in the scans) stands in for the design, written to OUT/bootstrap.postcard with
    /// its landmarks in OUT/bootstrap.csv; the map is relative to the first landmark, or
    /// tied to anchors (indices as in bootstrap.csv: the order the drive first saw them).
    #[arg(long, conflicts_with_all = ["design", "no_design_prior"])]
    pub without_map: bool,
    /// With `--without-map`: the installed landmarks' model (`p1`…`p4`, `f1`…`f4`, `none`);
    /// default the recording's scenario's `landmarks.model`.
    #[arg(long, requires = "without_map")]
    pub landmarks: Option<String>,
    /// With `--without-map`: their genes `W,H,D[,h1..h6]` (metres); default the scenario's,
    /// or the model's paper optimum.
    #[arg(long, requires = "without_map")]
    pub genes: Option<String>,
    /// A surveyed landmark: `INDEX,X,Y[,SD]` (index in the design map, or with
    /// `--without-map` in bootstrap.csv; base centre in mine coordinates in metres, 1σ
    /// default 0.005 m). Repeat for more.
    #[arg(long, allow_hyphen_values = true)]
    pub anchor: Vec<String>,
    /// Odometry distance between keyframes, metres.
    #[arg(long, default_value_t = 0.25)]
    pub keyframe_spacing: f64,
    /// Fit landmarks within this range of the vehicle, metres.
    #[arg(long, default_value_t = 20.0)]
    pub range: f64,
    /// Back end of the joint solve: factrs (Levenberg–Marquardt, faer's sparse Cholesky),
    /// apex (apex-solver) or own (the survey's own Levenberg–Marquardt on nalgebra-sparse).
    /// All three solve the same problem; see the README's "Solver" for their figures.
    #[arg(long, default_value = "factrs", value_parser = parse_solver)]
    pub solver: Solver,
    /// Print survey.json instead of the report.
    #[arg(long)]
    pub json: bool,
    /// No progress lines.
    #[arg(long)]
    pub quiet: bool,
}

fn parse_anchor(text: &str) -> Result<Anchor, String> {
    let v: Vec<&str> = text.split(',').map(str::trim).collect();
    let bad = || format!("--anchor `{text}`: give INDEX,X,Y[,SD] (metres)");
    if !(3..=4).contains(&v.len()) {
        return Err(bad());
    }
    let num = |s: &str| s.parse::<f64>().ok().filter(|x| x.is_finite());
    let a = Anchor {
        landmark: v[0].parse().map_err(|_| bad())?,
        x_m: num(v[1]).ok_or_else(bad)?,
        y_m: num(v[2]).ok_or_else(bad)?,
        sd_m: v.get(3).map_or(Some(0.005), |s| num(s)).ok_or_else(bad)?,
    };
    if a.sd_m <= 0.0 {
        return Err(format!("--anchor `{text}`: the 1σ must be positive"));
    }
    Ok(a)
}

/// The installed landmarks' shape for `--without-map`: `--landmarks`/`--genes`, else the
/// scenario's; `None` for a tunnel without landmarks.
fn installed_shape(
    a: &SurveyArgs,
    scenario: &Path,
) -> Result<Option<loc_core::landmark::LandmarkShape>, String> {
    let sc = host_sim::scenario::Scenario::from_file(scenario).map_err(|e| e.to_string())?;
    let model = a.landmarks.clone().unwrap_or(sc.landmarks.model.clone());
    let genes = match (&a.genes, &a.landmarks) {
        (Some(g), _) => Some(LandmarkChoice::parse_genes(g).map_err(|e| format!("--genes: {e}"))?),
        (None, Some(_)) => None,
        (None, None) => sc.landmarks.genes.clone(),
    };
    match LandmarkChoice::parse(&model, genes.as_deref())
        .map_err(|e| format!("--landmarks {model}: {e}"))?
    {
        LandmarkChoice::None => Ok(None),
        LandmarkChoice::Shape(s) => Ok(Some(s)),
    }
}

fn parse_solver(text: &str) -> Result<Solver, String> {
    text.parse()
        .map_err(|e: host_sim::survey::graph::UnknownSolver| e.to_string())
}

fn sources(a: &SurveyArgs) -> Result<ReplaySources, String> {
    let mut src = ReplaySources::in_dir(&a.dir).map_err(|e| e.to_string())?;
    let set = |slot: &mut PathBuf, v: &Option<PathBuf>| {
        if let Some(p) = v {
            *slot = p.clone();
        }
    };
    set(&mut src.scanner, &a.scanner);
    set(&mut src.odometry, &a.odometry);
    set(&mut src.map, &a.design);
    set(&mut src.scenario, &a.scenario);
    if a.scanner_times.is_some() || a.scanner.is_some() {
        src.scanner_times = a.scanner_times.clone();
    }
    Ok(src)
}

fn read_map(path: &Path) -> Result<Box<loc_core::map::TunnelMap>, String> {
    host_sim::replay::read_map(path).map_err(|e| e.to_string())
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> Result<PathBuf, String> {
    let p = dir.join(name);
    std::fs::write(&p, bytes).map_err(|e| format!("cannot write {}: {e}", p.display()))?;
    Ok(p)
}

/// Runs `host-sim survey`.
pub fn cmd_survey(a: &SurveyArgs) -> Result<(), String> {
    if !(a.tolerance.is_finite() && a.tolerance > 0.0) {
        return Err(format!(
            "--tolerance {}: give a positive number of metres",
            a.tolerance
        ));
    }
    if !(a.keyframe_spacing.is_finite() && a.keyframe_spacing > 0.0) {
        return Err("--keyframe-spacing: give a positive number of metres".into());
    }
    let mut src = sources(a)?;
    let mut options = SurveyOptions {
        keyframe_spacing_m: a.keyframe_spacing,
        landmark_range_m: a.range,
        design_tolerance_m: (!a.no_design_prior).then_some(a.tolerance),
        anchors: a
            .anchor
            .iter()
            .map(|s| parse_anchor(s))
            .collect::<Result<_, _>>()?,
        solver: a.solver,
        ..SurveyOptions::default()
    };
    let truth_path = a
        .truth
        .clone()
        .or_else(|| Some(a.dir.join(files::AS_BUILT_MAP)).filter(|p| p.is_file()));
    let truth = truth_path.as_deref().map(read_map).transpose()?;
    std::fs::create_dir_all(&a.out)
        .map_err(|e| format!("cannot create {}: {e}", a.out.display()))?;
    let quiet = a.quiet;
    let last = std::cell::Cell::new((Stage::Map, -1i32));
    let progress = |stage: Stage, f: f64| {
        let pct = (f * 10.0).floor() as i32 * 10;
        if !quiet && (last.get().0 != stage || last.get().1 != pct) {
            eprintln!("survey: {} {pct:>3} %", stage.name());
            last.set((stage, pct));
        }
    };
    if a.without_map {
        let shape = installed_shape(a, &src.scenario)?;
        let bootstrap = bootstrap::bootstrap(&src, shape.as_ref(), &options, &|f| {
            progress(Stage::Bootstrap, f)
        })
        .map_err(|e| e.to_string())?;
        let bytes = stored_map::to_file_bytes(&bootstrap.map).map_err(|e| e.to_string())?;
        src.map = write(&a.out, "bootstrap.postcard", &bytes)?;
        write(
            &a.out,
            "bootstrap.csv",
            bootstrap::landmarks_csv(&bootstrap).as_bytes(),
        )?;
        if !quiet {
            eprintln!("survey: {}", bootstrap.summary());
        }
        options.design_tolerance_m = None;
        options.prior = PriorMap::Drive;
    }
    let s = survey::survey(&src, &options, &progress).map_err(|e| e.to_string())?;
    let against = truth.as_ref().map(|t| AgainstTruth {
        prior: score::score(&s.prior, t),
        surveyed: score::score(&s.map, t),
    });
    let map_bytes = stored_map::to_file_bytes(&s.map).map_err(|e| e.to_string())?;
    let mut written = vec![write(&a.out, "survey.postcard", &map_bytes)?];
    let json =
        serde_json::to_string_pretty(&report::json(&s, against)).map_err(|e| e.to_string())?;
    written.push(write(&a.out, "survey.json", json.as_bytes())?);
    written.push(write(
        &a.out,
        "landmarks.csv",
        report::landmarks_csv(&s).as_bytes(),
    )?);
    let text = report::text(&s, against.as_ref());
    written.push(write(&a.out, "report.txt", text.as_bytes())?);
    written.extend(host_sim::survey::plot::write_plots(&a.out, &s)?);
    if a.json {
        println!("{json}");
    } else {
        println!("{text}");
        for p in written {
            println!("wrote {}", p.display());
        }
        println!(
            "localise against it: host-sim replay {} --map {}",
            a.dir.display(),
            a.out.join("survey.postcard").display()
        );
    }
    Ok(())
}
