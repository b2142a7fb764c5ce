//! The search space of one landmark model: its genes in genome order {W, H, D, h1…h6},
//! their names, units and bounds (loc-core's [`GeneBounds`], Table 1 as loc-core reads it),
//! and the way back from a gene vector to a [`LandmarkChoice`].

use loc_core::landmark::{GeneBounds, LandmarkModel};

use crate::landmarks::{LandmarkChoice, LandmarkChoiceError};

/// One gene vector of the GA, in genome order, SI units (metres; h1…h6 as multiples of H).
pub type Genes = Vec<f64>;

/// The genes of one model and their bounds.
#[derive(Debug, Clone, PartialEq)]
pub struct GeneSpace {
    /// The landmark model searched.
    pub model: LandmarkModel,
    /// `[min, max]` of each gene, genome order.
    pub bounds: Vec<(f64, f64)>,
}

impl GeneSpace {
    /// The space of `model` with loc-core's bounds.
    pub fn for_model(model: LandmarkModel) -> Self {
        let b = GeneBounds::for_model(model);
        let bounds = (0..model.gene_count())
            .filter_map(|i| b.gene(i))
            .map(|r| (f64::from(r.min), f64::from(r.max)))
            .collect();
        Self { model, bounds }
    }

    /// Number of genes.
    pub fn len(&self) -> usize {
        self.bounds.len()
    }

    /// Always false: every model has W, H and D.
    pub fn is_empty(&self) -> bool {
        self.bounds.is_empty()
    }

    /// Name of gene `i` (`W`, `H`, `D`, `h1`…`h6`).
    pub fn name(&self, i: usize) -> String {
        match i {
            0 => "W".into(),
            1 => "H".into(),
            2 => "D".into(),
            _ => format!("h{}", i - 2),
        }
    }

    /// Unit of gene `i`: `m`, or `H` for the node heights (multiples of H).
    pub fn unit(&self, i: usize) -> &'static str {
        if i < 3 {
            "m"
        } else {
            "H"
        }
    }

    /// Index of the spacing gene D.
    pub const SPACING: usize = 2;

    /// `genes` clamped into the bounds, gene by gene (NaN becomes the lower bound).
    pub fn clamp(&self, genes: &mut [f64]) {
        for (g, &(lo, hi)) in genes.iter_mut().zip(&self.bounds) {
            *g = if g.is_nan() { lo } else { g.clamp(lo, hi) };
        }
    }

    /// The landmark design of a gene vector (which must lie within the bounds).
    pub fn choice(&self, genes: &[f64]) -> Result<LandmarkChoice, LandmarkChoiceError> {
        LandmarkChoice::parse(self.model.code(), Some(genes))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_names_and_clamping() {
        let p1 = GeneSpace::for_model(LandmarkModel::P1Triangle);
        assert_eq!(p1.len(), 3);
        assert_eq!(p1.bounds[2], (1.25, 100.0));
        let f4 = GeneSpace::for_model(LandmarkModel::F4SymmetricInverted);
        assert_eq!(f4.len(), 9);
        assert_eq!(f4.name(3), "h1");
        assert_eq!(f4.name(8), "h6");
        assert_eq!(f4.unit(8), "H");
        let mut g = vec![-1.0, f64::NAN, 1e9];
        p1.clamp(&mut g);
        assert_eq!(g, vec![p1.bounds[0].0, p1.bounds[1].0, 100.0]);
        // Every bound itself is a valid design (f32 round trip included).
        let lo: Vec<f64> = f4.bounds.iter().map(|b| b.0).collect();
        let hi: Vec<f64> = f4.bounds.iter().map(|b| b.1).collect();
        assert!(f4.choice(&lo).is_ok());
        assert!(f4.choice(&hi).is_ok());
    }
}
