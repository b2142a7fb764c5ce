//! The two objectives of landmark design on the paper's P1 optimum in `paper-10m`: one
//! simulated fitness (a whole closed-loop run, the GA's evaluation) against one
//! evaluation of the deterministic Fisher objective (24 traced scans). Their ratio is the
//! "at least 1000 times cheaper" figure of the README.
//!
//! `cargo bench -p host-sim --bench objectives -- --warm-up-time 1 --measurement-time 3`

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;

use host_sim::optimize::fitness::{ObjectiveKind, SearchObjective};
use host_sim::optimize::genes::GeneSpace;
use host_sim::scenario::named::named;
use loc_core::landmark::LandmarkModel;

fn objectives(c: &mut Criterion) {
    let s = named("paper-10m").expect("named scenario");
    let space = GeneSpace::for_model(LandmarkModel::P1Triangle);
    let obj = SearchObjective::new(ObjectiveKind::Fisher, &s, space);
    let genes = [0.5, 0.25, 9.5];
    let mut g = c.benchmark_group("landmark_objective");
    g.sample_size(10);
    g.bench_function("simulated_fitness_paper_10m_p1", |b| {
        b.iter(|| black_box(obj.simulated.evaluate(&genes, 1).expect("run").mse_eq2))
    });
    g.finish();
    c.bench_function("fisher_objective_paper_10m_p1", |b| {
        b.iter(|| black_box(obj.fitness(&genes, &[]).expect("fisher")))
    });
}

criterion_group!(benches, objectives);
criterion_main!(benches);
