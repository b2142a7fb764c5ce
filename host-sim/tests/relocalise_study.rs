//! The quick variant of `host-sim relocalise` (the README's study runs 100 power-ups and 20
//! kidnappings): a few power-ups without a pose at random places on `tunnel-1km` (P1) and a
//! few kidnappings, through the simulator's closed loop. Every run must track at the right
//! place within 30 m, none may ever report tracking at a wrong one, and every kidnapping
//! must be noticed.

use host_sim::relocalise_study::{run_study, StudySpec};
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
