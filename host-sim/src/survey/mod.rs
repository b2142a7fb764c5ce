//! `host-sim survey`: the as-built map from one recorded drive.
pub mod graph;
pub mod landmark_fit;
