//! The `apex-solver` back end of [`super::graph`]: the same factors as apex's `BetweenFactor`
//! and `PriorFactor` over its `SE2` (analytic Jacobians), its `HuberLoss`, its
//! Levenberg–Marquardt on faer's sparse Cholesky; the marginals from apex's Jacobian at the
//! solution with faer's sparse Cholesky, a batch of landmarks at a time.
//!
//! apex's own covariances (`with_compute_covariances`) invert the whole information matrix
//! densely (`H⁻¹`, every variable): on the kilometre (2 980 poses, 8 940 unknowns) that took
//! 2.1 GB and 6.8 s of solve against the batches' few MB.
//!
//! apex orders its SE(2) parameters and tangent `(x m, y m, θ rad)` and writes the between
//! residual `log(z⁻¹ ∘ a⁻¹ ∘ b)` (factrs: `log(b⁻¹ ∘ a ∘ z)`, the same length): the
//! covariances are permuted from and to the survey's `(θ, x, y)` here; both perturb on the
//! right.

use apex_solver::core::loss_functions::HuberLoss;
use apex_solver::core::problem::Problem as ApexProblem;
use apex_solver::core::variable::ManifoldVariable;
use apex_solver::core::VarKey;
use apex_solver::linearizer::cpu::sparse::build_symbolic_structure;
use apex_solver::optimizer::OptimizationStatus;
use apex_solver::{
    BetweenFactor, JacobianMode, LevenbergMarquardt, LevenbergMarquardtConfig, ManifoldType,
    NoiseModel, PriorFactor, SE2,
};
use nalgebra::Matrix3;
use nalgebra_apex::{DMatrix, DVector};

use super::graph::{information, GraphError, Problem, Solution, HUBER_K, MARGINAL_BATCH};
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
        let n = NoiseModel::from_sigmas(&[problem.first_keyframe_sd(); 3])
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
        .with_cost_tolerance(1e-6);
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
    let landmark_covariance = marginals(&apex, &result.parameters, &l)?;
    Ok(Solution {
        keyframes,
        landmarks,
        landmark_covariance,
        error_before: result.initial_cost,
        error_after: result.final_cost,
        iterations: result.iterations,
    })
}

/// apex's variables after the solve.
type Variables = slotmap::SlotMap<VarKey, Box<dyn ManifoldVariable>>;

/// Each landmark's 3×3 block of the inverse of `Jᵀ J` (apex's whitened, Huber-weighted
/// Jacobian at `variables`), in the survey's `(θ, x, y)`.
fn marginals(
    apex: &ApexProblem,
    variables: &Variables,
    landmarks: &[VarKey],
) -> Result<Vec<Matrix3<f64>>, GraphError> {
    use faer_apex::linalg::solvers::Solve;
    use faer_apex::sparse::linalg::solvers::{Llt, SymbolicLlt};
    if landmarks.is_empty() {
        // Nothing to report (and a chain of keyframes held by a 10 km prior alone is too
        // ill-conditioned to factor).
        return Ok(Vec::new());
    }
    let failed = |why: String| GraphError::Solver(format!("apex-solver's marginals: {why}"));
    let mut index = slotmap::SecondaryMap::new();
    let mut dim = 0;
    for (key, v) in variables {
        index.insert(key, dim);
        dim += v.free_dof();
    }
    let symbolic = build_symbolic_structure(apex, variables, &index, dim)
        .map_err(|e| failed(e.to_string()))?;
    let (_, j) = apex
        .compute_residual_and_jacobian_sparse(variables, &index, &symbolic)
        .map_err(|e| failed(e.to_string()))?;
    let jt = j
        .as_ref()
        .transpose()
        .to_col_major()
        .map_err(|e| failed(format!("{e:?}")))?;
    let h = &jt * j.as_ref();
    let llt = Llt::try_new_with_symbolic(
        SymbolicLlt::try_new(h.symbolic(), faer_apex::Side::Lower)
            .map_err(|e| failed(format!("{e:?}")))?,
        h.as_ref(),
        faer_apex::Side::Lower,
    )
    .map_err(|e| failed(format!("the information matrix is singular: {e:?}")))?;
    let mut out = Vec::with_capacity(landmarks.len());
    for batch in landmarks.chunks(MARGINAL_BATCH) {
        let starts: Vec<usize> = batch
            .iter()
            .map(|&k| {
                index
                    .get(k)
                    .copied()
                    .ok_or_else(|| failed("a landmark is not ordered".into()))
            })
            .collect::<Result<_, _>>()?;
        let mut rhs = faer_apex::Mat::<f64>::zeros(dim, 3 * batch.len());
        for (c, &s) in starts.iter().enumerate() {
            for d in 0..3 {
                rhs[(s + d, 3 * c + d)] = 1.0;
            }
        }
        let x = llt.solve(&rhs);
        for (c, &s) in starts.iter().enumerate() {
            out.push(Matrix3::from_fn(|r, q| {
                x[(s + TO_APEX[r], 3 * c + TO_APEX[q])]
            }));
        }
    }
    Ok(out)
}
