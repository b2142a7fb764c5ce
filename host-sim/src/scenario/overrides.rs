//! Command-line adjustments of a scenario (`--landmarks`, `--genes`, `--matcher`, `--seed`,
//! …), applied on top of a named scenario or a file and validated like the file itself.

use super::{MatcherChoice, Scenario, ScenarioError};
use crate::landmarks::LandmarkChoice;
use crate::lidar::ScanRate;

/// Values given on the command line; `None` keeps the scenario's own.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Overrides {
    /// Landmark model: none, p1…p4, f1…f4.
    pub landmarks: Option<String>,
    /// Genes as text `W,H,D[,h1..h6]`.
    pub genes: Option<String>,
    /// Matcher.
    pub matcher: Option<MatcherChoice>,
    /// Seed.
    pub seed: Option<u64>,
    /// Every n-th landmark missing.
    pub missing_every: Option<u32>,
    /// Fraction of landmarks missing at random.
    pub missing_fraction: Option<f64>,
    /// Fraction of landmarks damaged.
    pub damage_fraction: Option<f64>,
    /// σ of the landmarks' installation error along the wall, metres.
    pub install_sd_m: Option<f64>,
    /// Landmarks moved after the map was made (added to the scenario's).
    pub moved: Vec<super::MovedLandmark>,
    /// Fraction of landmarks moved at random after the map was made.
    pub moved_fraction: Option<f64>,
    /// Give the vehicle a yaw-rate gyro (the default tactical-grade one).
    pub gyro: bool,
    /// A chainage stretch `[from_m, to_m]` without landmarks in the true tunnel.
    pub missing_stretch_m: Option<[f64; 2]>,
    /// Length of the drive from its start, metres.
    pub drive_length_m: Option<f64>,
    /// Cruise speed, m/s.
    pub speed_mps: Option<f64>,
    /// LMS511 rate.
    pub rate: Option<ScanRate>,
    /// Model the scanner's sweep (`lidar.sweep`): each beam from where the vehicle was
    /// when the mirror passed it, and the localiser de-skews.
    pub sweep: bool,
    /// Range noise σ, metres.
    pub range_noise_m: Option<f64>,
    /// Share of the beams whose first echo is dust or spray (`lidar.dust.fraction`).
    pub dust_fraction: Option<f64>,
    /// People walking through the tunnel (`traffic.people`).
    pub people: Option<u32>,
    /// Vehicles driving through it (`traffic.vehicles`).
    pub vehicles: Option<u32>,
    /// Which echo of each beam the localiser takes (`localizer.echo`).
    pub echo: Option<super::EchoChoice>,
}

impl Overrides {
    /// Applies the overrides and validates the result.
    pub fn apply(&self, s: &mut Scenario) -> Result<(), ScenarioError> {
        if let Some(m) = &self.landmarks {
            s.landmarks.model = m.to_ascii_lowercase();
            // Genes of another model do not carry over.
            s.landmarks.genes = None;
        }
        if let Some(g) = &self.genes {
            s.landmarks.genes = Some(LandmarkChoice::parse_genes(g)?);
        }
        if let Some(m) = self.matcher {
            s.localizer.matcher = m;
        }
        if let Some(seed) = self.seed {
            s.seed = seed;
        }
        if let Some(n) = self.missing_every {
            s.landmarks.missing_every = Some(n);
            s.landmarks.missing_fraction = None;
        }
        if let Some(f) = self.missing_fraction {
            s.landmarks.missing_fraction = Some(f);
            s.landmarks.missing_every = None;
        }
        if let Some(f) = self.damage_fraction {
            s.landmarks.damage_fraction = f;
        }
        if let Some(sd) = self.install_sd_m {
            s.landmarks.install_sd_m = sd;
        }
        s.landmarks.moved.extend_from_slice(&self.moved);
        if let Some(f) = self.moved_fraction {
            s.landmarks.moved_fraction = f;
        }
        if self.sweep {
            s.lidar.sweep = true;
        }
        if self.gyro && s.odometry.gyro.is_none() {
            s.odometry.gyro = Some(crate::vehicle::odometry::GyroSpec::default());
        }
        if let Some(st) = self.missing_stretch_m {
            s.landmarks.missing_stretch_m = Some(st);
        }
        if let Some(len) = self.drive_length_m {
            if !(len.is_finite() && len > 0.0) {
                return Err(ScenarioError::Invalid {
                    key: "drive.end_m",
                    reason: format!("--length must be a positive number of metres, not {len}"),
                });
            }
            s.drive.end_m = s.drive.start_m + len;
        }
        if let Some(v) = self.speed_mps {
            s.drive.cruise_speed_mps = v;
        }
        if let Some(r) = self.rate {
            s.lidar.rate = r;
        }
        if let Some(n) = self.range_noise_m {
            s.lidar.range_noise_m = n;
        }
        if let Some(f) = self.dust_fraction {
            s.lidar.dust.fraction = f;
        }
        if let Some(n) = self.people {
            s.traffic.people = n;
        }
        if let Some(n) = self.vehicles {
            s.traffic.vehicles = n;
        }
        if let Some(e) = self.echo {
            s.localizer.echo = e;
        }
        s.validate()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::named::named;

    #[test]
    fn overrides_apply_and_are_validated() {
        let mut s = named("tunnel-1km").unwrap();
        let o = Overrides {
            landmarks: Some("F4".into()),
            genes: Some("1.0,0.3,7.5,0.5,1,0,1,0.5,0".into()),
            matcher: Some(MatcherChoice::Icp),
            seed: Some(9),
            missing_every: Some(5),
            drive_length_m: Some(300.0),
            ..Overrides::default()
        };
        o.apply(&mut s).unwrap();
        assert_eq!(s.landmarks.model, "f4");
        assert_eq!(s.landmarks.genes.as_ref().unwrap().len(), 9);
        assert_eq!(s.localizer.matcher, MatcherChoice::Icp);
        assert_eq!(s.seed, 9);
        assert_eq!(s.drive.end_m, s.drive.start_m + 300.0);
        let bad = Overrides {
            genes: Some("1,2".into()),
            ..Overrides::default()
        };
        assert!(bad.apply(&mut named("paper-10m").unwrap()).is_err());
        let bad = Overrides {
            missing_fraction: Some(1.5),
            ..Overrides::default()
        };
        let e = bad.apply(&mut named("paper-10m").unwrap()).unwrap_err();
        assert!(e.to_string().contains("landmarks.missing_fraction"), "{e}");
        let bad = Overrides {
            dust_fraction: Some(-0.1),
            ..Overrides::default()
        };
        let e = bad.apply(&mut named("paper-10m").unwrap()).unwrap_err();
        assert!(e.to_string().contains("lidar.dust.fraction"), "{e}");
    }

    #[test]
    fn dust_and_traffic_flags_reach_the_scenario_and_its_file() {
        let mut s = named("paper-10m").unwrap();
        let o = Overrides {
            dust_fraction: Some(0.2),
            people: Some(3),
            vehicles: Some(1),
            ..Overrides::default()
        };
        o.apply(&mut s).unwrap();
        assert_eq!(s.lidar.dust.fraction, 0.2);
        assert_eq!((s.traffic.people, s.traffic.vehicles), (3, 1));
        // The scenario file written beside a run reruns it with the same dust and traffic.
        let again = Scenario::from_toml(&s.to_toml()).unwrap();
        assert_eq!(again, s);
        // A clear scenario's file has neither section.
        let clear = named("paper-10m").unwrap().to_toml();
        assert!(
            !clear.contains("dust") && !clear.contains("traffic"),
            "{clear}"
        );
    }
}
