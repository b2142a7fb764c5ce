//! The survey's joint estimate: every keyframe pose and every landmark pose of the drive in
//! one sparse nonlinear least-squares problem, solved with `factrs` (Levenberg–Marquardt over
//! SE(2), faer's sparse Cholesky), and each landmark's marginal covariance from the same
//! linearisation.
//!
//! Factors (all SE(2) between or prior factors; covariances in factrs' tangent order
//! `(θ rad, x m, y m)`, right perturbation):
//! - keyframe → next keyframe: the odometry, with its across-tunnel offset and heading change
//!   replaced by the walls' where both keyframes see a wall ([`super::keyframes`]);
//! - keyframe → landmark: one landmark fitted in one scan ([`super::landmark_fit`]), with a
//!   Huber kernel (a fit spoilt by a person beside the landmark must not bend the map);
//! - landmark priors: the design's marks with the installation tolerance, anchors surveyed
//!   into mine coordinates, or the first landmark held where it was first seen.

use factrs::containers::{FactorBuilder, Graph, Values, ValuesOrder};
use factrs::core::{BetweenResidual, GaussianNoise, Huber, LevenMarquardt, PriorResidual};
use factrs::linalg::{DiffResult, Matrix3 as FMatrix3};
use factrs::optimizers::{LevenParams, OptError, Optimizer};
use factrs::variables::SE2;
use nalgebra::Matrix3;

use crate::vehicle::SimPose;

/// factrs' typed keys: `X(k)` keyframe k, `L(j)` landmark j.
mod keys {
    use factrs::assign_symbols;
    use factrs::variables::SE2;

    assign_symbols!(X: SE2; L: SE2);
}
use keys::{L, X};

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
    /// Total weighted squared error before and after.
    pub error_before: f64,
    /// After the solve.
    pub error_after: f64,
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

impl std::fmt::Display for GraphError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GraphError::BadCovariance { what } => {
                write!(f, "{what}: covariance not positive definite")
            }
            GraphError::Solver(why) => write!(f, "the joint estimate failed: {why}"),
        }
    }
}

impl std::error::Error for GraphError {}

fn se2(p: SimPose) -> SE2 {
    SE2::new(p.theta_rad, p.x_m, p.y_m)
}

fn pose(p: &SE2) -> SimPose {
    SimPose::new(p.x(), p.y(), p.theta())
}

fn noise(cov: &Matrix3<f64>, what: impl Fn() -> String) -> Result<GaussianNoise<3>, GraphError> {
    let m = FMatrix3::from_fn(|r, c| cov[(r, c)]);
    GaussianNoise::<3>::from_matrix_cov(m.as_view())
        .ok_or_else(|| GraphError::BadCovariance { what: what() })
}

/// A keyframe far from everything keeps the system well posed: a 10 km prior on the first
/// keyframe's position and heading (no pull on anything the scans determine).
const LOOSE_PRIOR_SD: f64 = 1e4;

/// Solves the problem (at most `max_iterations` Levenberg–Marquardt steps).
pub fn solve(problem: &Problem, max_iterations: usize) -> Result<Solution, GraphError> {
    let mut values = Values::new();
    for (k, p) in problem.keyframes.iter().enumerate() {
        values.insert(X(k as u32), se2(*p));
    }
    for (j, p) in problem.landmarks.iter().enumerate() {
        values.insert(L(j as u32), se2(*p));
    }
    let mut graph = Graph::new();
    if let Some(first) = problem.keyframes.first() {
        let n = GaussianNoise::<3>::from_scalar_sigma(LOOSE_PRIOR_SD);
        graph.add_factor(
            FactorBuilder::new1(PriorResidual::new(se2(*first)), X(0))
                .noise(n)
                .build(),
        );
    }
    for s in &problem.steps {
        let n = noise(&s.covariance, || format!("step {} → {}", s.from, s.to))?;
        graph.add_factor(
            FactorBuilder::new2(
                BetweenResidual::new(se2(s.z)),
                X(s.from as u32),
                X(s.to as u32),
            )
            .noise(n)
            .robust(Huber::default())
            .build(),
        );
    }
    for o in &problem.observations {
        let n = noise(&o.covariance, || {
            format!("landmark {} seen from keyframe {}", o.to, o.from)
        })?;
        graph.add_factor(
            FactorBuilder::new2(
                BetweenResidual::new(se2(o.z)),
                X(o.from as u32),
                L(o.to as u32),
            )
            .noise(n)
            .robust(Huber::default())
            .build(),
        );
    }
    for p in &problem.priors {
        let n = noise(&p.covariance, || {
            format!("prior of landmark {}", p.landmark)
        })?;
        graph.add_factor(
            FactorBuilder::new1(PriorResidual::new(se2(p.pose)), L(p.landmark as u32))
                .noise(n)
                .build(),
        );
    }
    let error_before = graph.error(&values);
    let mut params = LevenParams::default();
    params.base.max_iterations = max_iterations;
    let mut opt = LevenMarquardt::new(params, graph);
    let values = match opt.optimize(values) {
        Ok(v) | Err(OptError::MaxIterations(v)) => v,
        Err(e) => return Err(GraphError::Solver(format!("{e:?}"))),
    };
    let error_after = opt.graph().error(&values);
    let keyframes = (0..problem.keyframes.len())
        .map(|k| values.get::<_, SE2>(X(k as u32)).map(pose))
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| GraphError::Solver("a keyframe went missing".into()))?;
    let landmarks = (0..problem.landmarks.len())
        .map(|j| values.get::<_, SE2>(L(j as u32)).map(pose))
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| GraphError::Solver("a landmark went missing".into()))?;
    let landmark_covariance = marginals(opt.graph(), &values, problem.landmarks.len())?;
    Ok(Solution {
        keyframes,
        landmarks,
        landmark_covariance,
        error_before,
        error_after,
    })
}

/// Landmarks whose covariance columns are solved for at once (a dense block of
/// `n × 3·BATCH`: 25 000 unknowns × 96 columns is 19 MB).
const MARGINAL_BATCH: usize = 32;

/// Each landmark's 3×3 block of the inverse of `JᵀJ` at the solution.
fn marginals(
    graph: &Graph,
    values: &Values,
    landmarks: usize,
) -> Result<Vec<Matrix3<f64>>, GraphError> {
    use faer::linalg::solvers::Solve;
    if landmarks == 0 {
        // Nothing to report (and a chain of keyframes held by a 10 km prior alone is too
        // ill-conditioned to factor).
        return Ok(Vec::new());
    }
    let order = ValuesOrder::from_values(values);
    let graph_order = graph.sparsity_pattern(order.clone());
    let DiffResult { diff: j, .. } = graph.linearize(values).residual_jacobian(&graph_order);
    let jt = j
        .as_ref()
        .transpose()
        .to_col_major()
        .map_err(|e| GraphError::Solver(format!("{e:?}")))?;
    let h = &jt * j.as_ref();
    let llt = faer::sparse::linalg::solvers::Llt::try_new_with_symbolic(
        faer::sparse::linalg::solvers::SymbolicLlt::try_new(h.symbolic(), faer::Side::Lower)
            .map_err(|e| GraphError::Solver(format!("{e:?}")))?,
        h.as_ref(),
        faer::Side::Lower,
    )
    .map_err(|e| GraphError::Solver(format!("the information matrix is singular: {e:?}")))?;
    let index = |j: usize| order.get(L(j as u32)).map(|i| i.idx);
    let mut out = Vec::with_capacity(landmarks);
    let ids: Vec<usize> = (0..landmarks).collect();
    for batch in ids.chunks(MARGINAL_BATCH) {
        let starts: Vec<usize> = batch
            .iter()
            .map(|&j| index(j).ok_or_else(|| GraphError::Solver("landmark not ordered".into())))
            .collect::<Result<_, _>>()?;
        let mut rhs = faer::Mat::<f64>::zeros(order.dim(), 3 * batch.len());
        for (c, &s) in starts.iter().enumerate() {
            for d in 0..3 {
                rhs[(s + d, 3 * c + d)] = 1.0;
            }
        }
        let x = llt.solve(&rhs);
        for (c, &s) in starts.iter().enumerate() {
            out.push(Matrix3::from_fn(|r, q| x[(s + r, 3 * c + q)]));
        }
    }
    Ok(out)
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

    fn diag(t: f64, x: f64, y: f64) -> Matrix3<f64> {
        Matrix3::from_diagonal(&nalgebra::Vector3::new(t * t, x * x, y * y))
    }

    /// A straight drive past two landmarks, each seen from every keyframe, the odometry 5 %
    /// short: the landmark observations pull the trajectory and the landmarks into place.
    #[test]
    fn landmarks_seen_from_a_drive_are_placed_and_their_uncertainty_reported() {
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
        let s = solve(&p, 50).unwrap();
        assert!(s.error_after < s.error_before * 1e-3);
        let e = truth_l[1].between(s.landmarks[1]);
        assert!(e.x_m.abs() < 1e-3 && e.y_m.abs() < 1e-3, "{e:?}");
        let last = truth_x[29].between(s.keyframes[29]);
        assert!(last.x_m.abs() < 2e-3, "{last:?}");
        // The surveyed landmark is known to its prior, the other a little worse.
        let sd = |j: usize| s.landmark_covariance[j][(1, 1)].sqrt();
        assert!(
            sd(0) < 0.002 && sd(1) > sd(0) && sd(1) < 0.02,
            "{} {}",
            sd(0),
            sd(1)
        );
    }
}
