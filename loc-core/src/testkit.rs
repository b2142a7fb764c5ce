//! Synthetic tunnels and a scan simulator for tests, benchmarks, firmware fixtures and the
//! integration tests (cargo feature `testkit`; always on for loc-core's own tests).
//!
//! - [`TunnelSpec`]: a straight or constant-curvature tunnel (default width 5 m) with walls
//!   sampled every `wall_step_m`, optionally with landmarks placed like the paper's §4.4:
//!   spacing `d ~ U[D − 0.625, D + 0.625]` m from a seeded generator, on both walls.
//!   [`TunnelSpec::build_into`] fills any [`StoredMap`].
//! - [`ScanSimulator`]: ray casts every beam of a [`SensorSetup`] from a true vehicle pose
//!   and adds Gaussian range noise (σ default 10 mm). Deterministic for a seed.
//!
//! Frames: the tunnel's centre line starts at the world origin heading +x; a curved tunnel
//! turns left (counter-clockwise) with the given centre-line radius.

// Compiled only for this crate's tests and with the `testkit` feature (kept here rather than
// in lib.rs so the module list there stays a plain list).
#![cfg(any(test, feature = "testkit"))]

use crate::geometry::{Point2, Pose2};
use crate::landmark::{Genome, LandmarkModel, LandmarkShape};
use crate::map::{LandmarkPlacement, MapError, MapQuery, StoredMap, WallSide};
use crate::math;
use crate::rng::Pcg32;
use crate::scan::{Scan, SensorSetup, LMS511_MAX_BEAMS};

/// Half-width of the random spacing interval around D, metres (§4.4).
pub const SPACING_JITTER_M: f32 = 0.625;

/// Landmarks on both walls of a synthetic tunnel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LandmarkLayout {
    /// Model and genome of every landmark; `genome.spacing_m` is the reference spacing D.
    pub shape: LandmarkShape,
    /// Seed of the spacing draws (left and right walls use separate streams).
    pub seed: u64,
    /// Arc position of the first landmark on each wall, metres (then `d ~ U[D ± 0.625]`).
    pub first_s_m: f32,
}

impl LandmarkLayout {
    /// `model` with [`Genome::paper_default`], first landmark at 2 m.
    pub fn paper(model: LandmarkModel, seed: u64) -> Self {
        Self {
            shape: LandmarkShape::new(model, Genome::paper_default(model)),
            seed,
            first_s_m: 2.0,
        }
    }
}

/// A synthetic tunnel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TunnelSpec {
    /// Length of the centre line, metres.
    pub length_m: f32,
    /// Distance between the walls, metres.
    pub width_m: f32,
    /// Centre-line radius of a left-turning tunnel, metres; `None` for a straight one.
    pub radius_m: Option<f32>,
    /// Spacing of the wall vertices along the centre line, metres.
    pub wall_step_m: f32,
    /// Landmarks, or none.
    pub landmarks: Option<LandmarkLayout>,
}

impl TunnelSpec {
    /// Width of the paper's simulated tunnel, metres.
    pub const DEFAULT_WIDTH_M: f32 = 5.0;
    /// Radius of the curved test tunnel, metres.
    pub const DEFAULT_RADIUS_M: f32 = 50.0;

    /// A straight tunnel, 5 m wide, walls sampled every 1 m, no landmarks.
    pub fn straight(length_m: f32) -> Self {
        Self {
            length_m,
            width_m: Self::DEFAULT_WIDTH_M,
            radius_m: None,
            wall_step_m: 1.0,
            landmarks: None,
        }
    }

    /// A tunnel turning left on a 50 m centre-line radius, 5 m wide, walls every 1 m.
    /// Beyond 2π · 50 m ≈ 314 m it would run over itself: keep `length_m` below that.
    pub fn curved(length_m: f32) -> Self {
        Self {
            radius_m: Some(Self::DEFAULT_RADIUS_M),
            ..Self::straight(length_m)
        }
    }

    /// The same tunnel with landmarks.
    pub fn with_landmarks(self, layout: LandmarkLayout) -> Self {
        Self {
            landmarks: Some(layout),
            ..self
        }
    }

    /// Pose on the centre line at arc length `s_m`, shifted `lateral_m` to the left,
    /// heading along the tunnel (world frame).
    pub fn centre_pose(&self, s_m: f32, lateral_m: f32) -> Pose2 {
        match self.radius_m {
            None => Pose2::new(s_m, lateral_m, 0.0),
            Some(r) => {
                let phi = s_m / r;
                let (sin, cos) = math::sin_cos(phi);
                // Circle centre at (0, r); radius r − lateral for a point left of the line.
                let rr = r - lateral_m;
                Pose2::new(rr * sin, r - rr * cos, phi)
            }
        }
    }

    /// The point of one wall abreast of centre-line arc length `s_m`.
    fn wall_point(&self, side: WallSide, s_m: f32) -> Point2 {
        let half = 0.5 * self.width_m;
        let lateral = match side {
            WallSide::Left => half,
            WallSide::Right => -half,
        };
        self.centre_pose(s_m, lateral).translation()
    }

    /// Builds the tunnel into `map` (in place). Errors are the map's (capacity, geometry).
    pub fn build_into<const S: usize, const L: usize, const C: usize, const R: usize>(
        &self,
        map: &mut StoredMap<S, L, C, R>,
    ) -> Result<(), MapError> {
        let steps = if self.wall_step_m > 0.0 && self.length_m.is_finite() && self.length_m > 0.0 {
            math::max(math::floor(self.length_m / self.wall_step_m + 0.5), 1.0) as usize
        } else {
            0
        };
        let step = self.length_m / steps.max(1) as f32;
        let wall = |side| (0..=steps).map(move |i| self.wall_point(side, i as f32 * step));
        let mut b = map.builder_from_iters(wall(WallSide::Left), wall(WallSide::Right))?;
        if let Some(layout) = self.landmarks {
            for (side, stream) in [(WallSide::Left, 1_u64), (WallSide::Right, 2_u64)] {
                let mut rng = Pcg32::new(layout.seed, stream);
                let wall_len = b.map().wall_length_m(side);
                let d = layout.shape.genome.spacing_m;
                let half_w = 0.5 * layout.shape.genome.width_m;
                let mut s = layout.first_s_m;
                while s + half_w <= wall_len && s - half_w >= 0.0 {
                    b.add(LandmarkPlacement {
                        wall: side,
                        s_m: s,
                        offset_m: 0.0,
                        shape: layout.shape,
                    })?;
                    s += rng.uniform(d - SPACING_JITTER_M, d + SPACING_JITTER_M);
                }
            }
        }
        b.finish()
    }
}

/// Simulates LMS511-like scans against a map: ray cast per beam plus Gaussian range noise.
#[derive(Debug, Clone)]
pub struct ScanSimulator {
    /// Range noise, 1σ, metres (default 10 mm, mid LMS511 spec).
    pub noise_sigma_m: f32,
    rng: Pcg32,
}

impl ScanSimulator {
    /// Default range noise, 1σ, metres.
    pub const DEFAULT_NOISE_SIGMA_M: f32 = 0.010;

    /// A simulator with 10 mm noise and a seed.
    pub fn new(seed: u64) -> Self {
        Self::with_noise(seed, Self::DEFAULT_NOISE_SIGMA_M)
    }

    /// A simulator with noise σ in metres (0 for exact ranges).
    pub fn with_noise(seed: u64, noise_sigma_m: f32) -> Self {
        Self {
            noise_sigma_m,
            rng: Pcg32::new(seed, 0x5ca9),
        }
    }

    /// Writes one range per element of `ranges_m` (beam `i` at the geometry's angle `i`)
    /// seen from `vehicle_pose` (world frame) by the sensor of `setup`. Beams that hit
    /// nothing within `max_range_m` read 0 (no echo); hits get noise added (and stay ≥ 0).
    pub fn simulate(
        &mut self,
        map: &dyn MapQuery,
        vehicle_pose: &Pose2,
        setup: &SensorSetup,
        ranges_m: &mut [f32],
    ) {
        self.simulate_swept(map, |_| *vehicle_pose, 0.0, setup, ranges_m);
    }

    /// [`ScanSimulator::simulate`] as the scanner's mirror sweeps: beam `i` of `n` is taken
    /// `(n − 1 − i) · beam_period_s` seconds before the last beam, from the vehicle's world
    /// pose `vehicle_before(seconds)` that long before it.
    pub fn simulate_swept(
        &mut self,
        map: &dyn MapQuery,
        vehicle_before: impl Fn(f32) -> Pose2,
        beam_period_s: f32,
        setup: &SensorSetup,
        ranges_m: &mut [f32],
    ) {
        let n = ranges_m.len();
        for (i, r) in ranges_m.iter_mut().enumerate() {
            let before_s = (n - 1 - i) as f32 * beam_period_s;
            let sensor = vehicle_before(before_s).compose(&setup.mounting);
            let origin = sensor.translation();
            let angle = sensor.theta_rad + setup.geometry.beam_angle_rad(i);
            *r = match map.raycast(origin, angle, setup.geometry.max_range_m) {
                Some(hit) => {
                    let noisy = if self.noise_sigma_m > 0.0 {
                        self.rng.normal(hit.range_m, self.noise_sigma_m)
                    } else {
                        hit.range_m
                    };
                    math::max(noisy, f32::MIN_POSITIVE)
                }
                None => 0.0,
            };
        }
    }

    /// Simulates `beams` beams (at most [`LMS511_MAX_BEAMS`]) straight into `scan`.
    pub fn simulate_scan(
        &mut self,
        map: &dyn MapQuery,
        vehicle_pose: &Pose2,
        setup: &SensorSetup,
        beams: usize,
        scan: &mut Scan,
    ) {
        let mut ranges = [0.0_f32; LMS511_MAX_BEAMS];
        let n = beams.min(LMS511_MAX_BEAMS);
        let out = ranges.get_mut(..n).unwrap_or(&mut []);
        self.simulate(map, vehicle_pose, setup, out);
        scan.load_ranges_m(setup, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::{FeatureKind, TunnelMap};

    #[test]
    fn straight_tunnel_with_landmarks_respects_the_spacing() {
        let spec = TunnelSpec::straight(200.0)
            .with_landmarks(LandmarkLayout::paper(LandmarkModel::P1Triangle, 3));
        let mut map = TunnelMap::new();
        spec.build_into(&mut map).unwrap();
        let lms = map.landmarks();
        assert!(lms.len() >= 2 * 19, "{}", lms.len());
        for side in [WallSide::Left, WallSide::Right] {
            let s: heapless::Vec<f32, 64> = lms
                .iter()
                .filter(|l| l.placement.wall == side)
                .map(|l| l.placement.s_m)
                .collect();
            for w in s.windows(2) {
                let d = w[1] - w[0];
                assert!((9.5 - 0.625..=9.5 + 0.625).contains(&d), "{d}");
            }
        }
        // Deterministic for a seed, different for another.
        let mut again = TunnelMap::new();
        spec.build_into(&mut again).unwrap();
        assert_eq!(again.landmarks(), map.landmarks());
        let other = TunnelSpec::straight(200.0)
            .with_landmarks(LandmarkLayout::paper(LandmarkModel::P1Triangle, 4));
        other.build_into(&mut again).unwrap();
        assert_ne!(again.landmarks(), map.landmarks());
    }

    #[test]
    fn curved_tunnel_walls_are_on_their_circles() {
        let spec = TunnelSpec::curved(100.0);
        let mut map = TunnelMap::new();
        spec.build_into(&mut map).unwrap();
        let centre = Point2::new(0.0, 50.0);
        for p in map.wall_vertices(WallSide::Left) {
            assert!((p.dist(centre) - 47.5).abs() < 1e-3);
        }
        for p in map.wall_vertices(WallSide::Right) {
            assert!((p.dist(centre) - 52.5).abs() < 1e-3);
        }
        let pose = spec.centre_pose(50.0, 0.0);
        assert!((pose.translation().dist(centre) - 50.0).abs() < 1e-3);
        assert!((pose.theta_rad - 1.0).abs() < 1e-6);
    }

    #[test]
    fn noiseless_scan_sees_the_walls_at_the_right_range() {
        let spec = TunnelSpec::straight(100.0);
        let mut map = TunnelMap::new();
        spec.build_into(&mut map).unwrap();
        let setup = SensorSetup::lms511_forward(0.0, 0.0);
        let mut sim = ScanSimulator::with_noise(1, 0.0);
        let mut ranges = [0.0_f32; LMS511_MAX_BEAMS];
        sim.simulate(&map, &spec.centre_pose(50.0, 0.0), &setup, &mut ranges);
        // Beam 30 ≈ sensor 0° = vehicle −90°: the right wall 2.5 m away.
        let i = 30;
        let a = setup.beam_angle_vehicle_rad(i);
        assert!(
            (ranges[i] * math::sin(a) + 2.5).abs() < 1e-3,
            "{}",
            ranges[i]
        );
        // Straight ahead along the open tunnel: no echo within 80 m... the far end is open.
        assert_eq!(ranges[570], 0.0);
        let mut scan = Scan::new();
        sim.simulate_scan(&map, &spec.centre_pose(50.0, 0.0), &setup, 1141, &mut scan);
        assert!(scan.len() > 1000);
        for p in scan.points() {
            assert!((p.vehicle.y_m.abs() - 2.5).abs() < 1e-3, "{p:?}");
        }
    }

    #[test]
    fn noise_has_the_requested_sigma_and_is_seeded() {
        let spec = TunnelSpec::straight(100.0)
            .with_landmarks(LandmarkLayout::paper(LandmarkModel::P1Triangle, 9));
        let mut map = TunnelMap::new();
        spec.build_into(&mut map).unwrap();
        let setup = SensorSetup::default();
        let pose = spec.centre_pose(40.0, 0.3);
        let mut exact = [0.0_f32; LMS511_MAX_BEAMS];
        ScanSimulator::with_noise(0, 0.0).simulate(&map, &pose, &setup, &mut exact);
        let mut a = [0.0_f32; LMS511_MAX_BEAMS];
        let mut b = [0.0_f32; LMS511_MAX_BEAMS];
        ScanSimulator::new(5).simulate(&map, &pose, &setup, &mut a);
        ScanSimulator::new(5).simulate(&map, &pose, &setup, &mut b);
        assert_eq!(a, b);
        let (mut n, mut sum_sq) = (0usize, 0.0f64);
        for (x, e) in a.iter().zip(exact.iter()) {
            if *e > 0.0 {
                n += 1;
                sum_sq += f64::from(x - e) * f64::from(x - e);
            }
        }
        let sigma = (sum_sq / n as f64).sqrt();
        assert!((0.009..0.011).contains(&sigma), "σ = {sigma} over {n}");
        // Some beams see landmarks.
        let hits = (0..LMS511_MAX_BEAMS)
            .filter_map(|i| {
                let s = pose.compose(&setup.mounting);
                map.raycast(
                    s.translation(),
                    s.theta_rad + setup.geometry.beam_angle_rad(i),
                    80.0,
                )
            })
            .filter(|h| matches!(h.kind, FeatureKind::Landmark { .. }))
            .count();
        assert!(hits > 10, "{hits}");
    }
}
