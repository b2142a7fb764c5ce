//! Passive landmark designs (§4.1 of the paper, Table 1): the eight models, their genomes
//! and bounds, the profile polyline each design expands to, and its placement on a wall.
//!
//! - [`LandmarkModel`]: P1 triangle, P2 rectangle, P3 parabola, P4 ramp, F1…F4 piecewise.
//! - [`Genome`], [`GeneBounds`]: the genes {W, H, D, h1…h6} and Table 1 (with the
//!   corrections explained in the `genome` module docs).
//! - [`Profile`]: the cross-section in the landmark frame (u along the wall, v out of it).
//! - [`WallFrame`]: anchor, tangent and inward normal on a wall → world polyline.

mod genome;
mod model;
mod placement;
mod profile;

pub use genome::{Gene, GeneBounds, GeneRange, Genome, MAX_GENES, PIECEWISE_HEIGHTS};
pub use model::LandmarkModel;
pub use placement::WallFrame;
pub use profile::{Profile, MAX_PROFILE_SEGMENTS, MAX_PROFILE_VERTICES, PARABOLA_VERTICES};

/// One landmark design: a model and its genome.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LandmarkShape {
    /// Which shape function.
    pub model: LandmarkModel,
    /// Its genes.
    pub genome: Genome,
}

impl LandmarkShape {
    /// A design from its model and genome.
    pub const fn new(model: LandmarkModel, genome: Genome) -> Self {
        Self { model, genome }
    }

    /// The model with [`Genome::paper_default`].
    pub fn paper_default(model: LandmarkModel) -> Self {
        Self::new(model, Genome::paper_default(model))
    }

    /// Checks the genome against [`GeneBounds::for_model`].
    pub fn check(&self) -> Result<(), Gene> {
        GeneBounds::for_model(self.model).check(&self.genome)
    }

    /// The expanded cross-section in the landmark frame.
    pub fn profile(&self) -> Profile {
        Profile::new(self.model, &self.genome)
    }
}
