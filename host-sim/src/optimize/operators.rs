//! The GA's operators (§4.2): the initial draw, ranking, stochastic universal sampling,
//! elitism, uniform (scattered) crossover and Gaussian mutation, and one whole step from a
//! scored generation to the next.
//!
//! ## How the paper's words are read
//! - **Selection on a fitness to be minimised.** SUS lays the individuals along a line, each
//!   with a length proportional to its fitness; the MSE is to be *minimised*, so the length is
//!   taken from the rank instead (`1/√rank`, rank 1 = lowest MSE; the rank scaling of the GA
//!   tool the §4.2 wording follows). Lengths from `1/MSE` would hand almost every pointer to
//!   one lucky individual whenever one MSE is near zero.
//! - **"Best 5 % kept, 75 % of the rest recombined":** of N = 100, 5 elites go through
//!   unchanged, 71 children come from crossover (round(0.75 · 95)) and the other 24 from
//!   mutation. SUS draws two parents per crossover child and one per mutation child, and the
//!   parents are shuffled before pairing so that a parent is not paired with itself by order.
//! - **Mutation** adds `N(0, σ²)`, `σ = (max − min)/2`, to every gene of a mutation child and
//!   clamps it to the bounds; crossover children are not mutated.

use loc_core::rng::Pcg32;

use super::genes::{GeneSpace, Genes};

/// A uniform `f64` in `[0, 1)` with 53 random bits.
pub fn uniform01(rng: &mut Pcg32) -> f64 {
    let hi = u64::from(rng.next_u32() >> 5); // 27 bits
    let lo = u64::from(rng.next_u32() >> 6); // 26 bits
    ((hi << 26) | lo) as f64 * (1.0 / 9_007_199_254_740_992.0)
}

/// `n` genomes, each gene drawn from `U[min, max]` of its bounds.
pub fn initial_population(space: &GeneSpace, n: usize, rng: &mut Pcg32) -> Vec<Genes> {
    (0..n)
        .map(|_| {
            space
                .bounds
                .iter()
                .map(|&(lo, hi)| lo + (hi - lo) * uniform01(rng))
                .collect()
        })
        .collect()
}

/// Indices of the individuals by ascending fitness (best first); ties keep population order,
/// NaN ranks last.
pub fn ranking(fitness: &[f64]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..fitness.len()).collect();
    order.sort_by(|&a, &b| fitness[a].total_cmp(&fitness[b]));
    // total_cmp puts negative NaN first: move every NaN to the end, in order.
    let (mut finite, nan): (Vec<usize>, Vec<usize>) =
        order.into_iter().partition(|&i| !fitness[i].is_nan());
    finite.extend(nan);
    finite
}

/// Selection weight of each individual (population order): `1/√rank`, rank 1 = lowest MSE.
pub fn rank_weights(fitness: &[f64]) -> Vec<f64> {
    let mut w = vec![0.0; fitness.len()];
    for (r, i) in ranking(fitness).into_iter().enumerate() {
        w[i] = 1.0 / ((r + 1) as f64).sqrt();
    }
    w
}

/// Stochastic universal sampling: `n` pointers a constant `F/n` apart from a first one
/// drawn in `[0, F/n)` (`F` the total weight) over the individuals laid end to end, each
/// as long as its weight. Returns the index hit by each pointer, in pointer order.
/// An individual of weight `w` is selected `⌊n w / F⌋` or `⌈n w / F⌉` times.
pub fn stochastic_universal_sampling(weights: &[f64], n: usize, rng: &mut Pcg32) -> Vec<usize> {
    let total: f64 = weights.iter().sum();
    if weights.is_empty() || n == 0 || total.is_nan() || total <= 0.0 {
        return Vec::new();
    }
    let step = total / n as f64;
    let mut pointer = uniform01(rng) * step;
    let mut out = Vec::with_capacity(n);
    let mut i = 0;
    let mut end = weights[0];
    while out.len() < n {
        while pointer >= end && i + 1 < weights.len() {
            i += 1;
            end += weights[i];
        }
        out.push(i);
        pointer += step;
    }
    out
}

/// Fisher–Yates shuffle.
pub fn shuffle<T>(v: &mut [T], rng: &mut Pcg32) {
    for i in (1..v.len()).rev() {
        let j = rng.index(i + 1);
        v.swap(i, j);
    }
}

/// Uniform crossover: a random binary mask picks each gene from `a` (1) or `b` (0).
pub fn crossover_scattered(a: &[f64], b: &[f64], rng: &mut Pcg32) -> Genes {
    a.iter()
        .zip(b)
        .map(|(&x, &y)| if rng.next_u32() & 1 == 1 { x } else { y })
        .collect()
}

/// Gaussian mutation of every gene, `σ = (max − min)/2`, clamped to the bounds.
pub fn mutate_gaussian(parent: &[f64], space: &GeneSpace, rng: &mut Pcg32) -> Genes {
    let mut child: Genes = parent
        .iter()
        .zip(&space.bounds)
        .map(|(&g, &(lo, hi))| g + f64::from(rng.gaussian()) * (hi - lo) / 2.0)
        .collect();
    space.clamp(&mut child);
    child
}

/// How a generation of N is made: elites, crossover children, mutation children.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Composition {
    /// Best individuals copied unchanged.
    pub elite: usize,
    /// Children of uniform crossover.
    pub crossover: usize,
    /// Children of Gaussian mutation.
    pub mutation: usize,
}

impl Composition {
    /// The paper's split of `n`: `elite_fraction` of it (at least 1 when `n > 1`) kept,
    /// `crossover_fraction` of the rest crossed over, the remainder mutated.
    pub fn new(n: usize, elite_fraction: f64, crossover_fraction: f64) -> Self {
        let mut elite = (n as f64 * elite_fraction).round() as usize;
        if n > 1 {
            elite = elite.max(1);
        }
        let elite = elite.min(n);
        let rest = n - elite;
        let crossover = ((rest as f64 * crossover_fraction).round() as usize).min(rest);
        Self {
            elite,
            crossover,
            mutation: rest - crossover,
        }
    }

    /// Parents SUS must select: two per crossover child, one per mutation child.
    pub fn parents(&self) -> usize {
        2 * self.crossover + self.mutation
    }
}

/// One GA step: from a scored population to the next one (elites first, in rank order,
/// then the crossover children, then the mutation children).
pub fn next_generation(
    space: &GeneSpace,
    population: &[Genes],
    fitness: &[f64],
    composition: Composition,
    rng: &mut Pcg32,
) -> Vec<Genes> {
    let ranked = ranking(fitness);
    let mut next: Vec<Genes> = ranked
        .iter()
        .take(composition.elite)
        .map(|&i| population[i].clone())
        .collect();
    let mut parents =
        stochastic_universal_sampling(&rank_weights(fitness), composition.parents(), rng);
    shuffle(&mut parents, rng);
    let (pairs, singles) = parents.split_at(2 * composition.crossover);
    for pair in pairs.chunks_exact(2) {
        next.push(crossover_scattered(
            &population[pair[0]],
            &population[pair[1]],
            rng,
        ));
    }
    for &p in singles {
        next.push(mutate_gaussian(&population[p], space, rng));
    }
    next
}

#[cfg(test)]
mod tests {
    use super::*;
    use loc_core::landmark::LandmarkModel;

    fn p1() -> GeneSpace {
        GeneSpace::for_model(LandmarkModel::P1Triangle)
    }

    #[test]
    fn ranking_is_ascending_with_nan_last() {
        assert_eq!(
            ranking(&[3.0, f64::NAN, 1.0, 2.0, 1.0]),
            vec![2, 4, 3, 0, 1]
        );
        let w = rank_weights(&[3.0, 1.0, 2.0]);
        assert_eq!(w, vec![1.0 / 3f64.sqrt(), 1.0, 1.0 / 2f64.sqrt()]);
    }

    #[test]
    fn sus_selects_each_in_proportion_to_its_weight() {
        // Weights 4:2:1:1 of 8, 8 pointers: exactly 4, 2, 1, 1 selections whatever p0 is.
        let w = [4.0, 2.0, 1.0, 1.0];
        for seed in 0..50 {
            let mut rng = Pcg32::seeded(seed);
            let s = stochastic_universal_sampling(&w, 8, &mut rng);
            let count = |i| s.iter().filter(|&&k| k == i).count();
            assert_eq!((count(0), count(1), count(2), count(3)), (4, 2, 1, 1));
            assert!(s.windows(2).all(|p| p[0] <= p[1]), "pointer order");
        }
        // Non-integer expectations: floor or ceiling, never further (the SUS guarantee).
        let w = rank_weights(&[5.0, 1.0, 4.0, 2.0, 3.0, 0.5, 9.0]);
        let total: f64 = w.iter().sum();
        for seed in 0..200 {
            let mut rng = Pcg32::seeded(seed);
            let n = 166;
            let s = stochastic_universal_sampling(&w, n, &mut rng);
            assert_eq!(s.len(), n);
            for (i, wi) in w.iter().enumerate() {
                let e = n as f64 * wi / total;
                let c = s.iter().filter(|&&k| k == i).count() as f64;
                assert!(c >= e.floor() && c <= e.ceil(), "{i}: {c} vs {e}");
            }
        }
        assert!(stochastic_universal_sampling(&[], 3, &mut Pcg32::seeded(1)).is_empty());
    }

    #[test]
    fn composition_of_the_paper() {
        let c = Composition::new(100, 0.05, 0.75);
        assert_eq!((c.elite, c.crossover, c.mutation), (5, 71, 24));
        assert_eq!(c.parents(), 166);
        let small = Composition::new(4, 0.05, 0.75);
        assert_eq!((small.elite, small.crossover, small.mutation), (1, 2, 1));
    }

    #[test]
    fn crossover_takes_each_gene_from_one_parent_and_masks_vary() {
        let a = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0];
        let b = [-1.0, -2.0, -3.0, -4.0, -5.0, -6.0, -7.0, -8.0, -9.0];
        let mut rng = Pcg32::seeded(3);
        let mut from_a = [0usize; 9];
        for _ in 0..2000 {
            let c = crossover_scattered(&a, &b, &mut rng);
            for (j, &g) in c.iter().enumerate() {
                assert!(g == a[j] || g == b[j]);
                if g == a[j] {
                    from_a[j] += 1;
                }
            }
        }
        // Each gene from `a` about half the time (binomial 2000, ½: ±4.5σ = ±100).
        for n in from_a {
            assert!((900..=1100).contains(&n), "{from_a:?}");
        }
    }

    #[test]
    fn mutation_spreads_by_half_the_range_and_is_clamped() {
        let space = p1();
        let mid: Genes = space.bounds.iter().map(|b| (b.0 + b.1) / 2.0).collect();
        let mut rng = Pcg32::seeded(9);
        let n = 4000;
        let mut clamped = 0;
        let mut inside_sq = vec![0.0; 3];
        for _ in 0..n {
            let c = mutate_gaussian(&mid, &space, &mut rng);
            for (j, (&g, &(lo, hi))) in c.iter().zip(&space.bounds).enumerate() {
                assert!(g >= lo && g <= hi, "gene {j} = {g} outside [{lo}, {hi}]");
                if g == lo || g == hi {
                    clamped += 1;
                }
                inside_sq[j] += ((g - mid[j]) / (hi - lo)).powi(2);
            }
        }
        // From the centre, σ = span/2 leaves the range with P(|z| > 1) = 31.7 %.
        let share = clamped as f64 / (3 * n) as f64;
        assert!((0.29..0.345).contains(&share), "{share}");
        // The variance of the clamped draw, in spans²: E[min(z², 1)]/4 = 0.5161/4 = 0.129.
        for s in inside_sq {
            let v = s / n as f64;
            assert!((0.12..0.14).contains(&v), "{v}");
        }
    }

    #[test]
    fn next_generation_keeps_the_elites_and_the_size() {
        let space = p1();
        let mut rng = Pcg32::seeded(5);
        let pop = initial_population(&space, 100, &mut rng);
        for g in &pop {
            for (v, b) in g.iter().zip(&space.bounds) {
                assert!(*v >= b.0 && *v < b.1);
            }
        }
        let fitness: Vec<f64> = pop.iter().map(|g| (g[2] - 9.0).abs()).collect();
        let c = Composition::new(100, 0.05, 0.75);
        let next = next_generation(&space, &pop, &fitness, c, &mut rng);
        assert_eq!(next.len(), 100);
        let ranked = ranking(&fitness);
        for k in 0..5 {
            assert_eq!(next[k], pop[ranked[k]], "elite {k}");
        }
        // Crossover children carry parents' genes exactly; mutation children are in bounds.
        for child in &next[5..76] {
            for (j, g) in child.iter().enumerate() {
                assert!(pop.iter().any(|p| p[j] == *g));
            }
        }
        // Same inputs, same generator state: the same next generation.
        let again = next_generation(&space, &pop, &fitness, c, &mut Pcg32::seeded(77));
        let again2 = next_generation(&space, &pop, &fitness, c, &mut Pcg32::seeded(77));
        assert_eq!(again, again2);
    }

    #[test]
    fn uniform01_covers_the_unit_interval() {
        let mut rng = Pcg32::seeded(1);
        let v: Vec<f64> = (0..10_000).map(|_| uniform01(&mut rng)).collect();
        assert!(v.iter().all(|&x| (0.0..1.0).contains(&x)));
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        assert!((mean - 0.5).abs() < 0.01);
    }
}
