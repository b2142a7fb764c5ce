//! Which landmark design a run uses: none, or one of loc-core's eight models with the
//! paper-optimum genome or genes given by the user, expanded to the profile polyline the
//! world places on its walls.

use std::fmt;

use loc_core::landmark::{GeneBounds, Genome, LandmarkModel, LandmarkShape};

use crate::world::Profile;

/// The landmark design of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LandmarkChoice {
    /// A bare tunnel.
    None,
    /// Landmarks of this design.
    Shape(LandmarkShape),
}

/// Why a landmark choice was rejected.
#[derive(Debug, Clone, PartialEq)]
pub enum LandmarkChoiceError {
    /// The model name is not one of none, p1…p4, f1…f4.
    UnknownModel(String),
    /// A gene was not a number.
    BadGene(String),
    /// Wrong number of genes for the model.
    GeneCount {
        /// The model.
        model: &'static str,
        /// Genes given.
        given: usize,
    },
    /// A gene is outside its bounds (Table 1 as loc-core reads it).
    OutOfBounds {
        /// The gene's name.
        gene: String,
        /// Allowed range.
        min: f32,
        /// Allowed range.
        max: f32,
    },
    /// Genes given for `none`.
    GenesWithoutModel,
}

impl fmt::Display for LandmarkChoiceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::UnknownModel(m) => write!(
                f,
                "unknown landmark model `{m}`: use none, p1, p2, p3, p4, f1, f2, f3 or f4"
            ),
            Self::BadGene(g) => write!(f, "gene `{g}` is not a number"),
            Self::GeneCount { model, given } => write!(
                f,
                "{model} takes genes W,H,D (primitives) or W,H,D,h1..h6 (free shapes); {given} given"
            ),
            Self::OutOfBounds { gene, min, max } => {
                write!(f, "gene {gene} must lie in [{min}, {max}] (Table 1)")
            }
            Self::GenesWithoutModel => write!(f, "genes were given but the landmark model is none"),
        }
    }
}

impl std::error::Error for LandmarkChoiceError {}

impl LandmarkChoice {
    /// Parses a model name (`none`, `p1`…`f4`, case-insensitive) and optional genes
    /// (W, H, D and, for F1–F4, h1…h6); without genes the model's paper-optimum default.
    pub fn parse(model: &str, genes: Option<&[f64]>) -> Result<Self, LandmarkChoiceError> {
        if model.eq_ignore_ascii_case("none") {
            return match genes {
                Some(_) => Err(LandmarkChoiceError::GenesWithoutModel),
                None => Ok(LandmarkChoice::None),
            };
        }
        let m = LandmarkModel::from_code(model)
            .ok_or_else(|| LandmarkChoiceError::UnknownModel(model.to_string()))?;
        let genome = match genes {
            None => Genome::paper_default(m),
            Some(g) => {
                if g.len() != 3 && g.len() != m.gene_count() {
                    return Err(LandmarkChoiceError::GeneCount {
                        model: m.code(),
                        given: g.len(),
                    });
                }
                let f: Vec<f32> = g.iter().map(|&v| v as f32).collect();
                let mut genome = Genome::from_genes(&f);
                if g.len() == 3 && m.is_piecewise() {
                    genome.heights = Genome::paper_default(m).heights;
                }
                genome
            }
        };
        let shape = LandmarkShape::new(m, genome);
        shape.check().map_err(|gene| {
            let b = GeneBounds::for_model(m);
            let (name, r) = match gene {
                loc_core::landmark::Gene::Width => ("W".to_string(), b.width_m),
                loc_core::landmark::Gene::Height => ("H".to_string(), b.height_m),
                loc_core::landmark::Gene::Spacing => ("D".to_string(), b.spacing_m),
                loc_core::landmark::Gene::NodeHeight(i) => {
                    (format!("h{}", i + 1), b.heights.unwrap_or(b.height_m))
                }
            };
            LandmarkChoiceError::OutOfBounds {
                gene: name,
                min: r.min,
                max: r.max,
            }
        })?;
        Ok(LandmarkChoice::Shape(shape))
    }

    /// Parses a comma-separated gene list such as `0.5,0.25,9.5`.
    pub fn parse_genes(text: &str) -> Result<Vec<f64>, LandmarkChoiceError> {
        text.split(',')
            .map(|g| {
                g.trim()
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| LandmarkChoiceError::BadGene(g.trim().to_string()))
            })
            .collect()
    }

    /// The paper's short name ("P1"…"F4") or "none".
    pub fn code(&self) -> &'static str {
        match self {
            LandmarkChoice::None => "none",
            LandmarkChoice::Shape(s) => s.model.code(),
        }
    }

    /// The nominal spacing D, metres (0 for none).
    pub fn spacing_m(&self) -> f64 {
        match self {
            LandmarkChoice::None => 0.0,
            LandmarkChoice::Shape(s) => f64::from(s.genome.spacing_m),
        }
    }

    /// The profile polyline in the landmark frame (empty for none).
    pub fn profile(&self) -> Profile {
        match self {
            LandmarkChoice::None => Vec::new(),
            LandmarkChoice::Shape(s) => s
                .profile()
                .vertices()
                .iter()
                .map(|p| (f64::from(p.x_m), f64::from(p.y_m)))
                .collect(),
        }
    }

    /// The genes in genome order (the model's count), for reports.
    pub fn genes(&self) -> Vec<f64> {
        match self {
            LandmarkChoice::None => Vec::new(),
            LandmarkChoice::Shape(s) => s.genome.to_genes()[..s.model.gene_count()]
                .iter()
                // Genes are f32 in loc-core: round to the micrometre so 0.3 reads 0.3.
                .map(|&v| (f64::from(v) * 1e6).round() / 1e6)
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_genes_and_errors() {
        let p1 = LandmarkChoice::parse("P1", None).unwrap();
        assert_eq!(p1.code(), "P1");
        let prof = p1.profile();
        assert_eq!(prof.len(), 3);
        assert!(prof[1].1 > 0.0);
        let g = LandmarkChoice::parse_genes("0.4, 0.2, 8").unwrap();
        let custom = LandmarkChoice::parse("p2", Some(&g)).unwrap();
        assert!((custom.spacing_m() - 8.0).abs() < 1e-6);
        assert_eq!(custom.genes().len(), 3);
        let f4 = LandmarkChoice::parse("f4", None).unwrap();
        assert_eq!(f4.genes().len(), 9);
        assert_eq!(
            LandmarkChoice::parse("none", None).unwrap().profile(),
            vec![]
        );
        assert!(matches!(
            LandmarkChoice::parse("p9", None),
            Err(LandmarkChoiceError::UnknownModel(_))
        ));
        assert!(matches!(
            LandmarkChoice::parse("p1", Some(&[0.5, 0.25])),
            Err(LandmarkChoiceError::GeneCount { .. })
        ));
        let e = LandmarkChoice::parse("p1", Some(&[5.0, 0.25, 9.0])).unwrap_err();
        assert!(e.to_string().contains("gene W"), "{e}");
        assert!(LandmarkChoice::parse_genes("0.5,x").is_err());
    }
}
