//! Dust and spray in front of the LMS511: clouds that return an early echo on some beams,
//! the wall on the next echo (or nothing behind the densest parts: blocked).
//!
//! Real dust is clumpy: a cloud covers a run of neighbouring beams and stays for a while.
//! Each beam carries a value of a Gaussian field that is correlated across beams (a
//! Gauss–Markov process over the beam angle, `correlation_deg`) and over time (each scan's
//! field relaxes towards a fresh draw with `correlation_s`). Its marginal is N(0, 1) at
//! every beam and scan, so a beam is in a cloud when its value exceeds `Φ⁻¹(1 − fraction)`:
//! on average exactly `fraction` of the beams, in patches. The densest part of a cloud
//! (value above `Φ⁻¹(1 − fraction · blocked_fraction)`) lets nothing through: the cloud is
//! the beam's only echo. Where a beam meets its cloud is a second field of the same kind,
//! mapped to a uniform draw over `range_m` (clipped to before the surface the beam hits), so
//! the beams of one cloud see it at similar ranges.

use loc_core::rng::Pcg32;
use serde::{Deserialize, Serialize};

/// How much dust or spray the scanner looks through (scenario `[lidar.dust]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DustSpec {
    /// Share of the beams whose first echo is a cloud, 0–1 (0.2: one beam in five).
    pub fraction: f64,
    /// Where a beam meets its cloud, `[min_m, max_m]` from the scanner, metres; never
    /// closer than [`SEPARATION_M`] before the surface behind it.
    pub range_m: [f64; 2],
    /// Share of the clouded beams that the cloud blocks (no echo behind it), 0–1.
    pub blocked_fraction: f64,
    /// Angular correlation of the clouds, degrees (how wide a patch is).
    pub correlation_deg: f64,
    /// Correlation time of the clouds, seconds (how long a patch stays).
    pub correlation_s: f64,
}

impl Default for DustSpec {
    /// No dust; when a fraction is set: clouds 0.5–20 m out, 5 % of them blocking, patches
    /// of a few degrees that last about half a second.
    fn default() -> Self {
        Self {
            fraction: 0.0,
            range_m: [0.5, 20.0],
            blocked_fraction: 0.05,
            correlation_deg: 3.0,
            correlation_s: 0.5,
        }
    }
}

impl DustSpec {
    /// No dust, every setting at its default (what a scenario file leaves out).
    pub fn is_clear(&self) -> bool {
        *self == DustSpec::default()
    }

    /// Why the spec cannot be used (the dotted scenario key and the reason), or `None`.
    pub fn problem(&self) -> Option<(&'static str, &'static str)> {
        let [lo, hi] = self.range_m;
        if !(self.fraction.is_finite() && (0.0..=1.0).contains(&self.fraction)) {
            Some(("lidar.dust.fraction", "must lie in [0, 1]"))
        } else if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi) {
            Some((
                "lidar.dust.range_m",
                "must be [min_m, max_m] with 0 < min_m <= max_m",
            ))
        } else if !(self.blocked_fraction.is_finite()
            && (0.0..=1.0).contains(&self.blocked_fraction))
        {
            Some(("lidar.dust.blocked_fraction", "must lie in [0, 1]"))
        } else if !(self.correlation_deg.is_finite() && self.correlation_deg > 0.0) {
            Some(("lidar.dust.correlation_deg", "must be a positive angle"))
        } else if !(self.correlation_s.is_finite() && self.correlation_s > 0.0) {
            Some(("lidar.dust.correlation_s", "must be a positive time"))
        } else {
            None
        }
    }
}

/// A cloud's echo is at least this far before the surface behind it, metres (closer, the
/// scanner would not separate the two echoes).
pub const SEPARATION_M: f64 = 0.3;

/// What a beam meets in the dust.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cloud {
    /// Where a beam meets it, as a share of the way from `range_m[0]` to the nearer of
    /// `range_m[1]` and the surface behind it, 0–1.
    pub depth: f64,
    /// Nothing behind it reaches the scanner.
    pub blocked: bool,
}

impl Cloud {
    /// Range of the cloud's echo on a beam whose first surface is `surface_m` away (`None`:
    /// nothing within `max_range_m`), or `None` where the cloud cannot lie before it.
    pub fn range_m(
        &self,
        spec: &DustSpec,
        surface_m: Option<f64>,
        max_range_m: f64,
    ) -> Option<f64> {
        let [lo, hi] = spec.range_m;
        let far = surface_m.map_or(max_range_m, |s| s - SEPARATION_M).min(hi);
        (far >= lo).then_some(lo + self.depth * (far - lo))
    }
}

/// The clouds' state from scan to scan.
#[derive(Debug, Clone)]
pub struct DustField {
    spec: DustSpec,
    rng: Pcg32,
    /// Per beam: the cloud field (N(0, 1) marginal) and the range field.
    density: Vec<f64>,
    depth: Vec<f64>,
    last_t_s: Option<f64>,
    cloud_above: f64,
    blocked_above: f64,
}

impl DustField {
    /// Clouds as `spec` says, with their own random stream.
    pub fn new(spec: DustSpec, seed: u64) -> Self {
        Self {
            spec,
            rng: Pcg32::new(seed, 0xd057),
            density: Vec::new(),
            depth: Vec::new(),
            last_t_s: None,
            cloud_above: normal_quantile(1.0 - spec.fraction),
            blocked_above: normal_quantile(1.0 - spec.fraction * spec.blocked_fraction),
        }
    }

    /// The spec.
    pub fn spec(&self) -> &DustSpec {
        &self.spec
    }

    /// Moves the clouds on to time `t_s` for a scan of `beams` beams `step_deg` apart.
    pub fn advance(&mut self, t_s: f64, beams: usize, step_deg: f64) {
        let rho_beam = (-step_deg.abs() / self.spec.correlation_deg).exp();
        let fresh = self.density.len() != beams || self.last_t_s.is_none();
        let rho_time = match self.last_t_s {
            Some(t0) if !fresh => (-(t_s - t0).abs() / self.spec.correlation_s).exp(),
            _ => 0.0,
        };
        self.last_t_s = Some(t_s);
        self.density.resize(beams, 0.0);
        self.depth.resize(beams, 0.0);
        for field in [&mut self.density, &mut self.depth] {
            let mut innovation = f64::from(self.rng.gaussian());
            let keep = (1.0 - rho_time * rho_time).sqrt();
            let new_part = (1.0 - rho_beam * rho_beam).sqrt();
            for v in field.iter_mut() {
                innovation = rho_beam * innovation + new_part * f64::from(self.rng.gaussian());
                *v = rho_time * *v + keep * innovation;
            }
        }
    }

    /// The cloud on beam `index` in the current scan, if any.
    pub fn cloud(&self, index: usize) -> Option<Cloud> {
        if self.spec.fraction <= 0.0 {
            return None;
        }
        let v = *self.density.get(index)?;
        (v > self.cloud_above).then(|| Cloud {
            depth: normal_cdf(*self.depth.get(index).unwrap_or(&0.0)),
            blocked: v > self.blocked_above,
        })
    }
}

/// Φ(x), the standard normal distribution function (Abramowitz & Stegun 7.1.26, error
/// below 1.5e-7).
pub fn normal_cdf(x: f64) -> f64 {
    let z = x.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * z);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erf = 1.0 - poly * (-z * z).exp();
    if x >= 0.0 {
        0.5 * (1.0 + erf)
    } else {
        0.5 * (1.0 - erf)
    }
}

/// Φ⁻¹(p) by bisection on [`normal_cdf`]: +∞ for p ≥ 1 (nothing exceeds it), −∞ for p ≤ 0.
pub fn normal_quantile(p: f64) -> f64 {
    if p.is_nan() || p >= 1.0 {
        return f64::INFINITY;
    }
    if p <= 0.0 {
        return f64::NEG_INFINITY;
    }
    let (mut lo, mut hi) = (-40.0f64, 40.0f64);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if normal_cdf(mid) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn field(fraction: f64) -> DustField {
        DustField::new(
            DustSpec {
                fraction,
                ..DustSpec::default()
            },
            3,
        )
    }

    #[test]
    fn quantile_inverts_the_distribution_function() {
        for p in [0.01, 0.2, 0.5, 0.8, 0.95, 0.999] {
            assert!((normal_cdf(normal_quantile(p)) - p).abs() < 1e-6, "{p}");
        }
        assert!((normal_quantile(0.8) - 0.841_621).abs() < 1e-4);
        assert_eq!(normal_quantile(1.0), f64::INFINITY);
        assert_eq!(normal_quantile(0.0), f64::NEG_INFINITY);
    }

    #[test]
    fn the_share_of_clouded_beams_is_the_fraction_and_comes_in_patches() {
        let mut f = field(0.2);
        let (mut clouded, mut blocked, mut beams, mut runs) = (0usize, 0usize, 0usize, 0usize);
        let mut kept = 0usize;
        let mut previous: Vec<bool> = Vec::new();
        for k in 0..2000 {
            f.advance(f64::from(k) * 0.04, 1141, 1.0 / 6.0);
            let now: Vec<bool> = (0..1141).map(|i| f.cloud(i).is_some()).collect();
            clouded += now.iter().filter(|&&c| c).count();
            blocked += (0..1141)
                .filter(|&i| f.cloud(i).is_some_and(|c| c.blocked))
                .count();
            runs += now.windows(2).filter(|w| w[1] && !w[0]).count();
            if previous.len() == now.len() {
                kept += now
                    .iter()
                    .zip(&previous)
                    .filter(|(a, b)| **a && **b)
                    .count();
            }
            beams += now.len();
            previous = now;
        }
        let share = clouded as f64 / beams as f64;
        assert!((share - 0.2).abs() < 0.02, "share {share}");
        let blocked_share = blocked as f64 / clouded as f64;
        assert!(
            (blocked_share - 0.05).abs() < 0.02,
            "blocked {blocked_share}"
        );
        // Patches: clouded beams come in runs of many beams, not one by one (white noise
        // at 20 % would give runs of 1.25 beams on average).
        let mean_run = clouded as f64 / runs as f64;
        assert!(mean_run > 5.0, "mean run {mean_run} beams");
        // And they stay: most clouded beams are clouded in the next scan too.
        assert!(
            kept as f64 / clouded as f64 > 0.6,
            "kept {kept} of {clouded}"
        );
    }

    #[test]
    fn no_dust_without_a_fraction_and_clouds_lie_before_the_surface() {
        let mut f = field(0.0);
        f.advance(0.0, 100, 1.0);
        assert!((0..100).all(|i| f.cloud(i).is_none()));
        let spec = DustSpec::default();
        let c = Cloud {
            depth: 1.0,
            blocked: false,
        };
        assert_eq!(c.range_m(&spec, Some(3.0), 80.0), Some(3.0 - SEPARATION_M));
        assert_eq!(c.range_m(&spec, None, 80.0), Some(20.0));
        assert_eq!(
            c.range_m(&spec, Some(0.6), 80.0),
            None,
            "no room before the wall"
        );
        let near = Cloud { depth: 0.0, ..c };
        assert_eq!(near.range_m(&spec, Some(10.0), 80.0), Some(0.5));
    }

    #[test]
    fn bad_specs_name_their_key() {
        let bad = DustSpec {
            fraction: 1.5,
            ..DustSpec::default()
        };
        assert_eq!(bad.problem().unwrap().0, "lidar.dust.fraction");
        let bad = DustSpec {
            range_m: [5.0, 1.0],
            ..DustSpec::default()
        };
        assert_eq!(bad.problem().unwrap().0, "lidar.dust.range_m");
        assert!(DustSpec::default().problem().is_none());
    }
}
