//! `run --record` then `replay`: a replay of a simulated run through the recorded LMS511
//! byte stream, odometry CSV, map file and initial pose gives the run's own figures.

use host_sim::closed_loop::RunOptions;
use host_sim::metrics::{Accuracy, Metrics};
use host_sim::record::{self, files};
use host_sim::replay::{self, scan_source::TimeSource, ReplaySources};
use host_sim::scenario::named::named;
use host_sim::session::{run_scenario, EstimatorChoice};

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * (1.0 + a.abs().max(b.abs()))
}

fn assert_same_accuracy(what: &str, a: &Accuracy, b: &Accuracy) {
    let pairs = [
        ("mse_eq2", a.mse_eq2, b.mse_eq2),
        ("position_rms_m", a.position_rms_m, b.position_rms_m),
        ("heading_rms_rad", a.heading_rms_rad, b.heading_rms_rad),
        (
            "max_position_error_m",
            a.max_position_error_m,
            b.max_position_error_m,
        ),
        ("along_rms_m", a.along_rms_m, b.along_rms_m),
        ("across_rms_m", a.across_rms_m, b.across_rms_m),
        (
            "final_position_error_m",
            a.final_position_error_m,
            b.final_position_error_m,
        ),
    ];
    for (name, x, y) in pairs {
        assert!(close(x, y), "{what} {name}: run {x} vs replay {y}");
    }
}

fn assert_same_metrics(run: &Metrics, rep: &Metrics) {
    assert_eq!(run.scans, rep.scans);
    assert!(close(run.distance_m, rep.distance_m));
    assert!(close(run.sim_time_s, rep.sim_time_s));
    assert_same_accuracy("localiser", &run.localizer, &rep.localizer);
    assert_same_accuracy("odometry", &run.odometry, &rep.odometry);
}

/// A localised run of `paper-10m` with `seed`, recorded into a temporary directory (with the
/// files written).
fn recorded_run(
    seed: u64,
) -> (
    host_sim::closed_loop::RunLog,
    tempfile::TempDir,
    Vec<std::path::PathBuf>,
) {
    let mut s = named("paper-10m").unwrap();
    s.seed = seed;
    recorded(&s)
}

/// A localised run of `s`, recorded into a temporary directory (with the files written).
fn recorded(
    s: &host_sim::scenario::Scenario,
) -> (
    host_sim::closed_loop::RunLog,
    tempfile::TempDir,
    Vec<std::path::PathBuf>,
) {
    let options = RunOptions {
        keep_scans: true,
        progress: None,
        ..Default::default()
    };
    let log = run_scenario(s, EstimatorChoice::Localizer, &options).unwrap();
    let (_, map_file) = record::scenario_map(s).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let written = record::write_recording(dir.path(), &log, &map_file, None).unwrap();
    (log, dir, written)
}

#[test]
fn replaying_a_recorded_run_gives_the_runs_figures() {
    let (log, dir, written) = recorded_run(7);
    assert_eq!(written.len(), 8);
    for name in [
        files::SCANNER,
        files::SCANNER_TIMES,
        files::ODOMETRY,
        files::GROUND_TRUTH,
        files::INITIAL_POSE,
        files::MAP,
        files::SCENARIO,
        files::README,
    ] {
        assert!(dir.path().join(name).is_file(), "{name}");
    }
    // 2391 bytes per 1141-beam telegram with DIST1 alone (clear air: one echo per beam).
    let stream = std::fs::metadata(dir.path().join(files::SCANNER))
        .unwrap()
        .len();
    assert_eq!(stream, 2391 * log.scans.len() as u64);

    let sources = ReplaySources::in_dir(dir.path()).unwrap();
    let rep = replay::replay(&sources, EstimatorChoice::Localizer).unwrap();
    assert_eq!(rep.source.time_source, TimeSource::Sidecar);
    assert!(rep.warnings.is_empty(), "{:?}", rep.warnings);
    assert_eq!(rep.source.scans, log.scans.len());
    assert_eq!(rep.source.scored_scans, log.samples.len());
    assert_eq!(rep.log.statuses, log.statuses);
    // The very same estimates, scan by scan.
    for (a, b) in log.samples.iter().zip(&rep.log.samples) {
        assert_eq!(a.t_s, b.t_s);
        assert_eq!(a.truth, b.truth);
        assert_eq!(a.estimate, b.estimate, "at t = {}", a.t_s);
        assert_eq!(a.odometry, b.odometry, "at t = {}", a.t_s);
    }
    let (m_run, m_rep) = (log.metrics(), rep.log.metrics());
    assert_same_metrics(&m_run, &m_rep);
    // The localiser did localise (the comparison is not between two failures).
    assert!(
        log.status_count(host_sim::status::EstimatorStatus::is_tracking) > log.samples.len() / 2
    );
    assert!(m_run.localizer.position_rms_m < m_run.odometry.position_rms_m);

    // Without the sidecar the scanner's own clock is used (offset by its power-up time):
    // the odometry is then on another clock, and the replay refuses to localise scans
    // without the motion between them.
    std::fs::remove_file(dir.path().join(files::SCANNER_TIMES)).unwrap();
    let clock = replay::scan_source::read_scans(&dir.path().join(files::SCANNER), None).unwrap();
    assert_eq!(clock.time_source, TimeSource::ScannerClock);
    let dt = clock.scans[0].t_s - log.samples[0].t_s;
    assert!(
        (dt - record::scanner_telegram::POWER_UP_BEFORE_RUN_S).abs() < 1e-6,
        "{dt}"
    );
    let sources = ReplaySources::in_dir(dir.path()).unwrap();
    let e = replay::replay(&sources, EstimatorChoice::OdometryOnly)
        .unwrap_err()
        .to_string();
    assert!(e.contains("different clocks"), "{e}");
}

#[test]
fn replay_names_what_is_missing() {
    let dir = tempfile::tempdir().unwrap();
    let e = ReplaySources::in_dir(dir.path()).unwrap_err().to_string();
    assert!(e.contains(files::SCANNER), "{e}");
    let e = ReplaySources::in_dir(&dir.path().join("nope"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a directory"), "{e}");
}

/// A user's own recording: the real LMS511 capture as SICK's `.pcapng.json` (an office, not a
/// tunnel), with an odometry log of a vehicle standing still, a map file and an initial pose,
/// without ground truth: every scan is decoded and goes through the localiser, nothing is
/// scored, nothing panics on a scene that matches no map, and no pose claims to track it.
#[test]
fn replays_a_real_lms511_capture_without_ground_truth() {
    let capture = sick_captures::path(sick_captures::LMS511_JSON);
    let dir = tempfile::tempdir().unwrap();
    let s = named("paper-10m").unwrap();
    let (_, map_file) = record::scenario_map(&s).unwrap();
    std::fs::write(dir.path().join(files::MAP), map_file).unwrap();
    std::fs::write(dir.path().join(files::SCENARIO), s.to_toml()).unwrap();
    // The JSON's times run from the capture start; the scans come a few seconds in.
    let mut odo = String::from("t_s,dt_s,v_mps,omega_radps\n");
    for k in 1..=1500 {
        odo.push_str(&format!("{},0.01,0,0\n", f64::from(k) * 0.01));
    }
    std::fs::write(dir.path().join(files::ODOMETRY), odo).unwrap();
    std::fs::write(
        dir.path().join(files::INITIAL_POSE),
        "x_m,y_m,theta_rad,sigma_xy_m,sigma_theta_rad\n1,0,0,0.05,0.01\n",
    )
    .unwrap();
    // The directory has no scanner stream of its own: the capture is given by path.
    assert!(ReplaySources::in_dir(dir.path()).is_err());
    let sources = ReplaySources {
        scanner: capture,
        ..placeholder(dir.path())
    };
    let rep = replay::replay(&sources, EstimatorChoice::Localizer).unwrap();
    assert_eq!(rep.source.scans, 174);
    assert_eq!(rep.source.time_source, TimeSource::Capture);
    // An office is no tunnel of the map: no scan is tracked. The matcher either fails to
    // lay the office onto the tunnel (rejected) or lays it (perhaps cut short by the scan's
    // work budget) and the integrity check does not confirm the map, which the replay says
    // once that is a tenth of the scans or more.
    let rejected = rep.steps.iter().filter(|s| s.status.is_rejected()).count();
    let unconfirmed = rep.steps.len() - rejected;
    if unconfirmed * 10 < rep.steps.len() {
        assert!(rep.warnings.is_empty(), "{:?}", rep.warnings);
    } else {
        assert_eq!(rep.warnings.len(), 1, "{:?}", rep.warnings);
        assert!(
            rep.warnings[0].contains("map was not confirmed"),
            "{:?}",
            rep.warnings
        );
    }
    assert!(!rep.steps.iter().any(|s| s.status.is_tracking()));
    assert!(
        rep.source.other_frames > 0,
        "the start-up dialogue is skipped"
    );
    assert_eq!(rep.steps.len(), 174);
    assert!(rep.log.samples.is_empty());
    assert!(rep.steps.windows(2).all(|w| w[0].t_s < w[1].t_s));
    assert!(rep
        .steps
        .iter()
        .all(|s| s.estimate.x_m.is_finite() && s.estimate.y_m.is_finite()));
}

/// The sources of a directory that has everything but the scanner stream.
fn placeholder(dir: &std::path::Path) -> ReplaySources {
    ReplaySources {
        scanner: std::path::PathBuf::new(),
        scanner_times: None,
        odometry: dir.join(files::ODOMETRY),
        map: dir.join(files::MAP),
        scenario: dir.join(files::SCENARIO),
        initial_pose: Some(dir.join(files::INITIAL_POSE)),
        ground_truth: None,
    }
}

/// A scanner at a layout the scenario does not name: the recording's telegrams start at 0°
/// (the first 30 beams of −5°…185° cut off, as an LMS511 configured with
/// `LMPoutputRange` 0°…185° sends) and the scenario file says nothing of it. The replay takes
/// the telegrams' own beam angles and localises as well as the run did on the full scans.
#[test]
fn a_recording_at_another_start_angle_is_localised_with_its_own_beam_angles() {
    use lidar_driver::{Dialect, Framer, ScanData, ScanRepr};

    let (log, dir, _) = recorded_run(3);

    // Re-encode every telegram from beam 30 on: start −5° + 30 · 1/6° = 0°.
    let path = dir.path().join(files::SCANNER);
    let bytes = std::fs::read(&path).unwrap();
    let mut framer = Framer::new(vec![0u8; 16 * 1024]);
    let mut cut = Vec::new();
    framer.feed(&bytes, |f| {
        let scan = ScanData::new_checked(f.unwrap()).unwrap();
        let mut repr = ScanRepr::parse(&scan);
        // Every echo channel alike: they are the echoes of the same beams.
        for dist in &mut repr.channels16 {
            dist.values.drain(..30);
            dist.start_angle_1e4_deg = 0;
        }
        cut.extend(repr.to_vec(Dialect::ColaB).unwrap());
    });
    std::fs::write(&path, cut).unwrap();

    let sources = ReplaySources::in_dir(dir.path()).unwrap();
    let rep = replay::replay(&sources, EstimatorChoice::Localizer).unwrap();
    assert_eq!(rep.source.scans, log.scans.len());
    let (run, cut) = (log.metrics().localizer, rep.log.metrics().localizer);
    eprintln!(
        "position RMS: full scans {:.2} mm, scans from 0 deg {:.2} mm",
        run.position_rms_m * 1e3,
        cut.position_rms_m * 1e3
    );
    assert!(
        cut.position_rms_m < 0.010 && cut.position_rms_m < 1.5 * run.position_rms_m,
        "run {} m, replay {} m",
        run.position_rms_m,
        cut.position_rms_m
    );
    let tracking = rep
        .log
        .status_count(host_sim::status::EstimatorStatus::is_tracking);
    assert!(tracking > rep.log.samples.len() / 2, "{tracking}");
    // Read with the scenario's −5° start instead, the same beams would sit 5° off: the
    // localiser would not find the walls where they are.
    let first = &rep.log.scans[0];
    assert_eq!(first.layout.start_angle_1e4_deg, 0);
    assert_eq!(usize::from(first.layout.beams), 1111);
}

/// A recording of a scenario whose centre line comes from a CSV carries a copy of the CSV
/// (the issue: replay of the shipped S-bend example failed with "cannot read scenario
/// …/s-bend-400m.csv"): moved anywhere, it replays on its own.
#[test]
fn a_recording_of_a_csv_centre_line_is_self_contained() {
    let example = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/s-bend-400m.toml");
    let mut s = host_sim::scenario::Scenario::from_file(std::path::Path::new(example)).unwrap();
    s.drive.end_m = s.drive.start_m + 15.0;
    let (log, dir, written) = recorded(&s);
    assert!(written
        .iter()
        .any(|p| p.ends_with(host_sim::scenario::CENTERLINE_COPY)));
    // Moved elsewhere: the example's own CSV is no longer beside it.
    let moved = tempfile::tempdir().unwrap();
    for f in std::fs::read_dir(dir.path()).unwrap() {
        let f = f.unwrap();
        std::fs::copy(f.path(), moved.path().join(f.file_name())).unwrap();
    }
    drop(dir);
    let sources = ReplaySources::in_dir(moved.path()).unwrap();
    let rep = replay::replay(&sources, EstimatorChoice::Localizer).unwrap();
    assert_eq!(rep.source.scans, log.scans.len());
    assert_same_metrics(&log.metrics(), &rep.log.metrics());
}

/// Damage in the scanner stream loses only the damaged telegrams: a flipped bit, a cut in the
/// middle of a telegram and garbage between two telegrams each drop at most the telegram they
/// hit; the replay runs on the others, at their own times, names each lost one by its row and
/// byte offset, and still localises.
#[test]
fn a_damaged_stream_loses_only_the_damaged_telegrams() {
    let (log, dir, _) = recorded_run(7);
    let n = log.scans.len();
    let stream_path = dir.path().join(files::SCANNER);
    let mut stream = std::fs::read(&stream_path).unwrap();
    let telegram = 2391usize;
    // Garbage between telegrams 60 and 61 (done first: the offsets below stay valid).
    let garbage = [0x55u8; 37];
    stream.splice(61 * telegram..61 * telegram, garbage);
    // 500 bytes cut out of the middle of telegram 40.
    stream.drain(40 * telegram + 900..40 * telegram + 1400);
    // A flipped bit in a range value of telegram 10 (its checksum no longer matches).
    stream[10 * telegram + 1200] ^= 0x10;
    std::fs::write(&stream_path, &stream).unwrap();

    let sources = ReplaySources::in_dir(dir.path()).unwrap();
    let rep = replay::replay(&sources, EstimatorChoice::Localizer).unwrap();
    assert_eq!(rep.source.time_source, TimeSource::Sidecar);
    assert_eq!(rep.source.scans, n - 2, "{:?}", rep.warnings);
    assert_eq!(rep.source.damaged_scans, 2);
    let lost: Vec<&String> = rep
        .warnings
        .iter()
        .filter(|w| w.contains(" at byte "))
        .collect();
    assert_eq!(lost.len(), 2, "{:?}", rep.warnings);
    assert!(
        lost[0].contains("scan 10 at byte 23910"),
        "{:?}",
        rep.warnings
    );
    assert!(
        lost[1].contains("scan 40 at byte 95640"),
        "{:?}",
        rep.warnings
    );
    // Every surviving scan keeps its own time: the times are the run's minus the two lost.
    let mut expected: Vec<f64> = log.scans.iter().map(|s| s.t_s).collect();
    expected.remove(40);
    expected.remove(10);
    let got: Vec<f64> = rep.steps.iter().map(|s| s.t_s).collect();
    assert_eq!(got, expected);
    // Up to the first damage the estimates are the run's own; after it the localiser goes on.
    for (a, b) in log.samples.iter().zip(&rep.log.samples).take(10) {
        assert_eq!(a.estimate, b.estimate, "at t = {}", a.t_s);
    }
    let m = rep.log.metrics();
    assert!(
        m.localizer.position_rms_m < 2.0 * log.metrics().localizer.position_rms_m + 1e-3,
        "{} vs {}",
        m.localizer.position_rms_m,
        log.metrics().localizer.position_rms_m
    );
}

/// `replay --estimates`: another localiser's poses are scored by the same pairing and
/// metrics. The replay's own `estimates.csv` (poses printed to 10 µm) scores as the replay
/// itself; a file missing scans is refused, naming the first.
#[test]
fn another_localisers_estimates_score_as_the_replay_does() {
    let (_, dir, _) = recorded_run(3);
    let sources = ReplaySources::in_dir(dir.path()).unwrap();
    let own = replay::replay(&sources, EstimatorChoice::Localizer).unwrap();
    let est = dir.path().join("own-estimates.csv");
    let mut buf = Vec::new();
    replay::write_estimates_csv(&own.steps, &mut buf).unwrap();
    std::fs::write(&est, &buf).unwrap();
    let options = replay::ReplayOptions {
        keep_scans: false,
        estimates: Some(est.clone()),
        ..replay::ReplayOptions::default()
    };
    let ext = replay::replay_with(&sources, EstimatorChoice::Localizer, &options).unwrap();
    assert_eq!(ext.log.samples.len(), own.log.samples.len());
    let (a, b) = (own.log.metrics(), ext.log.metrics());
    for (name, x, y) in [
        (
            "position",
            a.localizer.position_rms_m,
            b.localizer.position_rms_m,
        ),
        (
            "heading",
            a.localizer.heading_rms_rad * 1e2,
            b.localizer.heading_rms_rad * 1e2,
        ),
        ("along", a.localizer.along_rms_m, b.localizer.along_rms_m),
        ("across", a.localizer.across_rms_m, b.localizer.across_rms_m),
        (
            "max",
            a.localizer.max_position_error_m,
            b.localizer.max_position_error_m,
        ),
    ] {
        assert!((x - y).abs() < 2e-5, "{name}: own {x} vs scored {y}");
    }
    // The odometry baseline is the recording's, whatever the estimates.
    assert_eq!(a.odometry.position_rms_m, b.odometry.position_rms_m);
    assert!(ext.log.estimator.starts_with("external"));
    // The file's own per-scan times are reported, not the time of reading a row.
    let mean_own = own.steps.iter().map(|s| s.update_us).sum::<f64>() / own.steps.len() as f64;
    let mean_ext = ext.steps.iter().map(|s| s.update_us).sum::<f64>() / ext.steps.len() as f64;
    assert!(
        (mean_own - mean_ext).abs() < 0.1,
        "{mean_own} vs {mean_ext}"
    );

    // Half the rows dropped: refused, not scored on the last pose held.
    let text = String::from_utf8(buf).unwrap();
    let kept: Vec<&str> = text.lines().take(own.steps.len() / 2).collect();
    std::fs::write(&est, kept.join("\n")).unwrap();
    let e = replay::replay_with(&sources, EstimatorChoice::Localizer, &options)
        .unwrap_err()
        .to_string();
    assert!(e.contains("has no row for") && e.contains("scans"), "{e}");
}

/// `replay --bound`: every scan of `paper-10m` (landmarks always in view) has a finite
/// Cramér–Rao bound at the true pose, of millimetres, and the localiser's error is of its
/// order (not orders of magnitude below a bound, which would mean the bound is wrong; the
/// filter averages scans, so somewhat below the one-scan bound is right: 0.69 here).
#[test]
fn the_cramer_rao_bound_of_each_scan_sits_beside_the_error() {
    let (_, dir, _) = recorded_run(2);
    let sources = ReplaySources::in_dir(dir.path()).unwrap();
    let options = replay::ReplayOptions {
        keep_scans: false,
        bound: true,
        ..replay::ReplayOptions::default()
    };
    let rep = replay::replay_with(&sources, EstimatorChoice::Localizer, &options).unwrap();
    let b = rep.bound.expect("a bound with ground truth");
    assert_eq!(b.scans, rep.log.samples.len());
    assert!(
        b.position_rms_m > 0.5e-3 && b.position_rms_m < 5e-3,
        "{b:?}"
    );
    assert!(b.across_rms_m < b.position_rms_m && b.along_rms_m < b.position_rms_m);
    assert!(b.position_ratio > 0.5 && b.position_ratio < 4.0, "{b:?}");
    let m = rep.log.metrics();
    let ratio = m.localizer.position_rms_m / b.position_rms_m;
    assert!(
        (ratio - b.position_ratio).abs() < 1e-9,
        "the same scans: {ratio} vs {b:?}"
    );
}
