//! Planar geometry: points, SE(2) poses and line segments, all in metres and radians.
//!
//! Which frame a value is in (sensor, vehicle or world) is part of each API's docs; the
//! types themselves are frame-agnostic.

mod point;
mod pose;
mod segment;

pub use point::Point2;
pub use pose::{Pose2, PoseTransform};
pub use segment::{Segment, SegmentProjection};
