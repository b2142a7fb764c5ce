//! # host-sim: tunnel, vehicle and LMS511 simulator, and the engineer's tool
//!
//! Simulates a skid-steer loader driving through a mining tunnel with passive landmarks,
//! scans it with a simulated SICK LMS511, and runs loc-core's localiser in closed loop
//! exactly as the vehicle does (odometry and every scan in, pose out), then scores it
//! against ground truth with the paper's metrics.
//!
//! Module map (one concern each):
//! - [`world`]: centre line, wall roughness, landmark layout; true geometry vs design.
//! - [`raycast`]: uniform-grid spatial index and ray casting over the true geometry.
//! - [`lidar`]: the LMS511 model (rates, field of view, noise, no echo, up to five echoes,
//!   `u16` mm); [`lidar::dust`] the dust and spray clouds in front of it.
//! - [`traffic`]: people and vehicles moving through the tunnel, in the scans, not the map.
//! - [`vehicle`]: ICR skid-steer kinematics with slip, path follower, wheel odometry.
//!
//! Frames: world (the map's, metres), vehicle (x forward, y left), sensor (the LMS511's).
//! The simulator's own state is `f64`; what goes into loc-core is `f32`, as on the MCU.

pub mod closed_loop;
pub mod design;
pub mod estimator;
pub mod hil;
pub mod landmarks;
pub mod lidar;
pub mod map_export;
pub mod mcap_out;
pub mod metrics;
pub mod noise_spread;
pub mod odometry_gaps;
pub mod optimize;
pub mod output;
pub mod plot;
pub mod raycast;
pub mod record;
pub mod relocalise_study;
pub mod replay;
pub mod report;
pub mod scenario;
pub mod session;
pub mod status;
pub mod stored_map;
pub mod survey;
pub mod traffic;
pub mod vehicle;
pub mod visuals;
pub mod world;
