//! Property tests of landmark profiles: every genome within the bounds of its model gives
//! a well-formed outline (ends on the wall, no height below the wall, u increasing, within
//! capacity), and any genome at all (NaN, huge) gives no panic.

use loc_core::landmark::{GeneBounds, Genome, LandmarkModel, Profile, MAX_PROFILE_VERTICES};
use proptest::prelude::*;

fn model() -> impl Strategy<Value = LandmarkModel> {
    (0u8..8).prop_map(|t| LandmarkModel::from_tag(t).unwrap())
}

/// A genome within the model's bounds, from unit draws.
fn in_bounds(model: LandmarkModel, unit: [f32; 9]) -> Genome {
    let b = GeneBounds::for_model(model);
    let genes: Vec<f32> = (0..model.gene_count())
        .map(|i| {
            let r = b.gene(i).unwrap();
            r.min + unit[i] * r.span()
        })
        .collect();
    Genome::from_genes(&genes)
}

proptest! {
    #[test]
    fn in_bounds_genomes_give_well_formed_profiles(m in model(), unit in prop::array::uniform9(0.0f32..=1.0)) {
        let g = in_bounds(m, unit);
        prop_assert_eq!(GeneBounds::for_model(m).check(&g), Ok(()));
        let p = Profile::new(m, &g);
        let v = p.vertices();
        prop_assert!(v.len() >= 3 && v.len() <= MAX_PROFILE_VERTICES);
        let half = 0.5 * g.width_m;
        prop_assert!((v[0].x_m + half).abs() < 1e-6 && v[0].y_m == 0.0);
        let last = v[v.len() - 1];
        prop_assert!((last.x_m - half).abs() < 1e-6 && last.y_m == 0.0);
        for w in v.windows(2) {
            prop_assert!(w[1].x_m >= w[0].x_m - 1e-6);
        }
        let max_h = if m.is_piecewise() { 3.0 * g.height_m } else { g.height_m };
        prop_assert!(v.iter().all(|q| q.y_m >= 0.0 && q.y_m <= max_h + 1e-6));
        if m.is_symmetric() {
            for i in 0..=20 {
                let u = -half + g.width_m * i as f32 / 20.0;
                prop_assert!((p.height_at(u) - p.height_at(-u)).abs() < 1e-4);
            }
        }
    }

    #[test]
    fn any_genome_never_panics(m in model(), genes in prop::array::uniform9(any::<f32>())) {
        let g = Genome::from_genes(&genes);
        let p = Profile::new(m, &g);
        prop_assert!(p.vertices().len() <= MAX_PROFILE_VERTICES);
        let _ = p.height_at(0.1);
        let _ = GeneBounds::for_model(m).check(&g);
    }
}
