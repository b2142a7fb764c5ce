//! When the GA stops (§4.2): after a maximum number of generations, or when the average
//! relative decrease of the fitness falls below a tolerance (0.1 %).
//!
//! "The fitness" is read as the best fitness of each generation (the population's mean
//! never settles: mutation draws with σ = half of each gene's range). The average is taken
//! over the last `window` generations, so one generation without progress does not stop a
//! search that is still improving; with the elites kept, the best never rises, so every
//! relative decrease is ≥ 0.

/// The stopping rule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StoppingRule {
    /// Generations at most (the paper: 100).
    pub max_generations: usize,
    /// Generations the average relative decrease is taken over.
    pub window: usize,
    /// Stop when the average relative decrease is below this (the paper: 0.001 = 0.1 %).
    pub tolerance: f64,
}

/// Why the GA stopped.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StopReason {
    /// The maximum number of generations was run.
    MaxGenerations,
    /// The average relative decrease of the best fitness fell below the tolerance.
    Converged {
        /// The average relative decrease over the window when it stopped.
        average_relative_decrease: f64,
    },
}

impl StoppingRule {
    /// The paper's settings with a window of 10 generations.
    pub const PAPER: StoppingRule = StoppingRule {
        max_generations: 100,
        window: 10,
        tolerance: 0.001,
    };

    /// Average relative decrease of `best` (best fitness per generation, first first) over
    /// the last `window` steps, or `None` while fewer than `window + 1` generations exist.
    pub fn average_relative_decrease(&self, best: &[f64]) -> Option<f64> {
        if self.window == 0 || best.len() < self.window + 1 {
            return None;
        }
        let tail = &best[best.len() - self.window - 1..];
        let sum: f64 = tail
            .windows(2)
            .map(|p| {
                if p[0] > 0.0 && p[0].is_finite() {
                    (p[0] - p[1]) / p[0]
                } else if p[1] < p[0] {
                    // From an infinite (failed) best to a finite one: full progress.
                    1.0
                } else {
                    0.0
                }
            })
            .sum();
        Some(sum / self.window as f64)
    }

    /// Whether to stop after the generations whose best fitness is `best`.
    pub fn check(&self, best: &[f64]) -> Option<StopReason> {
        if best.len() >= self.max_generations {
            return Some(StopReason::MaxGenerations);
        }
        match self.average_relative_decrease(best) {
            Some(d) if d < self.tolerance => Some(StopReason::Converged {
                average_relative_decrease: d,
            }),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stops_on_the_average_relative_decrease_over_the_window() {
        let rule = StoppingRule {
            max_generations: 100,
            window: 3,
            tolerance: 0.001,
        };
        // Too short to judge.
        assert_eq!(rule.check(&[1.0, 1.0, 1.0]), None);
        // No decrease over 3 steps: converged.
        assert_eq!(
            rule.check(&[1.0, 1.0, 1.0, 1.0]),
            Some(StopReason::Converged {
                average_relative_decrease: 0.0
            })
        );
        // One 1 % step among three: 0.33 % average, still improving.
        assert_eq!(rule.check(&[1.0, 0.99, 0.99, 0.99]), None);
        // The 1 % step leaves the window: converged.
        let d = rule.average_relative_decrease(&[1.0, 0.99, 0.99, 0.99, 0.99]);
        assert_eq!(d, Some(0.0));
        // 0.05 % per step is below 0.1 %.
        let slow: Vec<f64> = (0..5).map(|k| 0.9995f64.powi(k)).collect();
        assert!(matches!(
            rule.check(&slow),
            Some(StopReason::Converged { .. })
        ));
        // From failed (infinite) evaluations to a finite best counts as progress.
        assert_eq!(rule.check(&[f64::INFINITY, f64::INFINITY, 2.0, 2.0]), None);
    }

    #[test]
    fn stops_at_the_maximum() {
        let rule = StoppingRule {
            max_generations: 4,
            window: 10,
            tolerance: 0.001,
        };
        let falling = [8.0, 4.0, 2.0, 1.0];
        assert_eq!(rule.check(&falling[..3]), None);
        assert_eq!(rule.check(&falling), Some(StopReason::MaxGenerations));
    }
}
