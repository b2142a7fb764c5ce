//! The `apex-solver` back end of [`super::graph`]: the same factors as apex's `BetweenFactor`
//! and `PriorFactor` over its `SE2` (analytic Jacobians), its `HuberLoss`, its
//! Levenberg–Marquardt on faer's sparse Cholesky, and its covariances.
//!
//! apex orders its SE(2) parameters and tangent `(x m, y m, θ rad)` and writes the between
//! residual `log(z⁻¹ ∘ a⁻¹ ∘ b)` (factrs: `log(b⁻¹ ∘ a ∘ z)`, the same length): the
//! covariances are permuted from and to the survey's `(θ, x, y)` here; both perturb on the
//! right.

use apex_solver::core::loss_functions::HuberLoss;
use apex_solver::core::problem::Problem as ApexProblem;
use apex_solver::core::VarKey;
use apex_solver::optimizer::OptimizationStatus;
use apex_solver::{
    BetweenFactor, JacobianMode, LevenbergMarquardt, LevenbergMarquardtConfig, ManifoldType,
    NoiseModel, PriorFactor, SE2,
};
use nalgebra::Matrix3;
use nalgebra_apex::{DMatrix, DVector};

use super::graph::{information, GraphError, Problem, Solution, HUBER_K, LOOSE_PRIOR_SD};
use crate::vehicle::SimPose;

/// Index in apex's `(x, y, θ)` of each of the survey's `(θ, x, y)`.
const TO_APEX: [usize; 3] = [2, 0, 1];
/// Index in the survey's `(θ, x, y)` of each of apex's `(x, y, θ)`.
const FROM_APEX: [usize; 3] = [1, 2, 0];

fn se2(p: SimPose) -> SE2 {
    SE2::from_xy_angle(p.x_m, p.y_m, p.theta_rad)
}

fn params(p: SimPose) -> DVector<f64> {
    DVector::from_column_slice(&[p.x_m, p.y_m, p.theta_rad])
}

/// apex's noise model (square-root information, its order) of a survey covariance.
fn noise(cov: &Matrix3<f64>, what: impl Fn() -> String) -> Result<NoiseModel, GraphError> {
    let info = information(cov, &what)?;
    let apex = DMatrix::from_fn(3, 3, |r, c| info[(FROM_APEX[r], FROM_APEX[c])]);
    NoiseModel::from_information(apex).map_err(|_| GraphError::BadCovariance { what: what() })
}

fn huber() -> Result<HuberLoss, GraphError> {
    HuberLoss::new(HUBER_K).map_err(|e| GraphError::Solver(format!("apex's Huber kernel: {e}")))
}

fn add_between(
    apex: &mut ApexProblem,
    keys: [VarKey; 2],
    z: SimPose,
    cov: &Matrix3<f64>,
    what: impl Fn() -> String,
) -> Result<(), GraphError> {
    let n = noise(cov, &what)?;
    apex.try_add_residual_block_with_noise(
        &keys,
        Box::new(BetweenFactor::new(se2(z))),
        Some(Box::new(huber()?)),
        n,
    )
    .map(|_| ())
    .map_err(|e| GraphError::Solver(format!("{}: apex refused the factor: {e}", what())))
}

fn add_prior(
    apex: &mut ApexProblem,
    key: VarKey,
    pose: SimPose,
    n: NoiseModel,
    what: impl Fn() -> String,
) -> Result<(), GraphError> {
    apex.try_add_residual_block_with_noise(&[key], Box::new(PriorFactor::new(se2(pose))), None, n)
        .map(|_| ())
        .map_err(|e| GraphError::Solver(format!("{}: apex refused the factor: {e}", what())))
}

/// Solves the problem (at most `max_iterations` Levenberg–Marquardt steps).
pub(super) fn solve(problem: &Problem, max_iterations: usize) -> Result<Solution, GraphError> {
    let mut apex = ApexProblem::new(JacobianMode::Sparse);
    let x: Vec<VarKey> = problem
        .keyframes
        .iter()
        .map(|p| apex.add_variable(ManifoldType::SE2, params(*p)))
        .collect();
    let l: Vec<VarKey> = problem
        .landmarks
        .iter()
        .map(|p| apex.add_variable(ManifoldType::SE2, params(*p)))
        .collect();
    let missing = |what: &str, i: usize| GraphError::Solver(format!("{what} {i} out of range"));
    if let (Some(&k0), Some(first)) = (x.first(), problem.keyframes.first()) {
        let n = NoiseModel::from_sigmas(&[LOOSE_PRIOR_SD; 3])
            .map_err(|e| GraphError::Solver(format!("the loose prior: {e}")))?;
        add_prior(&mut apex, k0, *first, n, || "the loose prior".into())?;
    }
    for s in &problem.steps {
        let a = *x.get(s.from).ok_or_else(|| missing("keyframe", s.from))?;
        let b = *x.get(s.to).ok_or_else(|| missing("keyframe", s.to))?;
        add_between(&mut apex, [a, b], s.z, &s.covariance, || {
            format!("step {} → {}", s.from, s.to)
        })?;
    }
    for o in &problem.observations {
        let a = *x.get(o.from).ok_or_else(|| missing("keyframe", o.from))?;
        let b = *l.get(o.to).ok_or_else(|| missing("landmark", o.to))?;
        add_between(&mut apex, [a, b], o.z, &o.covariance, || {
            format!("landmark {} seen from keyframe {}", o.to, o.from)
        })?;
    }
    for p in &problem.priors {
        let what = || format!("prior of landmark {}", p.landmark);
        let key = *l
            .get(p.landmark)
            .ok_or_else(|| missing("landmark", p.landmark))?;
        let n = noise(&p.covariance, what)?;
        add_prior(&mut apex, key, p.pose, n, what)?;
    }
    let config = LevenbergMarquardtConfig::new()
        .with_max_iterations(max_iterations)
        // factrs' relative stop.
        .with_cost_tolerance(1e-6)
        .with_compute_covariances(!problem.landmarks.is_empty());
    let result = LevenbergMarquardt::with_config(config)
        .optimize(&mut apex)
        .map_err(|e| GraphError::Solver(format!("apex-solver: {e}")))?;
    match &result.status {
        OptimizationStatus::NumericalFailure
        | OptimizationStatus::IllConditionedJacobian
        | OptimizationStatus::InvalidNumericalValues
        | OptimizationStatus::UserTerminated
        | OptimizationStatus::Failed(_) => {
            return Err(GraphError::Solver(format!(
                "apex-solver stopped: {}",
                result.status
            )))
        }
        _ => {}
    }
    let pose_of = |k: VarKey| {
        result.parameters.get(k).map(|v| {
            let p = v.as_param_slice();
            SimPose::new(p[0], p[1], p[2])
        })
    };
    let keyframes = x
        .iter()
        .map(|&k| pose_of(k))
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| GraphError::Solver("apex-solver lost a keyframe".into()))?;
    let landmarks = l
        .iter()
        .map(|&k| pose_of(k))
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| GraphError::Solver("apex-solver lost a landmark".into()))?;
    let landmark_covariance = if l.is_empty() {
        Vec::new()
    } else {
        let cov = result.covariances.as_ref().ok_or_else(|| {
            GraphError::Solver(
                "apex-solver computed no covariances: the information matrix is singular".into(),
            )
        })?;
        l.iter()
            .map(|&k| {
                cov.get(k)
                    .map(|m| Matrix3::from_fn(|r, c| m[(TO_APEX[r], TO_APEX[c])]))
            })
            .collect::<Option<Vec<_>>>()
            .ok_or_else(|| GraphError::Solver("apex-solver lost a landmark's covariance".into()))?
    };
    Ok(Solution {
        keyframes,
        landmarks,
        landmark_covariance,
        error_before: result.initial_cost,
        error_after: result.final_cost,
        iterations: result.iterations,
    })
}
