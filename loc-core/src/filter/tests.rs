use super::*;
use crate::geometry::{Point2, Pose2};
use nalgebra::Vector3;

fn diag(a: f32, b: f32, c: f32) -> Matrix3<f32> {
    Matrix3::from_diagonal(&Vector3::new(a, b, c))
}

/// A smooth-tunnel match at (10, 0, 0): it observes y and θ only; `hold` is the unobserved
/// direction the update must not move (none: an unprojected update).
fn smooth_tunnel_update(ekf: &mut Ekf, hold: Option<Point2>) -> UpdateReport {
    ekf.update(
        Pose2::new(10.0, 0.0, 0.0),
        &diag(0.0, 1e6, 1e7),
        hold,
        &obs(),
        &UpdateConfig::default(),
    )
    .unwrap()
}

/// The default matcher's observability criterion.
fn obs() -> crate::matching::Observability {
    crate::matching::MatchConfig::default().observability()
}

#[test]
fn rejects_bad_initialisation() {
    assert_eq!(
        Ekf::new(Pose2::new(f32::NAN, 0.0, 0.0), diag(1.0, 1.0, 1.0)),
        Err(FilterInitError::NonFinitePose)
    );
    assert_eq!(
        Ekf::new(Pose2::IDENTITY, diag(1.0, -1.0, 1.0)),
        Err(FilterInitError::InvalidCovariance)
    );
}

#[test]
fn prediction_moves_in_vehicle_frame_and_grows_covariance() {
    let noise = OdometryNoise::default();
    let mut ekf = Ekf::with_scale(
        Pose2::new(1.0, 2.0, core::f32::consts::FRAC_PI_2),
        diag(1e-4, 1e-4, 1e-6),
        noise.scale_sd,
    )
    .unwrap();
    let step = OdometryIncrement {
        dx_m: 1.0,
        dy_m: 0.0,
        dtheta_rad: 0.0,
    };
    ekf.predict(&step, &noise).unwrap();
    let p = ekf.pose();
    assert!((p.x_m - 1.0).abs() < 1e-5 && (p.y_m - 3.0).abs() < 1e-5);
    let c = ekf.covariance();
    // Heading north: along-track (y) variance grows by (3 % of 1 m)² from the unknown
    // scale alone, cross-track less.
    assert!(c[(1, 1)] > 1e-4 + 0.8 * 0.03f32.powi(2));
    assert!(c[(0, 0)] < c[(1, 1)]);
    assert!(matches!(
        ekf.predict(
            &OdometryIncrement {
                dx_m: f32::NAN,
                ..step
            },
            &noise
        ),
        Err(OdometryRejection::NonFinite)
    ));
    assert!(matches!(
        ekf.predict(&OdometryIncrement { dx_m: 1e9, ..step }, &noise),
        Err(OdometryRejection::StepTooLarge { .. })
    ));
    assert_eq!(ekf.pose(), p);
}

#[test]
fn update_leaves_unobserved_direction_to_odometry() {
    // Prior: 0.5 m along x (tunnel axis), 0.1 m across, 3°.
    let prior = Pose2::new(10.5, 0.1, 3f32.to_radians());
    let p0 = diag(0.25, 0.01, 3f32.to_radians().powi(2));
    let mut ekf = Ekf::new(prior, p0).unwrap();
    let report = smooth_tunnel_update(&mut ekf, None);
    assert_eq!(report.observed_directions, 2);
    let p = ekf.pose();
    assert!((p.x_m - 10.5).abs() < 1e-5, "{p:?}");
    assert!(p.y_m.abs() < 0.01 && p.theta_rad.abs() < 1e-3, "{p:?}");
    let c = ekf.covariance();
    assert!((c[(0, 0)] - 0.25).abs() < 1e-6, "{c}");
    assert!(c[(1, 1)] < 1e-4);
    assert!(c.cholesky().is_some());
}

#[test]
fn full_update_and_gate() {
    let mut ekf = Ekf::new(Pose2::new(0.05, 0.0, 0.0), diag(0.01, 0.01, 1e-3)).unwrap();
    let info = diag(1e6, 1e6, 1e7);
    let cfg = UpdateConfig::default();
    let r = ekf
        .update(Pose2::IDENTITY, &info, None, &obs(), &cfg)
        .unwrap();
    assert_eq!(r.observed_directions, 3);
    assert!(ekf.pose().x_m.abs() < 2e-3);
    // A match 2 m away with a tight prior fails the gate and changes nothing.
    let before = ekf;
    let e = ekf
        .update(Pose2::new(2.0, 0.0, 0.0), &info, None, &obs(), &cfg)
        .unwrap_err();
    assert!(
        matches!(e, UpdateRejection::FailedGate { dof: 3, .. }),
        "{e:?}"
    );
    assert_eq!(ekf, before);
    assert_eq!(
        ekf.update(Pose2::IDENTITY, &Matrix3::zeros(), None, &obs(), &cfg),
        Err(UpdateRejection::NothingObserved)
    );
    assert_eq!(
        ekf.update(
            Pose2::new(f32::INFINITY, 0.0, 0.0),
            &info,
            None,
            &obs(),
            &cfg
        ),
        Err(UpdateRejection::NonFinite)
    );
}

#[test]
fn covariance_stays_bounded_without_updates() {
    let mut ekf = Ekf::new(Pose2::IDENTITY, diag(1.0, 1.0, 1.0)).unwrap();
    let noise = OdometryNoise::default();
    for _ in 0..100_000 {
        let _ = ekf.predict(
            &OdometryIncrement {
                dx_m: 5.0,
                dy_m: 0.0,
                dtheta_rad: 1.0,
            },
            &noise,
        );
    }
    let c = ekf.covariance();
    assert!(c.iter().all(|v| v.is_finite()));
    assert!(c.diagonal().max() <= MAX_VARIANCE * 1.0001);
    assert!(ekf.pose().is_finite());
}

#[test]
fn projected_gain_holds_along_position_despite_correlation() {
    // A prior correlated between along (x) and heading, as after driving a bend.
    let p0 = Matrix3::new(0.25, 0.0, 0.01, 0.0, 0.01, 0.0, 0.01, 0.0, 0.003);
    let mut ekf = Ekf::new(Pose2::new(10.5, 0.1, 0.05), p0).unwrap();
    let mut free = ekf;
    smooth_tunnel_update(&mut free, None);
    // Unprojected, the correlation drags x.
    assert!((free.pose().x_m - 10.5).abs() > 0.05, "{:?}", free.pose());
    smooth_tunnel_update(&mut ekf, Some(Point2::new(1.0, 0.0)));
    assert!((ekf.pose().x_m - 10.5).abs() < 1e-5, "{:?}", ekf.pose());
    assert!((ekf.covariance()[(0, 0)] - 0.25).abs() < 1e-5);
    assert!(ekf.pose().y_m.abs() < 0.01);
    assert!(ekf.covariance().cholesky().is_some());
}

/// A direction observed weakly (a curve seen far ahead fixing the position along the
/// tunnel to 0.2 m) is the same fix scan after scan: the filter takes it while it improves
/// on what the filter knows, and otherwise holds it as it would an unobserved one.
#[test]
fn a_weak_direction_is_taken_only_where_the_match_knows_it_better() {
    let weak = diag(25.0, 1e6, 1e7);
    assert!(25.0 < obs().weak_below_per_m2 && 25.0 > obs().min_information_per_m2);
    let cfg = UpdateConfig::default();
    let mut ekf = Ekf::new(Pose2::new(10.5, 0.01, 0.0), diag(1.0, 0.01, 1e-4)).unwrap();
    // The filter knows x to 1 m, the match to 0.2 m: taken.
    let r = ekf
        .update(Pose2::new(10.0, 0.0, 0.0), &weak, None, &obs(), &cfg)
        .unwrap();
    assert_eq!(r.observed_directions, 3);
    let var_x = ekf.covariance()[(0, 0)];
    assert!((ekf.pose().x_m - 10.02).abs() < 0.01, "{:?}", ekf.pose());
    assert!((var_x - 0.04 / 1.04).abs() < 2e-3, "{var_x}");
    // The same fix again (it shares its errors with the first): held, x and its variance
    // untouched, the lateral position and heading still updated.
    let before = ekf.pose();
    let r = ekf
        .update(Pose2::new(10.1, 0.0, 0.0), &weak, None, &obs(), &cfg)
        .unwrap();
    assert_eq!(r.observed_directions, 2);
    assert!(
        (ekf.pose().x_m - before.x_m).abs() < 1e-5,
        "{:?}",
        ekf.pose()
    );
    assert!((ekf.covariance()[(0, 0)] - var_x).abs() < 1e-6);
    // A fix four times as good as the filter's knowledge is taken.
    let better = diag(100.0 / var_x, 1e6, 1e7);
    let r = ekf
        .update(Pose2::new(10.0, 0.0, 0.0), &better, None, &obs(), &cfg)
        .unwrap();
    assert_eq!(r.observed_directions, 3);
    assert!(ekf.covariance()[(0, 0)] < 0.9 * var_x);
    assert!(ekf.covariance().cholesky().is_some());
}

/// Full-pose fixes every `step_m` of a straight drive whose odometry reads `odometry_scale`
/// times the truth; returns the filter and the true pose at the end.
fn drive_with_fixes(odometry_scale: f32, metres: usize, step_m: f32) -> (Ekf, Pose2) {
    let noise = OdometryNoise::default();
    let mut ekf = Ekf::with_scale(Pose2::IDENTITY, diag(1e-6, 1e-6, 1e-8), noise.scale_sd).unwrap();
    let mut truth = Pose2::IDENTITY;
    let fix = diag(1.0 / 25e-6, 1.0 / 25e-6, 1.0 / 1e-8);
    let steps = (metres as f32 / step_m) as usize;
    for _ in 0..steps {
        truth = Pose2::new(truth.x_m + step_m, 0.0, 0.0);
        let inc = OdometryIncrement {
            dx_m: step_m * odometry_scale,
            dy_m: 0.0,
            dtheta_rad: 0.0,
        };
        ekf.predict(&inc, &noise).unwrap();
        ekf.update(truth, &fix, None, &obs(), &UpdateConfig::default())
            .unwrap();
    }
    (ekf, truth)
}

#[test]
fn the_odometry_scale_is_learnt_from_position_fixes() {
    // Odometry 2 % short: the true translation is 1/0.98 = 1.0204 × odometry's.
    let (mut ekf, truth) = drive_with_fixes(0.98, 30, 0.4);
    let expected = 1.0 / 0.98 - 1.0;
    assert!(
        (ekf.scale() - expected).abs() < 3.0 * ekf.scale_sd() && ekf.scale_sd() < 0.005,
        "scale {} ± {}",
        ekf.scale(),
        ekf.scale_sd()
    );
    // Ten metres on odometry alone now land within centimetres (2 % would be 20 cm), and
    // the covariance says so.
    let noise = OdometryNoise::default();
    for _ in 0..25 {
        let inc = OdometryIncrement {
            dx_m: 0.4 * 0.98,
            dy_m: 0.0,
            dtheta_rad: 0.0,
        };
        ekf.predict(&inc, &noise).unwrap();
    }
    let err = ekf.pose().x_m - (truth.x_m + 10.0);
    let sd = ekf.covariance()[(0, 0)].sqrt();
    assert!(
        err.abs() < 0.05 && err.abs() < 3.0 * sd,
        "error {err} m, σ {sd} m"
    );
}

#[test]
fn motion_that_is_not_odometry_is_not_scaled() {
    let (mut ekf, _) = drive_with_fixes(0.95, 30, 0.4);
    assert!(ekf.scale() > 0.04, "{}", ekf.scale());
    let step = OdometryIncrement {
        dx_m: 1.0,
        dy_m: 0.0,
        dtheta_rad: 0.0,
    };
    let x0 = ekf.pose().x_m;
    let q = diag(1e-4, 1e-4, 1e-6);
    ekf.predict_motion(&step, &q, &OdometryNoise::default())
        .unwrap();
    assert!((ekf.pose().x_m - x0 - 1.0).abs() < 1e-5);
    let x1 = ekf.pose().x_m;
    ekf.predict(&step, &OdometryNoise::default()).unwrap();
    assert!((ekf.pose().x_m - x1 - (1.0 + ekf.scale())).abs() < 1e-5);
}

#[test]
fn a_fix_along_moves_the_position_and_the_scale_not_the_heading() {
    // A prior correlated between along (x) and heading, as after driving a bend, with the
    // odometry's scale correlated with x (metres driven on it).
    let p0 = Matrix3::new(0.04, 0.0, 0.002, 0.0, 1e-4, 0.0, 0.002, 0.0, 1e-3);
    let mut ekf = Ekf::with_scale(Pose2::new(10.0, 0.1, 0.05), p0, 0.02).unwrap();
    for _ in 0..10 {
        let inc = OdometryIncrement {
            dx_m: 1.0,
            dy_m: 0.0,
            dtheta_rad: 0.0,
        };
        ekf.predict(&inc, &OdometryNoise::default()).unwrap();
    }
    let before = ekf;
    // The wall's end says the vehicle is 0.3 m further along x than predicted, ±5 cm.
    let report = ekf
        .update_position_along(
            Point2::new(1.0, 0.0),
            0.3,
            0.05 * 0.05,
            GateProbability::P999,
        )
        .unwrap();
    assert_eq!(report.observed_directions, 1);
    let dx = ekf.pose().x_m - before.pose().x_m;
    assert!(dx > 0.2 && dx < 0.3, "moved {dx}");
    assert_eq!(ekf.pose().theta_rad, before.pose().theta_rad);
    assert!(
        ekf.scale() > before.scale(),
        "the odometry read short: {}",
        ekf.scale()
    );
    assert!(ekf.covariance()[(0, 0)] < 0.05 * 0.05);
    assert!(ekf.covariance().cholesky().is_some());
    // Beyond the gate, or nonsense: rejected, the state unchanged.
    let mut gated = before;
    assert!(matches!(
        gated.update_position_along(Point2::new(1.0, 0.0), 30.0, 1e-4, GateProbability::P999),
        Err(UpdateRejection::FailedGate { dof: 1, .. })
    ));
    assert_eq!(gated, before);
    for (d, nu, var) in [
        (Point2::new(f32::NAN, 0.0), 0.1, 1e-3),
        (Point2::new(0.0, 0.0), 0.1, 1e-3),
        (Point2::new(1.0, 0.0), f32::INFINITY, 1e-3),
        (Point2::new(1.0, 0.0), 0.1, 0.0),
        (Point2::new(1.0, 0.0), 0.1, f32::NAN),
    ] {
        let mut bad = before;
        assert_eq!(
            bad.update_position_along(d, nu, var, GateProbability::P999),
            Err(UpdateRejection::NonFinite)
        );
        assert_eq!(bad, before);
    }
}

#[test]
fn scans_share_an_error_by_how_far_apart_they_are() {
    // At rest, or with no correlation length: the cap, or nothing shared.
    assert_eq!(shared_error_scans(0.0, 0.8, 64.0), 64.0);
    assert_eq!(shared_error_scans(0.1, 0.0, 64.0), 1.0);
    assert_eq!(shared_error_scans(f32::NAN, 0.8, 64.0), 1.0);
    assert_eq!(shared_error_scans(0.0, 0.8, 0.5), 1.0);
    // coth(d / 2L): 4 cm apart on walls correlated over 1 m share an error 50 times over…
    let near = shared_error_scans(0.04, 1.0, 1000.0);
    assert!(
        (near - 1.0 / libm::tanhf(0.02)).abs() < 0.05 * near,
        "{near}"
    );
    // …scans metres apart hardly at all.
    let far = shared_error_scans(5.0, 1.0, 64.0);
    assert!((1.0..1.02).contains(&far), "{far}");
}

/// A vehicle at rest matched again and again: the walls' share of the matches' error
/// across the tunnel is the same in every scan, so the filter's variance across does not
/// fall as if each match were new; along (here x) and heading it is the update it was.
#[test]
fn matches_sharing_their_error_do_not_average_it_away_across() {
    let start = diag(1e-2, 1e-2, 1e-4);
    let info = diag(1.0 / 9e-6, 1.0 / 9e-6, 1.0 / 1e-8); // 3 mm, 0.1 mrad
    let run = |shared: f32| {
        let mut ekf = Ekf::new(Pose2::IDENTITY, start).unwrap();
        for _ in 0..50 {
            ekf.update_shared(
                Pose2::IDENTITY,
                &info,
                None,
                &obs(),
                &UpdateConfig::default(),
                shared,
            )
            .unwrap();
        }
        ekf.covariance()
    };
    let (independent, shared) = (run(1.0), run(64.0));
    assert!(independent[(1, 1)].sqrt() < 1.0e-3, "{independent}");
    assert!(shared[(1, 1)].sqrt() > 3.0e-3, "{shared}");
    assert!((shared[(0, 0)] - independent[(0, 0)]).abs() < 1e-3 * independent[(0, 0)]);
    assert!((shared[(2, 2)] - independent[(2, 2)]).abs() < 1e-2 * independent[(2, 2)]);
    // Counted once, the update is `update`'s.
    let mut a = Ekf::new(Pose2::IDENTITY, start).unwrap();
    let mut b = a;
    let m = Pose2::new(0.001, 0.002, 0.0001);
    a.update(m, &info, None, &obs(), &UpdateConfig::default())
        .unwrap();
    b.update_shared(m, &info, None, &obs(), &UpdateConfig::default(), 1.0)
        .unwrap();
    assert_eq!(a, b);
}
