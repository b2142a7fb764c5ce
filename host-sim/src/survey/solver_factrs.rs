//! The `factrs` back end of [`super::graph`]: Levenberg–Marquardt over SE(2) (factrs 0.3,
//! automatic differentiation, faer's sparse Cholesky), and each landmark's marginal
//! covariance from factrs' linearisation at the solution with faer's sparse Cholesky
//! directly (factrs has no marginals; the faer version it uses).

use std::cell::Cell;
use std::rc::Rc;

use factrs::containers::{FactorBuilder, Graph, Values, ValuesOrder};
use factrs::core::{BetweenResidual, GaussianNoise, Huber, LevenMarquardt, PriorResidual};
use factrs::linalg::{DiffResult, Matrix3 as FMatrix3};
use factrs::optimizers::{LevenParams, OptError, OptObserver, Optimizer};
use factrs::variables::SE2;
use nalgebra::Matrix3;

use super::graph::{GraphError, Problem, Solution, HUBER_K, MARGINAL_BATCH};
use crate::vehicle::SimPose;

/// factrs' typed keys: `X(k)` keyframe k, `L(j)` landmark j.
mod keys {
    use factrs::assign_symbols;
    use factrs::variables::SE2;

    assign_symbols!(X: SE2; L: SE2);
}
use keys::{L, X};

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

/// Counts factrs' Levenberg–Marquardt steps (it notifies its observers once per step).
struct StepCounter(Rc<Cell<usize>>);

impl OptObserver for StepCounter {
    fn on_step(&self, _values: &Values, _step: i64) {
        self.0.set(self.0.get() + 1);
    }
}

/// Solves the problem (at most `max_iterations` Levenberg–Marquardt steps).
pub(super) fn solve(problem: &Problem, max_iterations: usize) -> Result<Solution, GraphError> {
    let mut values = Values::new();
    for (k, p) in problem.keyframes.iter().enumerate() {
        values.insert(X(k as u32), se2(*p));
    }
    for (j, p) in problem.landmarks.iter().enumerate() {
        values.insert(L(j as u32), se2(*p));
    }
    let mut graph = Graph::new();
    if let Some(first) = problem.keyframes.first() {
        let n = GaussianNoise::<3>::from_scalar_sigma(problem.first_keyframe_sd());
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
            .robust(Huber::new(HUBER_K))
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
            .robust(Huber::new(HUBER_K))
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
    let steps = Rc::new(Cell::new(0));
    opt.add_observer(StepCounter(Rc::clone(&steps)));
    // factrs panics when its Cholesky factorisation fails (a singular or indefinite system,
    // `expect` in its solver) instead of returning an error: caught here, so a degenerate
    // survey is reported, not a crash.
    let optimized = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| opt.optimize(values)))
        .map_err(|_| {
            GraphError::Solver(
                "factrs' linear solver failed (the system is singular or not positive definite: a keyframe or landmark tied to too little)".into(),
            )
        })?;
    let values = match optimized {
        Ok(v) | Err(OptError::MaxIterations(v)) => v,
        Err(e) => {
            return Err(GraphError::Solver(format!(
                "factrs' Levenberg–Marquardt stopped: {e:?}"
            )))
        }
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
        iterations: steps.get(),
    })
}

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
