//! The survey's own back end of [`super::graph`]: Levenberg–Marquardt (Gauss–Newton steps
//! with Marquardt's diagonal damping) on the sparse normal equations, nalgebra-sparse's
//! Cholesky, analytic SE(2) Jacobians ([`super::own_se2`]), the Huber kernel by IRLS weights,
//! and each landmark's marginal covariance from the factor at the solution.
//!
//! **Ordering.** nalgebra-sparse's `CscCholesky` factors in the order it is given (no
//! fill-reducing permutation), so the normal equations are laid out in the drive's own
//! order: the keyframes in sequence, each landmark right after the last keyframe that sees
//! it (`chain_order`). Keyframes couple only to keyframes a few baselines back (at most
//! 16 on the kilometre), so the keyframe part of the factor stays a band; a landmark placed
//! after its last observer fills in only over the stretch it is seen from (20 m of range:
//! about 160 keyframes), instead of the whole drive (landmarks last: an arrow whose
//! landmark rows fill over every later keyframe) or all its observers against each other
//! (landmarks first: a dense block of 160 keyframes). Reverse Cuthill–McKee would find a
//! band of the same kind but not this placement of the landmarks, and needs a graph search
//! the drive's order gives for free.
//!
//! **Marginals.** A landmark at block position `p` has `H⁻¹`'s block `Yᵀ Y` with
//! `Y = L⁻¹ E_p` (`E_p` its three unit columns): a forward substitution that starts at
//! column `3p` of the factor `L`, so a landmark costs the factor's columns after it.

use nalgebra::{DMatrix, Matrix3, Vector3};
use nalgebra_sparse::factorization::{CscCholesky, CscSymbolicCholesky};
use nalgebra_sparse::pattern::SparsityPattern;

use super::graph::{information, GraphError, Problem, Solution, HUBER_K};
use super::own_se2::{self, Tangent};
use crate::vehicle::SimPose;

/// One factor: a prior (`from: None`) or a between factor, in variable indices (keyframes
/// first, then landmarks).
struct Factor {
    from: Option<usize>,
    to: usize,
    z: SimPose,
    /// `Σ⁻¹`, `(θ, x, y)`.
    information: Matrix3<f64>,
    /// Huber kernel ([`HUBER_K`]) or plain least squares.
    robust: bool,
    /// Where its blocks of `H` are: `[(to, to), (from, from), (from, to), (to, from)]` as
    /// `(row block, column block)`; the last three only for between factors.
    slots: [Slot; 4],
}

/// Where a 3×3 block of `H` sits in the CSC values: entry `(r, c)` of the block is at
/// `start + c·stride + r`.
#[derive(Debug, Clone, Copy, Default)]
struct Slot {
    start: usize,
    stride: usize,
}

impl Slot {
    fn add(self, values: &mut [f64], block: &Matrix3<f64>) {
        for c in 0..3 {
            let col = self.start + c * self.stride;
            for r in 0..3 {
                values[col + r] += block[(r, c)];
            }
        }
    }
}

/// The block position of every variable (keyframes `0..K`, then landmarks): the keyframes in
/// sequence, each landmark right after the last keyframe that observes it, landmarks seen
/// from no keyframe at the end.
fn chain_order(problem: &Problem) -> Vec<usize> {
    let k = problem.keyframes.len();
    let mut last_seen: Vec<Option<usize>> = vec![None; problem.landmarks.len()];
    for o in &problem.observations {
        if let Some(l) = last_seen.get_mut(o.to) {
            *l = Some(l.map_or(o.from, |f| f.max(o.from)));
        }
    }
    let mut after: Vec<Vec<usize>> = vec![Vec::new(); k];
    let mut unseen = Vec::new();
    for (j, l) in last_seen.iter().enumerate() {
        match l.and_then(|f| after.get_mut(f)) {
            Some(list) => list.push(k + j),
            None => unseen.push(k + j),
        }
    }
    let sequence = (0..k)
        .flat_map(|x| std::iter::once(x).chain(after[x].iter().copied()))
        .chain(unseen);
    let mut position = vec![0; k + problem.landmarks.len()];
    for (p, v) in sequence.enumerate() {
        position[v] = p;
    }
    position
}

/// The normal equations' layout: the symmetric block pattern of `H` in [`chain_order`]
/// (both triangles, as nalgebra-sparse's Cholesky reads them), scalar CSC.
struct Layout {
    /// Block position of each variable.
    position: Vec<usize>,
    pattern: SparsityPattern,
    /// Per block column: the CSC offset of its first scalar column, and its block rows.
    columns: Vec<(usize, Vec<usize>)>,
    /// Where each scalar diagonal entry is in the values.
    diagonal: Vec<usize>,
}

impl Layout {
    fn new(problem: &Problem, factors: &[Factor]) -> Result<Self, GraphError> {
        let position = chain_order(problem);
        let blocks = position.len();
        let mut rows: Vec<Vec<usize>> = (0..blocks).map(|b| vec![b]).collect();
        for f in factors {
            if let Some(from) = f.from {
                let (a, b) = (position[from], position[f.to]);
                rows[a].push(b);
                rows[b].push(a);
            }
        }
        let mut offsets = Vec::with_capacity(3 * blocks + 1);
        let mut indices = Vec::new();
        let mut columns = Vec::with_capacity(blocks);
        for list in &mut rows {
            list.sort_unstable();
            list.dedup();
        }
        for (bc, list) in rows.into_iter().enumerate() {
            columns.push((indices.len(), Vec::new()));
            for _ in 0..3 {
                offsets.push(indices.len());
                indices.extend(list.iter().flat_map(|&br| [3 * br, 3 * br + 1, 3 * br + 2]));
            }
            columns[bc].1 = list;
        }
        offsets.push(indices.len());
        let n = 3 * blocks;
        let pattern = SparsityPattern::try_from_offsets_and_indices(n, n, offsets, indices)
            .map_err(|e| GraphError::Solver(format!("the normal equations' pattern: {e}")))?;
        let mut layout = Layout {
            position,
            pattern,
            columns,
            diagonal: Vec::with_capacity(n),
        };
        for b in 0..blocks {
            let s = layout.slot(b, b)?;
            layout
                .diagonal
                .extend((0..3).map(|c| s.start + c * s.stride + c));
        }
        Ok(layout)
    }

    /// The slot of block `(row, col)` (block positions).
    fn slot(&self, row: usize, col: usize) -> Result<Slot, GraphError> {
        let (start, list) = &self.columns[col];
        let i = list
            .binary_search(&row)
            .map_err(|_| GraphError::Solver(format!("block ({row}, {col}) not in the pattern")))?;
        Ok(Slot {
            start: start + 3 * i,
            stride: 3 * list.len(),
        })
    }

    fn dim(&self) -> usize {
        3 * self.position.len()
    }
}

/// The current poses: keyframes, then landmarks.
type Poses = Vec<SimPose>;

/// The cost `Σ ρ(d²)` at `poses`, and with `h`/`g` given, `H = Σ Jᵀ w Σ⁻¹ J` and
/// `g = Σ Jᵀ w Σ⁻¹ r` (block positions) accumulated into them.
fn evaluate(
    factors: &[Factor],
    layout: &Layout,
    poses: &Poses,
    mut normal: Option<(&mut [f64], &mut [f64])>,
) -> f64 {
    let mut cost = 0.0;
    for f in factors {
        let (r, jacobians) = match (f.from, normal.is_some()) {
            (Some(a), true) => {
                let (r, ja, jb) = own_se2::between(poses[a], poses[f.to], f.z);
                (r, Some((Some(ja), jb)))
            }
            (Some(a), false) => (own_se2::between_residual(poses[a], poses[f.to], f.z), None),
            (None, true) => {
                let (r, j) = own_se2::prior(poses[f.to], f.z);
                (r, Some((None, j)))
            }
            (None, false) => (own_se2::prior_residual(poses[f.to], f.z), None),
        };
        let wr: Vector3<f64> = f.information * r;
        let d2 = r.dot(&wr);
        let (c, w) = if f.robust {
            own_se2::huber(d2, HUBER_K)
        } else {
            (d2 / 2.0, 1.0)
        };
        cost += c;
        let (Some((h, g)), Some((ja, jb))) = (normal.as_mut(), jacobians) else {
            continue;
        };
        let info = f.information * w;
        let bt = jb.transpose() * info;
        let pb = 3 * layout.position[f.to];
        f.slots[0].add(h, &(bt * jb));
        let gb: Tangent = bt * r;
        for i in 0..3 {
            g[pb + i] += gb[i];
        }
        if let (Some(ja), Some(from)) = (ja, f.from) {
            let at = ja.transpose() * info;
            let pa = 3 * layout.position[from];
            f.slots[1].add(h, &(at * ja));
            let hab = at * jb;
            f.slots[2].add(h, &hab);
            f.slots[3].add(h, &hab.transpose());
            let ga: Tangent = at * r;
            for i in 0..3 {
                g[pa + i] += ga[i];
            }
        }
    }
    cost
}

/// The factors of the problem, with their information matrices.
fn factors(problem: &Problem) -> Result<Vec<Factor>, GraphError> {
    let k = problem.keyframes.len();
    let landmarks = problem.landmarks.len();
    let out_of_range = |what: String| GraphError::Solver(format!("{what}: index out of range"));
    let factor = |from, to, z, information, robust| Factor {
        from,
        to,
        z,
        information,
        robust,
        slots: [Slot::default(); 4],
    };
    let mut out = Vec::with_capacity(
        1 + problem.steps.len() + problem.observations.len() + problem.priors.len(),
    );
    if let Some(first) = problem.keyframes.first() {
        let info = Matrix3::identity() / problem.first_keyframe_sd().powi(2);
        out.push(factor(None, 0, *first, info, false));
    }
    for s in &problem.steps {
        let what = || format!("step {} → {}", s.from, s.to);
        if s.from >= k || s.to >= k {
            return Err(out_of_range(what()));
        }
        let info = information(&s.covariance, what)?;
        out.push(factor(Some(s.from), s.to, s.z, info, true));
    }
    for o in &problem.observations {
        let what = || format!("landmark {} seen from keyframe {}", o.to, o.from);
        if o.from >= k || o.to >= landmarks {
            return Err(out_of_range(what()));
        }
        let info = information(&o.covariance, what)?;
        out.push(factor(Some(o.from), k + o.to, o.z, info, true));
    }
    for p in &problem.priors {
        let what = || format!("prior of landmark {}", p.landmark);
        if p.landmark >= landmarks {
            return Err(out_of_range(what()));
        }
        let info = information(&p.covariance, what)?;
        out.push(factor(None, k + p.landmark, p.pose, info, false));
    }
    Ok(out)
}

/// Puts each factor's blocks in the layout.
fn assign_slots(factors: &mut [Factor], layout: &Layout) -> Result<(), GraphError> {
    for f in factors {
        let b = layout.position[f.to];
        f.slots[0] = layout.slot(b, b)?;
        if let Some(from) = f.from {
            if from == f.to {
                return Err(GraphError::Solver(format!(
                    "a factor between variable {from} and itself"
                )));
            }
            let a = layout.position[from];
            f.slots[1] = layout.slot(a, a)?;
            f.slots[2] = layout.slot(a, b)?;
            f.slots[3] = layout.slot(b, a)?;
        }
    }
    Ok(())
}

/// Marquardt's damping `λ`: where it starts, how it moves, and where the solver gives up
/// looking for a step that lowers the cost (the solution is then as good as it gets).
const LAMBDA_START: f64 = 1e-6;
const LAMBDA_FACTOR: f64 = 10.0;
const LAMBDA_MIN: f64 = 1e-12;
const LAMBDA_MAX: f64 = 1e8;
/// A step is taken when the cost falls by at least this fraction of what the linear model
/// predicts.
const MIN_FIDELITY: f64 = 1e-3;
/// Stop when an accepted step lowers the cost by less than this, relative or absolute
/// (factrs' defaults, so the iteration counts compare).
const TOLERANCE_RELATIVE: f64 = 1e-6;
const TOLERANCE_ABSOLUTE: f64 = 1e-6;

/// The sparse Cholesky of the normal equations, its symbolic part kept across iterations.
struct Cholesky {
    symbolic: CscSymbolicCholesky,
    numeric: Option<CscCholesky<f64>>,
}

impl Cholesky {
    fn new(layout: &Layout) -> Self {
        Cholesky {
            symbolic: CscSymbolicCholesky::factor(layout.pattern.clone()),
            numeric: None,
        }
    }

    /// Factors the matrix with these values (the layout's pattern); `false` when it is not
    /// positive definite.
    fn factor(&mut self, values: &[f64]) -> bool {
        let ok = match self.numeric.as_mut() {
            Some(c) => c.refactor(values).is_ok(),
            None => match CscCholesky::factor_numerical(self.symbolic.clone(), values) {
                Ok(c) => {
                    self.numeric = Some(c);
                    true
                }
                Err(_) => false,
            },
        };
        if !ok {
            // A failed factorisation leaves its workspace dirty: start the next afresh.
            self.numeric = None;
        }
        ok
    }

    /// `A x = b` with the last factor.
    fn solve(&self, b: &[f64]) -> Option<Vec<f64>> {
        let c = self.numeric.as_ref()?;
        let mut x = DMatrix::from_column_slice(b.len(), 1, b);
        c.solve_mut(&mut x);
        Some(x.as_slice().to_vec())
    }
}

/// `xᵀ H x` for `H` in the layout (both triangles stored).
fn quadratic_form(layout: &Layout, h: &[f64], x: &[f64]) -> f64 {
    let offsets = layout.pattern.major_offsets();
    let rows = layout.pattern.minor_indices();
    let mut sum = 0.0;
    for (c, &xc) in x.iter().enumerate() {
        let mut col = 0.0;
        for q in offsets[c]..offsets[c + 1] {
            col += h[q] * x[rows[q]];
        }
        sum += xc * col;
    }
    sum
}

/// The poses after the step `dx` (block positions).
fn stepped(poses: &Poses, layout: &Layout, dx: &[f64]) -> Poses {
    poses
        .iter()
        .zip(&layout.position)
        .map(|(p, &b)| own_se2::plus(*p, &Tangent::new(dx[3 * b], dx[3 * b + 1], dx[3 * b + 2])))
        .collect()
}

/// Solves the problem (at most `max_iterations` Levenberg–Marquardt steps).
pub(super) fn solve(problem: &Problem, max_iterations: usize) -> Result<Solution, GraphError> {
    let k = problem.keyframes.len();
    let mut factors = factors(problem)?;
    let layout = Layout::new(problem, &factors)?;
    assign_slots(&mut factors, &layout)?;
    let n = layout.dim();
    let mut poses: Poses = problem
        .keyframes
        .iter()
        .chain(&problem.landmarks)
        .copied()
        .collect();
    let mut cholesky = Cholesky::new(&layout);
    let mut h = vec![0.0; layout.pattern.nnz()];
    let mut damped = h.clone();
    let mut g = vec![0.0; n];
    let error_before = evaluate(&factors, &layout, &poses, None);
    let mut cost = error_before;
    let mut lambda = LAMBDA_START;
    let mut iterations = 0;
    'iterate: while iterations < max_iterations && n > 0 {
        h.fill(0.0);
        g.fill(0.0);
        evaluate(&factors, &layout, &poses, Some((&mut h[..], &mut g[..])));
        let minus_g: Vec<f64> = g.iter().map(|v| -v).collect();
        iterations += 1;
        loop {
            damped.copy_from_slice(&h);
            for &d in &layout.diagonal {
                damped[d] += lambda * h[d];
            }
            let step = if cholesky.factor(&damped) {
                cholesky.solve(&minus_g)
            } else {
                None
            };
            if let Some(dx) = step {
                // The IRLS model's decrease: −(gᵀδ + ½ δᵀHδ).
                let predicted = -(g.iter().zip(&dx).map(|(a, b)| a * b).sum::<f64>()
                    + 0.5 * quadratic_form(&layout, &h, &dx));
                let trial = stepped(&poses, &layout, &dx);
                let trial_cost = evaluate(&factors, &layout, &trial, None);
                if predicted > 0.0 && (cost - trial_cost) / predicted > MIN_FIDELITY {
                    let decrease = cost - trial_cost;
                    poses = trial;
                    cost = trial_cost;
                    lambda = (lambda / LAMBDA_FACTOR).max(LAMBDA_MIN);
                    if decrease <= TOLERANCE_ABSOLUTE || decrease <= TOLERANCE_RELATIVE * cost {
                        break 'iterate;
                    }
                    break;
                }
            }
            lambda *= LAMBDA_FACTOR;
            if lambda > LAMBDA_MAX {
                // No step lowers the cost: a minimum to within rounding.
                break 'iterate;
            }
        }
    }
    let landmark_covariance = marginals(&factors, &layout, &poses, problem, &mut cholesky)?;
    let (keyframes, landmarks) = poses.split_at(k);
    Ok(Solution {
        keyframes: keyframes.to_vec(),
        landmarks: landmarks.to_vec(),
        landmark_covariance,
        error_before,
        error_after: cost,
        iterations,
    })
}

/// Each landmark's 3×3 block of `H⁻¹` at `poses` (see the module's "Marginals").
fn marginals(
    factors: &[Factor],
    layout: &Layout,
    poses: &Poses,
    problem: &Problem,
    cholesky: &mut Cholesky,
) -> Result<Vec<Matrix3<f64>>, GraphError> {
    if problem.landmarks.is_empty() {
        // Nothing to report (and a chain of keyframes held by a 10 km prior alone is too
        // ill-conditioned to factor).
        return Ok(Vec::new());
    }
    let n = layout.dim();
    let mut h = vec![0.0; layout.pattern.nnz()];
    let mut g = vec![0.0; n];
    evaluate(factors, layout, poses, Some((&mut h[..], &mut g[..])));
    if !cholesky.factor(&h) {
        return Err(GraphError::Solver(
            "the information matrix at the solution is singular: a landmark or keyframe is tied to nothing".into(),
        ));
    }
    let l = cholesky
        .numeric
        .as_ref()
        .ok_or_else(|| GraphError::Solver("the factor went missing".into()))?
        .l();
    let (offsets, rows, values) = l.csc_data();
    let k = problem.keyframes.len();
    let mut y = vec![[0.0f64; 3]; n];
    let mut out = Vec::with_capacity(problem.landmarks.len());
    for j in 0..problem.landmarks.len() {
        let start = 3 * layout.position[k + j];
        y[start..].fill([0.0; 3]);
        for d in 0..3 {
            y[start + d][d] = 1.0;
        }
        let mut cov = Matrix3::zeros();
        for c in start..n {
            let first = offsets[c];
            let diagonal = values[first];
            let yc = y[c].map(|v| v / diagonal);
            if yc == [0.0; 3] {
                continue;
            }
            let v = Vector3::from(yc);
            cov += v * v.transpose();
            for q in first + 1..offsets[c + 1] {
                let (r, lv) = (rows[q], values[q]);
                for d in 0..3 {
                    y[r][d] -= lv * yc[d];
                }
            }
        }
        out.push(cov);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::survey::graph::Relative;

    fn relative(from: usize, to: usize) -> Relative {
        Relative {
            from,
            to,
            z: SimPose::new(0.0, 0.0, 0.0),
            covariance: Matrix3::identity(),
        }
    }

    #[test]
    fn landmarks_are_ordered_after_the_last_keyframe_that_sees_them() {
        let p = Problem {
            keyframes: vec![SimPose::new(0.0, 0.0, 0.0); 4],
            landmarks: vec![SimPose::new(0.0, 0.0, 0.0); 3],
            observations: vec![relative(0, 1), relative(2, 1), relative(1, 0)],
            ..Problem::default()
        };
        // Keyframes 0..4 are variables 0..4, landmarks 4..7; landmark 2 is seen from none.
        // Order: x0 x1 l0 x2 l1 x3 l2.
        assert_eq!(chain_order(&p), vec![0, 1, 3, 5, 2, 4, 6]);
    }

    #[test]
    fn the_diagonal_is_the_first_entry_of_each_column_of_the_factor() {
        // What the marginals' forward substitution relies on.
        let p = Problem {
            keyframes: vec![SimPose::new(0.0, 0.0, 0.0); 3],
            landmarks: vec![SimPose::new(1.0, 1.0, 0.0)],
            steps: vec![relative(0, 1), relative(1, 2), relative(0, 2)],
            observations: vec![relative(0, 0), relative(2, 0)],
            ..Problem::default()
        };
        let mut f = factors(&p).unwrap();
        let layout = Layout::new(&p, &f).unwrap();
        assign_slots(&mut f, &layout).unwrap();
        let poses: Poses = p.keyframes.iter().chain(&p.landmarks).copied().collect();
        let mut h = vec![0.0; layout.pattern.nnz()];
        let mut g = vec![0.0; layout.dim()];
        evaluate(&f, &layout, &poses, Some((&mut h[..], &mut g[..])));
        let mut c = Cholesky::new(&layout);
        assert!(c.factor(&h));
        let l = c.numeric.as_ref().unwrap().l();
        for col in 0..layout.dim() {
            assert_eq!(l.col(col).row_indices()[0], col);
        }
    }
}
