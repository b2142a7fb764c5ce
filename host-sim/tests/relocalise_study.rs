//! The quick variant of `host-sim relocalise` (the README's study runs 100 power-ups and 20
//! kidnappings): a few power-ups without a pose at random places on `tunnel-1km` (P1) and a
//! few kidnappings, through the simulator's closed loop. Every run must track at the right
//! place within 30 m, none may ever report tracking at a wrong one, and every kidnapping
//! must be noticed.

use host_sim::relocalise_study::{run_one, run_study, RunOutcome, StudySpec};
use host_sim::scenario::named::named;
use host_sim::scenario::overrides::Overrides;

fn tunnel() -> host_sim::scenario::Scenario {
    let mut s = named("tunnel-1km").expect("named scenario");
    Overrides {
        landmarks: Some("p1".into()),
        seed: Some(7),
        ..Overrides::default()
    }
    .apply(&mut s)
    .expect("overrides apply");
    s
}

#[test]
fn power_up_anywhere_tracks_at_the_right_place_within_30_m() {
    let spec = StudySpec {
        runs: 6,
        seed: 3,
        ..StudySpec::default()
    };
    let r = run_study(&tunnel(), &spec, None).expect("study runs");
    eprintln!("{}", r.report());
    assert_eq!(r.wrong_lock_runs(), 0, "{}", r.report());
    assert_eq!(r.tracked(), 6, "{}", r.report());
    let (_, _, max) = r.metres_to_tracking().expect("tracked");
    assert!(max <= 30.0, "{}", r.report());
}

#[test]
fn kidnappings_are_noticed_and_recovered_without_a_wrong_lock() {
    let spec = StudySpec {
        runs: 4,
        kidnap: true,
        drive_m: 60.0,
        seed: 5,
        ..StudySpec::default()
    };
    let r = run_study(&tunnel(), &spec, None).expect("study runs");
    eprintln!("{}", r.report());
    assert_eq!(r.wrong_lock_runs(), 0, "{}", r.report());
    assert!(r.runs.iter().all(|run| run.detected), "{}", r.report());
    assert_eq!(r.tracked(), 4, "{}", r.report());
    assert!(r.runs.iter().all(|run| run.jump_m.abs() >= 5.0));
}

#[test]
fn a_blind_lidar_is_bridged_on_odometry_and_a_kidnapping_in_a_run_is_recovered() {
    use host_sim::closed_loop::{Blind, RunOptions, Teleport};
    use host_sim::session::{run_scenario, EstimatorChoice};
    let mut s = tunnel();
    s.drive.end_m = s.drive.start_m + 120.0;
    let blind = [Blind {
        from_m: 20.0,
        seconds: 3.0,
    }];
    let teleports = [Teleport {
        at_distance_m: 60.0,
        jump_m: -20.0,
    }];
    let options = RunOptions {
        blind: &blind,
        teleports: &teleports,
        ..RunOptions::default()
    };
    let log = run_scenario(&s, EstimatorChoice::Localizer, &options).expect("runs");
    // No scan during the blind stretch (3 s at 25 Hz), and none tracking off the truth.
    let gap = log
        .samples
        .windows(2)
        .map(|w| w[1].t_s - w[0].t_s)
        .fold(0.0f64, f64::max);
    assert!(
        (2.9..3.2).contains(&gap),
        "longest gap between scans {gap:.2} s"
    );
    let mut relocalised = false;
    let mut tracking_after_kidnap = false;
    for (sample, status) in log.samples.iter().zip(&log.statuses) {
        let e =
            (sample.estimate.x_m - sample.truth.x_m).hypot(sample.estimate.y_m - sample.truth.y_m);
        if status.is_tracking() {
            assert!(
                e < 0.5,
                "tracking {e:.2} m off at {:.1} m",
                sample.distance_m
            );
            tracking_after_kidnap |= relocalised;
        }
        relocalised |= sample.distance_m > 60.0 && status.is_relocalising();
    }
    assert!(relocalised, "the kidnapping was not noticed");
    assert!(tracking_after_kidnap, "no tracking after the kidnapping");
}

/// Two kidnappings of the README's study (`--kidnap --drive 80`) that were once reported
/// tracking tens of metres off: study seed 4's tenth run, a jump of 47.2 m (five landmark
/// spacings less 0.3 m), after which the scans' landmarks fit in part, scan by scan, where
/// the map's look alike; and study seed 8's eleventh, a jump of −29.0 m whose first scan
/// had half its landmarks on map ones. The runs before them are drawn (and run) as the
/// study does, so these two are the study's own.
#[test]
fn kidnappings_to_look_alike_landmarks_are_never_reported_tracking_there() {
    for (seed, runs) in [(4, 10), (8, 11)] {
        let spec = StudySpec {
            runs,
            kidnap: true,
            drive_m: 80.0,
            seed,
            ..StudySpec::default()
        };
        let r = run_study(&tunnel(), &spec, None).expect("study runs");
        let last = r.runs.last().expect("runs");
        assert!(
            last.jump_m.abs() > 25.0,
            "not the run meant: {}",
            r.report()
        );
        assert!(
            r.runs.iter().all(|run| run.wrong_lock_scans == 0),
            "study seed {seed}: {}",
            r.report()
        );
        assert_eq!(r.tracked(), runs as usize, "{}", r.report());
    }
}

/// A kidnapping the filter's gate refuses once, after which the match slides onto a
/// look-alike stretch of landmarks and fits there (`relocalise --scenario tunnel-1km
/// --kidnap --drive 80 --study-seed 2`, run 44: 28.9 m back). One refused match is already
/// the sign of a jump: that scan was reported tracking 28.9 m off while a second refusal
/// was awaited.
#[test]
fn one_refused_match_is_enough_to_doubt_the_map() {
    let r = study_seed_2_run(44, 210.890_464_782_644_36, -28.907_430_171_966_553);
    assert!(r.detected, "{r:?}");
    assert_eq!(r.wrong_lock_scans, 0, "{}", r.timeline);
    assert!(r.timeline.contains("rejected:gate"), "{}", r.timeline);
}

/// Run `run_index` of `relocalise --scenario tunnel-1km --kidnap --drive 80 --study-seed 2`
/// (its start and jump as the study drew them).
fn study_seed_2_run(run_index: u64, start_m: f64, jump_m: f64) -> RunOutcome {
    let scenario = named("tunnel-1km").expect("named scenario");
    let world = scenario.build_world().expect("world");
    let choice = scenario.landmark_choice().expect("landmarks");
    let map = host_sim::stored_map::build(&world, &choice).expect("map");
    let mut run = scenario.clone();
    run.seed = scenario.seed.wrapping_add(run_index);
    let spec = StudySpec {
        runs: 1,
        drive_m: 80.0,
        kidnap: true,
        seed: 2,
        ..StudySpec::default()
    };
    run_one(&run, &world, &map, &spec, start_m, jump_m)
}

/// Kidnappings of about one landmark spacing (`relocalise --scenario tunnel-1km --kidnap
/// --drive 80 --study-seed 2`, runs 17 and 52: 9.07 and 9.30 m ahead, where the landmarks
/// are spaced 9–9.5 m, not evenly). After the jump two of the four landmarks in view still
/// fitted within 5 cm at the old pose; the nearest, which had fitted a scan before, was
/// left out of the match as a misfit, and the walls say nothing along the tunnel. Those
/// scans were reported tracking 9.07 m off until the match's left-out landmarks were
/// compared with the last match's (`MatchResult::landmarks_stopped_fitting`).
#[test]
fn a_landmark_that_stops_fitting_after_a_jump_is_noticed() {
    for (run_index, start_m, jump_m) in [
        (17, 293.298_273_086_440_1, 9.073_610_305_786_133),
        (52, 653.354_578_017_917_9, 9.297_539_889_812_47),
    ] {
        let r = study_seed_2_run(run_index, start_m, jump_m);
        assert!(r.detected, "run {run_index}: {r:?}");
        assert_eq!(r.wrong_lock_scans, 0, "run {run_index}: {}", r.timeline);
        assert!(
            r.tracking_after_m.is_some(),
            "run {run_index}: {}",
            r.timeline
        );
    }
}
