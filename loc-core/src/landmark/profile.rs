//! A landmark's cross-section as a polyline in the landmark frame, and its expansion from
//! the model and genome.
//!
//! ## Landmark frame
//! `u` (stored in [`Point2::x_m`]) runs along the wall from `−W/2` to `+W/2`, in the
//! direction of increasing arc length of the wall; `v` (in [`Point2::y_m`]) is the height out
//! of the wall into the tunnel. `v = 0` is the wall surface. Every profile starts at
//! `(−W/2, 0)` and ends at `(+W/2, 0)`: a landmark is a plate bolted to the wall.
//!
//! ## What negative heights and inversion mean on a wall
//! Table 1 lets h1…h6 range over −2…2, and `1 − s(u)` can be negative too, but a landmark
//! cannot reach into the rock. Heights are therefore **clamped at the wall surface**
//! (`v = max(v, 0)`): the part of the shape below zero becomes a flat stretch of the base
//! plate lying on the wall (kept as landmark geometry, it marks the plate's extent). Where a
//! segment crosses zero the crossing point is inserted, so the clamp is exact.
//!
//! The inverted models F2/F4 are `H · (1 − s(u))` over `|u| ≤ W/2` and zero outside: since
//! `h0 = 0`, an inverted landmark starts with a vertical step from the wall up to `H`
//! (and likewise at the far end when `1 − s` is not 0 there). P2 and P4 have vertical steps
//! too; all steps are kept as segments (a lidar sees a step's face from one side).
//!
//! ## Symmetric shapes with six heights
//! The 7 nodes `u_k = −W/2 + k·W/6`, `k = 0…6`, mirror about `u = 0` when `h_k = h_{6−k}`.
//! With `h0 = 0` that fixes `h6 = 0`, `h5 = h1`, `h4 = h2`, leaving h1, h2, h3 free (h3 is
//! the centre node). F3/F4 therefore use genes h1…h3 and ignore h4…h6 (kept in the genome so
//! every piecewise model shares one genome layout for the GA).
//!
//! ## Parabola sampling
//! P3 is sampled at [`PARABOLA_VERTICES`] = 11 evenly spaced nodes (10 chords). A chord of
//! `H (1 − (2u/W)²)` over `W/n` sags by `H / n²` from the curve: at most 3 mm for
//! `H ≤ 0.30 m`, under the LMS511's 6–14 mm range noise, while 10 segments per landmark
//! keeps the map small.

use crate::geometry::{Point2, Segment};
use crate::math;

use super::{Genome, LandmarkModel, PIECEWISE_HEIGHTS};

/// Most vertices any profile has: 7 nodes + 6 zero crossings + 2 end steps (piecewise
/// worst case), rounded up.
pub const MAX_PROFILE_VERTICES: usize = 16;

/// Most segments any profile has.
pub const MAX_PROFILE_SEGMENTS: usize = MAX_PROFILE_VERTICES - 1;

/// Vertices of the sampled parabola (P3).
pub const PARABOLA_VERTICES: usize = 11;

/// A landmark's cross-section in the landmark frame (`x_m` = u along the wall, `y_m` = v
/// height out of the wall), metres. Invariants: at least 2 vertices, first `(−W/2, 0)`, last
/// `(+W/2, 0)`, `u` non-decreasing, `v ≥ 0`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Profile {
    vertices: heapless::Vec<Point2, MAX_PROFILE_VERTICES>,
}

impl Profile {
    /// The expanded profile of `model` with `genome` (see the module docs). The genome is
    /// not bounds-checked here (see [`super::GeneBounds::check`]); non-finite genes give
    /// non-finite vertices.
    pub fn new(model: LandmarkModel, genome: &Genome) -> Self {
        let w = genome.width_m;
        let h = genome.height_m;
        let half = 0.5 * w;
        let mut p = Profile::default();
        match model {
            LandmarkModel::P1Triangle => {
                p.push(-half, 0.0);
                p.push(0.0, h);
                p.push(half, 0.0);
            }
            LandmarkModel::P2Rectangle => {
                p.push(-half, 0.0);
                p.push(-half, h);
                p.push(half, h);
                p.push(half, 0.0);
            }
            LandmarkModel::P3Parabola => {
                let n = (PARABOLA_VERTICES - 1) as f32;
                for i in 0..PARABOLA_VERTICES {
                    let x = -1.0 + 2.0 * i as f32 / n; // 2u/W in [-1, 1]
                                                       // The end nodes are exactly on the wall, whatever the rounding.
                    let v = if i == 0 || i == PARABOLA_VERTICES - 1 {
                        0.0
                    } else {
                        h * (1.0 - x * x)
                    };
                    p.push(x * half, v);
                }
            }
            LandmarkModel::P4Ramp => {
                p.push(-half, 0.0);
                p.push(half, h);
                p.push(half, 0.0);
            }
            LandmarkModel::F1Free
            | LandmarkModel::F2Inverted
            | LandmarkModel::F3Symmetric
            | LandmarkModel::F4SymmetricInverted => p.piecewise(model, genome),
        }
        p
    }

    /// The 6-segment piecewise-linear shapes, clamped at the wall.
    fn piecewise(&mut self, model: LandmarkModel, genome: &Genome) {
        let w = genome.width_m;
        let half = 0.5 * w;
        let hh = genome.heights;
        let s: [f32; PIECEWISE_HEIGHTS + 1] = if model.is_symmetric() {
            let [h1, h2, h3, ..] = hh;
            [0.0, h1, h2, h3, h2, h1, 0.0]
        } else {
            let [h1, h2, h3, h4, h5, h6] = hh;
            [0.0, h1, h2, h3, h4, h5, h6]
        };
        let n = PIECEWISE_HEIGHTS as f32;
        let mut prev: Option<(f32, f32)> = None;
        for (k, &sk) in s.iter().enumerate() {
            let u = -half + w * k as f32 / n;
            let raw = if model.is_inverted() { 1.0 - sk } else { sk };
            let v = genome.height_m * raw;
            match prev {
                None => {
                    if v > 0.0 {
                        self.push(-half, 0.0); // step up from the wall
                    }
                }
                Some((pu, pv)) => {
                    if (pv > 0.0 && v < 0.0) || (pv < 0.0 && v > 0.0) {
                        let t = pv / (pv - v);
                        self.push(pu + (u - pu) * t, 0.0);
                    }
                }
            }
            self.push(u, math::max(v, 0.0));
            prev = Some((u, v));
        }
        if let Some((_, v)) = prev {
            if v > 0.0 {
                self.push(half, 0.0); // step down to the wall
            }
        }
    }

    fn push(&mut self, u_m: f32, v_m: f32) {
        // Capacity is sized for the worst case (see MAX_PROFILE_VERTICES); a failed push
        // cannot happen, and would only shorten the outline.
        let _ = self.vertices.push(Point2::new(u_m, v_m));
    }

    /// The vertices, landmark frame, in order of increasing `u`.
    #[inline]
    pub fn vertices(&self) -> &[Point2] {
        &self.vertices
    }

    /// The segments between consecutive vertices, landmark frame.
    pub fn segments(&self) -> impl Iterator<Item = Segment> + '_ {
        self.vertices.windows(2).filter_map(|w| match w {
            [a, b] => Some(Segment::new(*a, *b)),
            _ => None,
        })
    }

    /// Largest height `v` of the profile, metres.
    pub fn max_height_m(&self) -> f32 {
        self.vertices.iter().fold(0.0, |m, p| math::max(m, p.y_m))
    }

    /// Height `v(u)` of the outline at `u_m` (the highest where a vertical step sits at
    /// `u_m`), 0 outside the landmark, metres.
    pub fn height_at(&self, u_m: f32) -> f32 {
        let mut best: f32 = 0.0;
        for s in self.segments() {
            let (lo, hi) = (math::min(s.a.x_m, s.b.x_m), math::max(s.a.x_m, s.b.x_m));
            if u_m < lo || u_m > hi {
                continue;
            }
            let v = if hi - lo <= f32::EPSILON {
                math::max(s.a.y_m, s.b.y_m)
            } else {
                s.a.y_m + (s.b.y_m - s.a.y_m) * (u_m - s.a.x_m) / (s.b.x_m - s.a.x_m)
            };
            best = math::max(best, v);
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn profile(model: LandmarkModel) -> (Profile, Genome) {
        let g = Genome::paper_default(model);
        (Profile::new(model, &g), g)
    }

    fn ends_on_wall(p: &Profile, g: &Genome) {
        let v = p.vertices();
        let (first, last) = (v[0], v[v.len() - 1]);
        assert_eq!(first, Point2::new(-0.5 * g.width_m, 0.0));
        assert_eq!(last, Point2::new(0.5 * g.width_m, 0.0));
        assert!(v.windows(2).all(|w| w[0].x_m <= w[1].x_m + 1e-6));
        assert!(v.iter().all(|q| q.y_m >= 0.0));
    }

    #[test]
    fn every_default_profile_ends_on_the_wall() {
        for m in LandmarkModel::ALL {
            let (p, g) = profile(m);
            ends_on_wall(&p, &g);
            assert!(p.vertices().len() <= MAX_PROFILE_VERTICES);
        }
    }

    #[test]
    fn primitives_reach_height_h() {
        for m in [
            LandmarkModel::P1Triangle,
            LandmarkModel::P2Rectangle,
            LandmarkModel::P3Parabola,
            LandmarkModel::P4Ramp,
        ] {
            let (p, g) = profile(m);
            assert!((p.max_height_m() - g.height_m).abs() < 1e-6, "{m:?}");
        }
        let (tri, g) = profile(LandmarkModel::P1Triangle);
        assert_eq!(tri.vertices().len(), 3);
        assert!((tri.height_at(0.0) - g.height_m).abs() < 1e-6);
        assert!((tri.height_at(g.width_m / 4.0) - g.height_m / 2.0).abs() < 1e-6);
        let (ramp, g) = profile(LandmarkModel::P4Ramp);
        assert!((ramp.height_at(0.0) - g.height_m / 2.0).abs() < 1e-6);
    }

    #[test]
    fn parabola_samples_lie_on_the_curve() {
        let (p, g) = profile(LandmarkModel::P3Parabola);
        assert_eq!(p.vertices().len(), PARABOLA_VERTICES);
        for q in p.vertices() {
            let x = 2.0 * q.x_m / g.width_m;
            assert!((q.y_m - g.height_m * (1.0 - x * x)).abs() < 1e-6);
        }
        // Sag between nodes stays below H / n².
        let u = 0.5 * g.width_m * 0.95;
        let x = 2.0 * u / g.width_m;
        let exact = g.height_m * (1.0 - x * x);
        assert!((p.height_at(u) - exact).abs() <= g.height_m / 100.0 + 1e-6);
    }

    #[test]
    fn free_shape_follows_the_heights() {
        let g = Genome::piecewise(0.6, 0.2, 7.5, [0.5, 1.0, 0.25, 0.75, 1.5, 0.5]);
        let p = Profile::new(LandmarkModel::F1Free, &g);
        ends_on_wall(&p, &g);
        for (k, hk) in g.heights.iter().enumerate() {
            let u = -0.3 + 0.1 * (k + 1) as f32;
            assert!((p.height_at(u) - 0.2 * hk).abs() < 1e-5, "node {k}");
        }
        // h6 ≠ 0: a step back to the wall at +W/2.
        let v = p.vertices();
        assert!((v[v.len() - 2].y_m - 0.1).abs() < 1e-6);
    }

    #[test]
    fn inverted_is_one_minus_the_free_shape() {
        let h = [0.5, 1.0, 0.25, 0.75, 0.9, 0.5];
        let g = Genome::piecewise(0.6, 0.2, 7.5, h);
        let f = Profile::new(LandmarkModel::F1Free, &g);
        let i = Profile::new(LandmarkModel::F2Inverted, &g);
        ends_on_wall(&i, &g);
        for k in 1..=5 {
            let u = -0.3 + 0.1 * k as f32;
            assert!(
                (f.height_at(u) + i.height_at(u) - 0.2).abs() < 1e-5,
                "node {k}"
            );
        }
        // h0 = 0 inverted: a step from the wall straight up to H at −W/2.
        assert_eq!(i.vertices()[1], Point2::new(-0.3, 0.2));
    }

    #[test]
    fn symmetric_shapes_are_even() {
        for m in [
            LandmarkModel::F3Symmetric,
            LandmarkModel::F4SymmetricInverted,
        ] {
            let mut g = Genome::paper_default(m);
            g.heights = [0.3, 1.2, -0.4, 9.0, 9.0, 9.0]; // h4..h6 ignored
            let p = Profile::new(m, &g);
            ends_on_wall(&p, &g);
            for i in 0..=40 {
                let u = -0.5 + i as f32 * 0.025;
                assert!(
                    (p.height_at(u) - p.height_at(-u)).abs() < 1e-5,
                    "{m:?} u={u}"
                );
            }
        }
    }

    #[test]
    fn negative_heights_clamp_at_the_wall_with_exact_crossings() {
        let g = Genome::piecewise(0.6, 0.2, 7.5, [1.0, -1.0, 1.0, -1.0, 1.0, -1.0]);
        let p = Profile::new(LandmarkModel::F1Free, &g);
        ends_on_wall(&p, &g);
        // Node 1 at u = −0.2 (v = 0.2), node 2 at u = −0.1 (v = −0.2 → 0): crossing at −0.15.
        assert!(p
            .vertices()
            .iter()
            .any(|q| (q.x_m + 0.15).abs() < 1e-6 && q.y_m == 0.0));
        assert_eq!(p.height_at(-0.1), 0.0);
        assert!(p.vertices().len() <= MAX_PROFILE_VERTICES);
        // Worst case fits: sign change on every segment plus both steps (inverted).
        let w = Genome::piecewise(0.6, 0.2, 7.5, [2.0, -2.0, 2.0, -2.0, 2.0, -2.0]);
        let q = Profile::new(LandmarkModel::F2Inverted, &w);
        ends_on_wall(&q, &w);
    }
}
