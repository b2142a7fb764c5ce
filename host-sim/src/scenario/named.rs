//! The named scenarios of the command line.
//!
//! - `paper-10m`: the paper's simulated tunnel (§5.1): a straight 10 m drive at walking
//!   pace through a 4 m wide, nearly smooth tunnel, P1 landmarks at the optimum spacing on
//!   both walls. The tunnel continues 10 m past the end of the drive so landmarks ahead
//!   stay in view, as they would in a longer tunnel.
//! - `tunnel-1km`: a curved, rough kilometre (straights, left and right curves of 250–400 m
//!   radius, an S-bend; 5 m wide, 10 mm wall roughness), driven at 3 m/s.
//! - `demo-200m`: the first 200 m of `tunnel-1km`, for the quick demo.

use super::{LandmarkConfig, LocalizerConfig, PieceConfig, Scenario, ScenarioError, TunnelConfig};
use crate::lidar::LidarSpec;
use crate::vehicle::odometry::OdometrySpec;
use crate::vehicle::path_follower::DriveSpec;
use crate::vehicle::skid_steer::SkidSteerSpec;

/// Names accepted by [`named`].
pub const NAMES: [&str; 3] = ["paper-10m", "tunnel-1km", "demo-200m"];

fn straight(length_m: f64) -> PieceConfig {
    PieceConfig {
        length_m,
        radius_m: None,
    }
}

fn arc(length_m: f64, radius_m: f64) -> PieceConfig {
    PieceConfig {
        length_m,
        radius_m: Some(radius_m),
    }
}

/// The curved kilometre's centre line: 1000 m in total.
pub fn kilometre_pieces() -> Vec<PieceConfig> {
    vec![
        straight(120.0),
        arc(180.0, 400.0),
        straight(100.0),
        arc(150.0, -250.0),
        straight(80.0),
        // S-bend.
        arc(90.0, 300.0),
        arc(90.0, -300.0),
        straight(190.0),
    ]
}

/// The scenario called `name`.
pub fn named(name: &str) -> Result<Scenario, ScenarioError> {
    let base = Scenario {
        name: name.to_string(),
        seed: 1,
        tunnel: TunnelConfig {
            width_m: 5.0,
            roughness_sigma_m: 0.01,
            roughness_correlation_m: 1.0,
            pieces: kilometre_pieces(),
            csv: None,
        },
        landmarks: LandmarkConfig::default(),
        lidar: LidarSpec::default(),
        vehicle: SkidSteerSpec::default(),
        odometry: OdometrySpec::default(),
        drive: DriveSpec {
            start_m: 2.0,
            end_m: 985.0,
            ..DriveSpec::default()
        },
        localizer: LocalizerConfig::default(),
        traffic: crate::traffic::TrafficSpec::default(),
        base_dir: Default::default(),
    };
    match name {
        "tunnel-1km" => Ok(base),
        "demo-200m" => Ok(Scenario {
            drive: DriveSpec {
                end_m: 202.0,
                ..base.drive
            },
            ..base
        }),
        "paper-10m" => Ok(Scenario {
            tunnel: TunnelConfig {
                width_m: 4.0,
                roughness_sigma_m: 0.005,
                roughness_correlation_m: 0.5,
                pieces: vec![straight(21.0)],
                csv: None,
            },
            landmarks: LandmarkConfig {
                first_m: 1.0,
                ..LandmarkConfig::default()
            },
            drive: DriveSpec {
                cruise_speed_mps: 1.0,
                start_m: 0.0,
                end_m: 10.0,
                ..DriveSpec::default()
            },
            ..base
        }),
        other => Err(ScenarioError::UnknownName(other.to_string())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_is_valid_and_the_kilometre_is_a_kilometre() {
        for n in NAMES {
            named(n).unwrap().validate().unwrap();
        }
        let len: f64 = kilometre_pieces().iter().map(|p| p.length_m).sum();
        assert!((len - 1000.0).abs() < 1e-9);
        assert!(named("nope").is_err());
    }
}
