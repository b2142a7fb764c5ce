//! The survey's joint estimate: every keyframe pose and every landmark pose of the drive in
//! one sparse nonlinear least-squares problem ([`Problem`]), solved by one of three back ends
//! ([`Solver`]: `factrs`, `apex-solver`, or the survey's own Levenberg–Marquardt on
//! nalgebra-sparse), and each landmark's marginal covariance from the same linearisation.
//!
//! Factors (all SE(2) between or prior factors; covariances in the tangent order
//! `(θ rad, x m, y m)`, right perturbation — factrs' order, which every back end reports in):
//! - keyframe → next keyframe: the odometry, with its across-tunnel offset and heading change
//!   replaced by the walls' where both keyframes see a wall ([`super::keyframes`]), with a
//!   Huber kernel;
//! - keyframe → landmark: one landmark fitted in one scan ([`super::landmark_fit`]), with a
//!   Huber kernel (a fit spoilt by a person beside the landmark must not bend the map);
//! - landmark priors: the design's marks with the installation tolerance, anchors surveyed
//!   into mine coordinates, or the first landmark held where it was first seen;
//! - a loose prior ([`LOOSE_PRIOR_SD`]) on the first keyframe.
//!
//! Every back end minimises the same cost, `Σ ρ(d²)` with `d² = rᵀ Σ⁻¹ r` the squared
//! Mahalanobis length of a factor's residual, `ρ(d²) = d²/2` for priors and the Huber loss
//! ([`HUBER_K`]) for the between factors, and reports the marginals of `H = Jᵀ W J` at the
//! solution (`W` the Huber IRLS weights). One difference: factrs 0.3's SE(2) logarithm takes
//! its small-angle branch (`V(θ) = I`) for every negative angle (`theta < 1e-5`, not
//! `|theta|`), so its residual's translation differs from the exact one by `O(θ·|t|)`. On
//! the kilometre that moves its landmarks from apex-solver's and the own solver's (which
//! agree to 0.1 µm) by 0.4 mm median, 1.3 mm at most; the own solver with factrs' logarithm
//! reproduces factrs' cost to 6 digits.

use std::fmt;
use std::str::FromStr;

use nalgebra::Matrix3;
use serde::Serialize;

#[cfg(feature = "solver-apex")]
use super::solver_apex;
use super::{solver_factrs, solver_own};
use crate::vehicle::SimPose;

/// A relative pose measured between two variables: `to` in `from`'s frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Relative {
    /// Index of the keyframe it is measured from.
    pub from: usize,
    /// Index of the keyframe (for steps) or landmark (for observations) measured.
    pub to: usize,
    /// The measurement.
    pub z: SimPose,
    /// Its covariance, `(θ, x, y)` right perturbation.
    pub covariance: Matrix3<f64>,
}

/// What a landmark is tied to besides the scans.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prior {
    /// Landmark index.
    pub landmark: usize,
    /// Its pose, world frame.
    pub pose: SimPose,
    /// Covariance, `(θ, x, y)` right perturbation.
    pub covariance: Matrix3<f64>,
}

/// The problem.
#[derive(Debug, Clone, Default)]
pub struct Problem {
    /// Keyframe poses to start from (the localiser's against the prior map), world frame.
    pub keyframes: Vec<SimPose>,
    /// Landmark poses to start from, world frame.
    pub landmarks: Vec<SimPose>,
    /// Keyframe → next keyframe.
    pub steps: Vec<Relative>,
    /// Keyframe → landmark.
    pub observations: Vec<Relative>,
    /// Landmark priors.
    pub priors: Vec<Prior>,
    /// 1σ of the prior holding the first keyframe where it starts (metres and radians);
    /// `None`: [`LOOSE_PRIOR_SD`], when landmarks or anchors fix the map.
    pub first_keyframe_sd: Option<f64>,
}

impl Problem {
    /// 1σ of the first keyframe's prior.
    pub fn first_keyframe_sd(&self) -> f64 {
        self.first_keyframe_sd.unwrap_or(LOOSE_PRIOR_SD)
    }
}

impl Relative {
    /// The squared Mahalanobis distance of this measurement from `to` seen from `from`
    /// (both world frame): about 3 on average when the factor's covariance is honest.
    pub fn chi2(&self, from: SimPose, to: SimPose) -> f64 {
        let e = self.z.between(from.between(to));
        let v = nalgebra::Vector3::new(e.theta_rad, e.x_m, e.y_m);
        self.covariance
            .try_inverse()
            .map_or(f64::INFINITY, |info| (v.transpose() * info * v)[0])
    }
}

/// The solution.
#[derive(Debug, Clone)]
pub struct Solution {
    /// Keyframe poses, world frame.
    pub keyframes: Vec<SimPose>,
    /// Landmark poses, world frame.
    pub landmarks: Vec<SimPose>,
    /// Each landmark's marginal covariance, `(θ, x, y)` right perturbation (in the
    /// landmark's own frame: `x` along its wall).
    pub landmark_covariance: Vec<Matrix3<f64>>,
    /// Total cost `Σ ρ(d²)` (dimensionless: squared Mahalanobis lengths) before the solve.
    pub error_before: f64,
    /// The same after the solve.
    pub error_after: f64,
    /// Levenberg–Marquardt iterations taken (accepted steps and the final rejected one
    /// counted as the back end counts them; at most the `max_iterations` given).
    pub iterations: usize,
}

/// Which back end solves the joint problem (`host-sim survey --solver NAME`). All three
/// minimise the same cost and report the same marginals; they differ in speed, memory and
/// dependencies (README, "Solver").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Solver {
    /// `factrs` 0.3: Levenberg–Marquardt over SE(2) on faer's sparse Cholesky (automatic
    /// differentiation); marginals from its linearisation with faer. The default.
    #[default]
    Factrs,
    /// `apex-solver` 1.5: Levenberg–Marquardt over SE(2) (analytic Jacobians) on faer's
    /// sparse Cholesky; marginals from its Jacobian at the solution with faer. Only in
    /// builds with the `solver-apex` feature (otherwise [`solve`] says how to get it).
    Apex,
    /// The survey's own Gauss–Newton/Levenberg–Marquardt ([`super::solver_own`]): analytic
    /// SE(2) Jacobians, Huber by IRLS weights, nalgebra-sparse's Cholesky in the keyframe-chain
    /// order with each landmark after the last keyframe that sees it.
    Own,
}

impl Solver {
    /// Every back end, the default first.
    pub const ALL: [Solver; 3] = [Solver::Factrs, Solver::Apex, Solver::Own];

    /// The back ends this build has (apex-solver only with the `solver-apex` feature), the
    /// default first.
    #[cfg(feature = "solver-apex")]
    pub const BUILT: &'static [Solver] = &[Solver::Factrs, Solver::Apex, Solver::Own];
    /// The back ends this build has (apex-solver only with the `solver-apex` feature), the
    /// default first.
    #[cfg(not(feature = "solver-apex"))]
    pub const BUILT: &'static [Solver] = &[Solver::Factrs, Solver::Own];

    /// The name on the command line and in `survey.json`.
    pub fn name(self) -> &'static str {
        match self {
            Solver::Factrs => "factrs",
            Solver::Apex => "apex",
            Solver::Own => "own",
        }
    }
}

impl fmt::Display for Solver {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A solver name that is none of [`Solver::ALL`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnknownSolver(pub String);

impl fmt::Display for UnknownSolver {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "unknown solver `{}`: give factrs (the default), apex or own",
            self.0
        )
    }
}

impl std::error::Error for UnknownSolver {}

impl FromStr for Solver {
    type Err = UnknownSolver;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Solver::ALL
            .into_iter()
            .find(|v| v.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| UnknownSolver(s.to_string()))
    }
}

/// Why the joint estimate failed.
#[derive(Debug, Clone, PartialEq)]
pub enum GraphError {
    /// A measurement's covariance is not positive definite (a bug upstream: a fit or a step
    /// that should have been left out).
    BadCovariance {
        /// Which factor.
        what: String,
    },
    /// The solver could not make progress (the problem is singular: a landmark or keyframe
    /// tied to nothing).
    Solver(String),
}

impl fmt::Display for GraphError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GraphError::BadCovariance { what } => {
                write!(f, "{what}: covariance not positive definite")
            }
            GraphError::Solver(why) => write!(f, "the joint estimate failed: {why}"),
        }
    }
}

impl std::error::Error for GraphError {}

/// A keyframe far from everything keeps the system well posed: a 10 km prior on the first
/// keyframe's position and heading (no pull on anything the scans determine), metres and
/// radians.
pub const LOOSE_PRIOR_SD: f64 = 1e4;

/// The Huber kernel's threshold on a factor's Mahalanobis length `d` (dimensionless):
/// quadratic below, linear above; factrs' default, 95 % efficiency on Gaussian noise.
pub const HUBER_K: f64 = 1.345;

/// Landmarks whose covariance columns are solved for at once by the faer back ends (a dense
/// block of `n × 3·BATCH`: 25 000 unknowns × 96 columns is 19 MB).
pub(super) const MARGINAL_BATCH: usize = 32;

/// The information matrix `Σ⁻¹` of a factor's covariance, or why not.
pub(super) fn information(
    cov: &Matrix3<f64>,
    what: impl Fn() -> String,
) -> Result<Matrix3<f64>, GraphError> {
    let symmetric = (cov + cov.transpose()) * 0.5;
    symmetric
        .cholesky()
        .filter(|_| cov.iter().all(|v| v.is_finite()))
        .map(|c| c.inverse())
        .ok_or_else(|| GraphError::BadCovariance { what: what() })
}

/// Solves the problem with `solver` (at most `max_iterations` Levenberg–Marquardt steps).
pub fn solve(
    problem: &Problem,
    solver: Solver,
    max_iterations: usize,
) -> Result<Solution, GraphError> {
    match solver {
        Solver::Factrs => solver_factrs::solve(problem, max_iterations),
        #[cfg(feature = "solver-apex")]
        Solver::Apex => solver_apex::solve(problem, max_iterations),
        #[cfg(not(feature = "solver-apex"))]
        Solver::Apex => Err(GraphError::Solver(
            "this host-sim was built without the apex-solver back end: rebuild with `cargo build --release -p host-sim --features solver-apex`".into(),
        )),
        Solver::Own => solver_own::solve(problem, max_iterations),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_of_a_step_grows_with_its_disagreement() {
        let r = Relative {
            from: 0,
            to: 1,
            z: SimPose::new(1.0, 0.0, 0.0),
            covariance: Matrix3::from_diagonal(&nalgebra::Vector3::new(1e-4, 1e-4, 1e-4)),
        };
        let a = SimPose::new(2.0, 1.0, 0.3);
        assert!(r.chi2(a, a.compose(SimPose::new(1.0, 0.0, 0.0))) < 1e-9);
        // 3 cm across at 1 cm σ: 9.
        let c = r.chi2(a, a.compose(SimPose::new(1.0, 0.03, 0.0)));
        assert!((c - 9.0).abs() < 0.01, "{c}");
    }

    #[test]
    fn solver_names_round_trip_and_unknown_names_say_what_to_give() {
        for s in Solver::ALL {
            assert_eq!(s.name().parse::<Solver>(), Ok(s));
        }
        assert_eq!(" Apex ".parse::<Solver>(), Ok(Solver::Apex));
        let e = "ceres".parse::<Solver>().unwrap_err().to_string();
        assert!(
            e.contains("ceres") && e.contains("factrs") && e.contains("own"),
            "{e}"
        );
        assert_eq!(Solver::default(), Solver::Factrs);
    }

    fn diag(t: f64, x: f64, y: f64) -> Matrix3<f64> {
        Matrix3::from_diagonal(&nalgebra::Vector3::new(t * t, x * x, y * y))
    }

    /// A straight drive past two landmarks, each seen from every keyframe, the odometry 5 %
    /// short: the landmark observations pull the trajectory and the landmarks into place.
    fn drive_past_two_landmarks(solver: Solver) {
        let truth_l = [SimPose::new(5.0, 2.5, 0.0), SimPose::new(12.0, -2.5, 0.0)];
        let truth_x: Vec<SimPose> = (0..30)
            .map(|k| SimPose::new(k as f64 * 0.5, 0.0, 0.0))
            .collect();
        let mut p = Problem {
            keyframes: truth_x
                .iter()
                .map(|x| SimPose::new(x.x_m * 0.95, 0.02, 0.0))
                .collect(),
            landmarks: truth_l
                .iter()
                .map(|l| l.compose(SimPose::new(0.05, 0.02, 0.01)))
                .collect(),
            ..Problem::default()
        };
        for k in 0..truth_x.len() - 1 {
            p.steps.push(Relative {
                from: k,
                to: k + 1,
                z: SimPose::new(0.475, 0.0, 0.0),
                covariance: diag(0.001, 0.05, 0.01),
            });
        }
        for (k, x) in truth_x.iter().enumerate() {
            for (j, l) in truth_l.iter().enumerate() {
                p.observations.push(Relative {
                    from: k,
                    to: j,
                    z: x.between(*l),
                    covariance: diag(0.01, 0.003, 0.003),
                });
            }
        }
        // Landmark 0 is surveyed: its pose holds the map in place.
        p.priors.push(Prior {
            landmark: 0,
            pose: truth_l[0],
            covariance: diag(0.001, 0.002, 0.002),
        });
        let s = solve(&p, solver, 50).unwrap();
        assert!(s.error_after < s.error_before * 1e-3, "{solver}");
        assert!(s.iterations >= 1 && s.iterations <= 50, "{solver}");
        let e = truth_l[1].between(s.landmarks[1]);
        assert!(e.x_m.abs() < 1e-3 && e.y_m.abs() < 1e-3, "{solver}: {e:?}");
        let last = truth_x[29].between(s.keyframes[29]);
        assert!(last.x_m.abs() < 2e-3, "{solver}: {last:?}");
        // The surveyed landmark is known to its prior, the other a little worse.
        let sd = |j: usize| s.landmark_covariance[j][(1, 1)].sqrt();
        assert!(
            sd(0) < 0.002 && sd(1) > sd(0) && sd(1) < 0.02,
            "{solver}: {} {}",
            sd(0),
            sd(1)
        );
    }

    #[test]
    fn landmarks_seen_from_a_drive_are_placed_and_their_uncertainty_reported() {
        for &solver in Solver::BUILT {
            drive_past_two_landmarks(solver);
        }
    }

    /// A small pseudo-random drive (xorshift, fixed seed): a curving chain of keyframes with
    /// odometry and longer-baseline steps, landmarks on both walls seen from the keyframes
    /// near them, two landmark priors; the measurements noisy, the start perturbed.
    fn random_problem(seed: u64) -> Problem {
        let mut state = seed;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let truth_x: Vec<SimPose> = (0..40)
            .map(|k| {
                let s = k as f64 * 0.5;
                SimPose::new(s, 0.02 * s * s / 2.0, 0.02 * s)
            })
            .collect();
        let truth_l: Vec<SimPose> = (0..6)
            .map(|j| {
                let s = 1.5 + j as f64 * 3.2;
                let side = if j % 2 == 0 { 2.4 } else { -2.4 };
                truth_x[0].compose(SimPose::new(s, 0.02 * s * s / 2.0 + side, 0.02 * s + 0.3))
            })
            .collect();
        let mut noisy = |p: SimPose, sd_rad: f64, sd_m: f64| {
            p.compose(SimPose::new(
                sd_m * uniform(),
                sd_m * uniform(),
                sd_rad * uniform(),
            ))
        };
        let mut p = Problem::default();
        for k in 0..truth_x.len() {
            for b in [1, 4] {
                if k + b < truth_x.len() {
                    let z = noisy(truth_x[k].between(truth_x[k + b]), 1e-4, 1e-4);
                    p.steps.push(Relative {
                        from: k,
                        to: k + b,
                        z,
                        covariance: diag(2e-4, 0.01, 2e-3),
                    });
                }
            }
            for (j, l) in truth_l.iter().enumerate() {
                if (truth_x[k].x_m - l.x_m).abs() < 8.0 {
                    let z = noisy(truth_x[k].between(*l), 1e-4, 1e-4);
                    p.observations.push(Relative {
                        from: k,
                        to: j,
                        z,
                        covariance: diag(0.01, 0.004, 0.003),
                    });
                }
            }
        }
        for j in [0, 5] {
            p.priors.push(Prior {
                landmark: j,
                pose: truth_l[j],
                covariance: diag(0.01, 0.005, 0.0025),
            });
        }
        p.keyframes = truth_x.iter().map(|x| noisy(*x, 0.01, 0.05)).collect();
        p.landmarks = truth_l.iter().map(|l| noisy(*l, 0.01, 0.05)).collect();
        p
    }

    /// With a scan match locked 0.3 m wrong the Huber kernel is active on it: apex-solver
    /// and the own solver, which share the exact SE(2) logarithm, still agree to the
    /// micrometre, and factrs (whose logarithm differs for negative angles) to the
    /// millimetre.
    #[test]
    fn the_back_ends_agree_with_an_outlier_under_the_huber_kernel() {
        let mut p = random_problem(0x0dd_ba11_5eed_0002);
        // steps[7] is keyframe 3 → 7 (baseline 4); the outlier says the same 0.3 m across.
        let (from, to) = (p.steps[7].from, p.steps[7].to);
        assert_eq!((from, to), (3, 7));
        let z = p.steps[7].z.compose(SimPose::new(0.0, 0.3, 0.0));
        p.steps.push(Relative {
            from,
            to,
            z,
            covariance: diag(2e-4, 0.01, 2e-3),
        });
        let [factrs, own] = [Solver::Factrs, Solver::Own].map(|s| solve(&p, s, 50).unwrap());
        #[cfg(feature = "solver-apex")]
        {
            let apex = solve(&p, Solver::Apex, 50).unwrap();
            let pairs = apex.keyframes.iter().zip(&own.keyframes);
            for (a, b) in pairs.chain(apex.landmarks.iter().zip(&own.landmarks)) {
                let d = a.between(*b);
                assert!(d.x_m.hypot(d.y_m) < 1e-6, "own against apex: {d:?}");
            }
            assert!((apex.error_after - own.error_after).abs() < 1e-6 * own.error_after);
        }
        for (a, b) in own.keyframes.iter().zip(&factrs.keyframes) {
            let d = a.between(*b);
            assert!(d.x_m.hypot(d.y_m) < 1e-3, "factrs against own: {d:?}");
        }
        // The outlier is held off: 3 → 7 stays where the other steps put it.
        let d = p.steps[7]
            .z
            .between(own.keyframes[3].between(own.keyframes[7]));
        assert!(d.y_m.abs() < 0.01, "{d:?}");
    }

    #[test]
    fn the_back_ends_agree_on_a_small_random_problem() {
        let p = random_problem(0x5eed_1234_abcd_0001);
        let solutions: Vec<(Solver, Solution)> = Solver::BUILT
            .iter()
            .map(|&s| (s, solve(&p, s, 50).unwrap()))
            .collect();
        let (_, reference) = &solutions[0];
        for (solver, s) in &solutions[1..] {
            let poses = reference
                .keyframes
                .iter()
                .zip(&s.keyframes)
                .chain(reference.landmarks.iter().zip(&s.landmarks));
            for (a, b) in poses {
                let d = a.between(*b);
                assert!(
                    d.x_m.hypot(d.y_m) < 1e-6 && d.theta_rad.abs() < 1e-6,
                    "{solver} against factrs: {d:?}"
                );
            }
            for (j, (a, b)) in reference
                .landmark_covariance
                .iter()
                .zip(&s.landmark_covariance)
                .enumerate()
            {
                for r in 0..3 {
                    let scale = (a[(r, r)] * b[(r, r)]).sqrt();
                    for c in 0..3 {
                        let tol = 0.01 * (a[(r, r)] * a[(c, c)]).sqrt();
                        assert!(
                            (a[(r, c)] - b[(r, c)]).abs() <= tol,
                            "{solver} landmark {j} ({r}, {c}): {} against factrs' {} (σ² {scale})",
                            b[(r, c)],
                            a[(r, c)]
                        );
                    }
                }
            }
            let rel = (s.error_after - reference.error_after).abs() / reference.error_after;
            assert!(
                rel < 1e-6,
                "{solver}: cost {} against {}",
                s.error_after,
                reference.error_after
            );
        }
    }
}
