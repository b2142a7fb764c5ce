//! The stored map: tunnel walls and landmarks in world coordinates, and the queries the
//! estimator makes against it.

mod query;

pub use query::{FeatureKind, MapHit, MapQuery, RayHit};
