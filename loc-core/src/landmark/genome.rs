//! A landmark's genes (§4.1, eqs. 3 and 4) and their bounds (Table 1).
//!
//! ## Table 1 as printed, and how this crate reads it
//! | genes | H (m) | W (m) | D (m) | h1…h6 |
//! |---|---|---|---|---|
//! | primitives | 0.01–0.30 | 0.01–0.60 | 0–100 | – |
//! | piecewise | 0.01–0.35 | 0.05–**0.150** | 0–**750** | −2.00–2.00 |
//!
//! Two printed values are implausible and [`GeneBounds::for_model`] corrects them (the
//! printed ones stay available as [`GeneBounds::table1_as_printed`]):
//! - piecewise **W max 0.150 m** would make each of the six segments at most 25 mm long,
//!   about one beam spacing where the lidar grazes the wall a few metres ahead, so the shape
//!   the GA optimises could not be seen; and it is below the primitives' 0.60 m although the
//!   free shapes are meant to be richer. Read as a misplaced decimal point: **1.50 m**.
//! - piecewise **D max 750 m** is 7.5 times the primitives' 100 m in a 10 m simulated
//!   tunnel; the optimum found was 7–8 m. Read as **100 m**, like the primitives.
//! - **D min 0** (both) would let consecutive landmarks overlap and makes the layout's
//!   `U[D − 0.625, D + 0.625]` spacing negative: raised to **1.25 m** (so every drawn spacing
//!   is at least 0.625 m).

use serde::{Deserialize, Serialize};

use super::LandmarkModel;

/// Number of piecewise-linear heights h1…h6.
pub const PIECEWISE_HEIGHTS: usize = 6;

/// Total genes of the largest genome ({W, H, D, h1…h6}).
pub const MAX_GENES: usize = 3 + PIECEWISE_HEIGHTS;

/// The genes of one landmark design. The primitives use `width_m`, `height_m` and
/// `spacing_m` only and keep `heights` at zero.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Genome {
    /// W: width of the landmark along the wall, metres.
    pub width_m: f32,
    /// H: height (primitives) or height scale (piecewise) out of the wall, metres.
    pub height_m: f32,
    /// D: reference spacing between consecutive landmarks along the wall, metres. A layout
    /// gene: it does not change the shape.
    pub spacing_m: f32,
    /// h1…h6: node heights of the piecewise-linear shapes as multiples of H (h0 = 0 is
    /// implicit). Unitless.
    pub heights: [f32; PIECEWISE_HEIGHTS],
}

/// Closed interval of one gene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeneRange {
    /// Smallest allowed value.
    pub min: f32,
    /// Largest allowed value.
    pub max: f32,
}

impl GeneRange {
    /// True when `v` is finite and within `[min, max]`.
    #[inline]
    pub fn contains(&self, v: f32) -> bool {
        v.is_finite() && v >= self.min && v <= self.max
    }

    /// `v` clamped into the range (NaN becomes `min`).
    #[inline]
    pub fn clamp(&self, v: f32) -> f32 {
        if v.is_nan() {
            self.min
        } else {
            v.clamp(self.min, self.max)
        }
    }

    /// Width of the range, `max − min`.
    #[inline]
    pub fn span(&self) -> f32 {
        self.max - self.min
    }
}

/// Which gene failed validation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Gene {
    /// W.
    Width,
    /// H.
    Height,
    /// D.
    Spacing,
    /// h1…h6 (`0` is h1).
    NodeHeight(u8),
}

/// The bounds of every gene of one model, in genome order {W, H, D, h1…h6}.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeneBounds {
    /// W, metres.
    pub width_m: GeneRange,
    /// H, metres.
    pub height_m: GeneRange,
    /// D, metres.
    pub spacing_m: GeneRange,
    /// h1…h6, multiples of H; `None` for the primitives.
    pub heights: Option<GeneRange>,
}

/// Smallest reference spacing allowed (see the module docs).
const MIN_SPACING_M: f32 = 1.25;

impl GeneBounds {
    /// The bounds this crate uses for `model`: Table 1 with the corrections of the module
    /// docs (piecewise W ≤ 1.50 m, D ∈ [1.25, 100] m for all).
    pub fn for_model(model: LandmarkModel) -> Self {
        let printed = Self::table1_as_printed(model);
        let spacing_m = GeneRange {
            min: MIN_SPACING_M,
            max: 100.0,
        };
        if model.is_piecewise() {
            Self {
                width_m: GeneRange {
                    min: printed.width_m.min,
                    max: 1.50,
                },
                spacing_m,
                ..printed
            }
        } else {
            Self {
                spacing_m,
                ..printed
            }
        }
    }

    /// Table 1 exactly as printed in the paper (including the values the module docs
    /// explain as misprints).
    pub fn table1_as_printed(model: LandmarkModel) -> Self {
        if model.is_piecewise() {
            Self {
                width_m: GeneRange {
                    min: 0.05,
                    max: 0.150,
                },
                height_m: GeneRange {
                    min: 0.01,
                    max: 0.35,
                },
                spacing_m: GeneRange {
                    min: 0.0,
                    max: 750.0,
                },
                heights: Some(GeneRange {
                    min: -2.0,
                    max: 2.0,
                }),
            }
        } else {
            Self {
                width_m: GeneRange {
                    min: 0.01,
                    max: 0.60,
                },
                height_m: GeneRange {
                    min: 0.01,
                    max: 0.30,
                },
                spacing_m: GeneRange {
                    min: 0.0,
                    max: 100.0,
                },
                heights: None,
            }
        }
    }

    /// The range of gene `index` in genome order {W, H, D, h1…h6}, or `None` past the
    /// model's last gene.
    pub fn gene(&self, index: usize) -> Option<GeneRange> {
        match index {
            0 => Some(self.width_m),
            1 => Some(self.height_m),
            2 => Some(self.spacing_m),
            3..MAX_GENES => self.heights,
            _ => None,
        }
    }

    /// Checks every gene of `genome` the model uses; the first gene out of bounds (or
    /// non-finite) is the error. Unused heights of a primitive must be zero.
    pub fn check(&self, genome: &Genome) -> Result<(), Gene> {
        if !self.width_m.contains(genome.width_m) {
            return Err(Gene::Width);
        }
        if !self.height_m.contains(genome.height_m) {
            return Err(Gene::Height);
        }
        if !self.spacing_m.contains(genome.spacing_m) {
            return Err(Gene::Spacing);
        }
        for (i, &h) in (0u8..).zip(genome.heights.iter()) {
            let ok = match self.heights {
                Some(r) => r.contains(h),
                None => h == 0.0,
            };
            if !ok {
                return Err(Gene::NodeHeight(i));
            }
        }
        Ok(())
    }
}

impl Genome {
    /// A primitive's genome {W, H, D}.
    pub const fn primitive(width_m: f32, height_m: f32, spacing_m: f32) -> Self {
        Self {
            width_m,
            height_m,
            spacing_m,
            heights: [0.0; PIECEWISE_HEIGHTS],
        }
    }

    /// A piecewise-linear genome {W, H, D, h1…h6}.
    pub const fn piecewise(
        width_m: f32,
        height_m: f32,
        spacing_m: f32,
        heights: [f32; PIECEWISE_HEIGHTS],
    ) -> Self {
        Self {
            width_m,
            height_m,
            spacing_m,
            heights,
        }
    }

    /// A design near the paper's optimum for `model`.
    ///
    /// The paper prints only the optimal spacing (D ≈ 9–10 m for primitives, 7–8 m for the
    /// free shapes, §5.1); W, H and h1…h6 are this crate's choices:
    /// - primitives: W = 0.50 m, H = 0.25 m, D = 9.5 m: large within Table 1 so a landmark
    ///   catches several beams at ~10 m along a 5 m tunnel, yet clear of the bounds.
    /// - free shapes: W = 1.0 m, H = 0.30 m, D = 7.5 m (W uses the corrected 1.50 m
    ///   bound); heights: F1 an asymmetric saw `[0.3, 0.9, 0.2, 0.6, 1.0, 0.0]`;
    ///   F2 `[0.6, 0.1, 0.8, 0.3, 0.9, 1.0]`; F3 an "M" `[0.5, 1.0, 0.0, 1.0, 0.5, 0.0]`;
    ///   F4 the same heights inverted, a "W" like the paper's Figure 7h.
    pub fn paper_default(model: LandmarkModel) -> Self {
        const PRIMITIVE: Genome = Genome::primitive(0.50, 0.25, 9.5);
        const M_SHAPE: [f32; PIECEWISE_HEIGHTS] = [0.5, 1.0, 0.0, 1.0, 0.5, 0.0];
        match model {
            LandmarkModel::P1Triangle
            | LandmarkModel::P2Rectangle
            | LandmarkModel::P3Parabola
            | LandmarkModel::P4Ramp => PRIMITIVE,
            LandmarkModel::F1Free => {
                Self::piecewise(1.0, 0.30, 7.5, [0.3, 0.9, 0.2, 0.6, 1.0, 0.0])
            }
            LandmarkModel::F2Inverted => {
                Self::piecewise(1.0, 0.30, 7.5, [0.6, 0.1, 0.8, 0.3, 0.9, 1.0])
            }
            LandmarkModel::F3Symmetric | LandmarkModel::F4SymmetricInverted => {
                Self::piecewise(1.0, 0.30, 7.5, M_SHAPE)
            }
        }
    }

    /// The genes in genome order {W, H, D, h1…h6}; a primitive uses the first 3
    /// ([`LandmarkModel::gene_count`]).
    pub fn to_genes(&self) -> [f32; MAX_GENES] {
        let [h1, h2, h3, h4, h5, h6] = self.heights;
        [
            self.width_m,
            self.height_m,
            self.spacing_m,
            h1,
            h2,
            h3,
            h4,
            h5,
            h6,
        ]
    }

    /// A genome from genes in genome order; missing genes are 0, extra ones ignored.
    pub fn from_genes(genes: &[f32]) -> Self {
        let mut all = [0.0_f32; MAX_GENES];
        for (dst, &src) in all.iter_mut().zip(genes) {
            *dst = src;
        }
        let [w, h, d, h1, h2, h3, h4, h5, h6] = all;
        Self::piecewise(w, h, d, [h1, h2, h3, h4, h5, h6])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_within_bounds() {
        for m in LandmarkModel::ALL {
            let g = Genome::paper_default(m);
            assert_eq!(GeneBounds::for_model(m).check(&g), Ok(()), "{m:?}");
            let d = g.spacing_m;
            if m.is_piecewise() {
                assert!((7.0..=8.0).contains(&d));
            } else {
                assert!((9.0..=10.0).contains(&d));
            }
        }
    }

    #[test]
    fn bounds_reject_out_of_range_and_nan() {
        let b = GeneBounds::for_model(LandmarkModel::P1Triangle);
        let mut g = Genome::paper_default(LandmarkModel::P1Triangle);
        g.height_m = 0.31;
        assert_eq!(b.check(&g), Err(Gene::Height));
        g.height_m = f32::NAN;
        assert_eq!(b.check(&g), Err(Gene::Height));
        let mut g = Genome::paper_default(LandmarkModel::P1Triangle);
        g.heights[2] = 0.5;
        assert_eq!(b.check(&g), Err(Gene::NodeHeight(2)));
        let bf = GeneBounds::for_model(LandmarkModel::F1Free);
        let mut f = Genome::paper_default(LandmarkModel::F1Free);
        f.heights[5] = 2.5;
        assert_eq!(bf.check(&f), Err(Gene::NodeHeight(5)));
        assert_eq!(
            bf.gene(8),
            Some(GeneRange {
                min: -2.0,
                max: 2.0
            })
        );
        assert_eq!(b.gene(3), None);
        assert_eq!(
            GeneBounds::table1_as_printed(LandmarkModel::F2Inverted)
                .width_m
                .max,
            0.150
        );
    }

    #[test]
    fn genes_round_trip() {
        let g = Genome::paper_default(LandmarkModel::F4SymmetricInverted);
        assert_eq!(Genome::from_genes(&g.to_genes()), g);
        let p = Genome::from_genes(&[0.4, 0.2, 9.0]);
        assert_eq!(p, Genome::primitive(0.4, 0.2, 9.0));
    }
}
