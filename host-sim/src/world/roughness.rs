//! Wall roughness: a spatially correlated random offset of a wall from its ideal line.
//!
//! Shotcreted, machine-bored walls deviate from the design surface by millimetres to
//! centimetres, about the lidar's own accuracy (§4.3): enough to disturb matching, not
//! enough to localise on. Modelled as a stationary Gauss–Markov (first-order
//! autoregressive) process along the chainage, with standard deviation `sigma_m` and
//! exponential autocorrelation of length `correlation_m`.

use loc_core::rng::Pcg32;

/// Spacing of the roughness samples (and of the true wall's vertices), metres.
pub const ROUGHNESS_STEP_M: f64 = 0.1;

/// Wall offsets (metres, positive into the tunnel) sampled every [`ROUGHNESS_STEP_M`]
/// from chainage `start_m`.
#[derive(Debug, Clone)]
pub struct RoughnessProfile {
    start_m: f64,
    offsets_m: Vec<f64>,
}

impl RoughnessProfile {
    /// A profile over `[start_m, end_m]` with standard deviation `sigma_m` and correlation
    /// length `correlation_m` (both ≥ 0; σ = 0 gives a perfectly smooth wall).
    pub fn generate(
        start_m: f64,
        end_m: f64,
        sigma_m: f64,
        correlation_m: f64,
        rng: &mut Pcg32,
    ) -> Self {
        let n = (((end_m - start_m) / ROUGHNESS_STEP_M).ceil().max(0.0) as usize) + 2;
        let rho = if correlation_m > 0.0 {
            (-ROUGHNESS_STEP_M / correlation_m).exp()
        } else {
            0.0
        };
        let innovation = sigma_m * (1.0 - rho * rho).sqrt();
        let mut offsets_m = Vec::with_capacity(n);
        let mut v = sigma_m * f64::from(rng.gaussian());
        for _ in 0..n {
            offsets_m.push(v);
            v = rho * v + innovation * f64::from(rng.gaussian());
        }
        Self { start_m, offsets_m }
    }

    /// Offset at chainage `s_m`, metres (linear interpolation; held at the ends).
    pub fn at(&self, s_m: f64) -> f64 {
        let u = ((s_m - self.start_m) / ROUGHNESS_STEP_M).max(0.0);
        let i = (u.floor() as usize).min(self.offsets_m.len() - 2);
        let t = (u - i as f64).min(1.0);
        self.offsets_m[i] * (1.0 - t) + self.offsets_m[i + 1] * t
    }

    /// The raw samples (for statistics in tests and reports).
    pub fn samples(&self) -> &[f64] {
        &self.offsets_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standard_deviation_and_correlation_as_asked() {
        let mut rng = Pcg32::seeded(5);
        let p = RoughnessProfile::generate(0.0, 20_000.0, 0.01, 0.5, &mut rng);
        let x = p.samples();
        let n = x.len() as f64;
        let mean = x.iter().sum::<f64>() / n;
        let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
        assert!((var.sqrt() - 0.01).abs() < 0.001, "sigma {}", var.sqrt());
        // Lag-one correlation of an AR(1) with step 0.1 m and length 0.5 m: exp(-0.2).
        let lag1 = x
            .windows(2)
            .map(|w| (w[0] - mean) * (w[1] - mean))
            .sum::<f64>()
            / n
            / var;
        assert!((lag1 - (-0.2f64).exp()).abs() < 0.03, "lag1 {lag1}");
    }

    #[test]
    fn zero_sigma_is_smooth_and_interpolation_is_continuous() {
        let mut rng = Pcg32::seeded(1);
        let flat = RoughnessProfile::generate(-5.0, 5.0, 0.0, 1.0, &mut rng);
        assert!(flat.samples().iter().all(|v| *v == 0.0));
        let p = RoughnessProfile::generate(0.0, 10.0, 0.02, 0.3, &mut rng);
        let (a, b) = (p.at(3.0999999), p.at(3.1000001));
        assert!((a - b).abs() < 1e-6);
        assert!(p.at(-100.0).is_finite() && p.at(1e6).is_finite());
    }
}
