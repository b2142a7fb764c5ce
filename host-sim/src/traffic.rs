//! People and vehicles moving through the tunnel (scenario `[traffic]`): obstacles the
//! scanner sees and the map does not hold.
//!
//! Each one walks or drives along the centre line at a constant speed and lateral offset,
//! turning back at the ends of the stretch it was placed on (the drive's, widened by
//! [`MARGIN_M`] either side), so it crosses the loader's scans again and again. People are
//! circles (0.25 m radius), vehicles boxes (2 m wide, 3 m long) along the tunnel. They are
//! opaque: a beam that meets one ends there (the wall behind it is hidden). They do not
//! collide with the loader or with each other: the simulation is of what the scanner sees.

use loc_core::rng::Pcg32;
use serde::{Deserialize, Serialize};

use crate::world::centerline::CenterLine;

/// Obstacles are placed over the drive's stretch widened by this much either way, metres.
pub const MARGIN_M: f64 = 40.0;

/// How much traffic the tunnel has (scenario `[traffic]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrafficSpec {
    /// People walking through the tunnel.
    pub people: u32,
    /// Vehicles driving through it.
    pub vehicles: u32,
    /// Walking speed, m/s.
    pub person_speed_mps: f64,
    /// Driving speed, m/s.
    pub vehicle_speed_mps: f64,
    /// A person's radius, metres.
    pub person_radius_m: f64,
    /// A vehicle's width and length, metres.
    pub vehicle_size_m: [f64; 2],
}

impl Default for TrafficSpec {
    /// No traffic; when there is: people at 1.4 m/s, 0.25 m in radius; vehicles 2 × 3 m at
    /// 5 m/s.
    fn default() -> Self {
        Self {
            people: 0,
            vehicles: 0,
            person_speed_mps: 1.4,
            vehicle_speed_mps: 5.0,
            person_radius_m: 0.25,
            vehicle_size_m: [2.0, 3.0],
        }
    }
}

impl TrafficSpec {
    /// No people and no vehicles, every setting at its default (what a scenario file
    /// leaves out).
    pub fn is_empty(&self) -> bool {
        *self == TrafficSpec::default()
    }

    /// Why the spec cannot be used (the dotted scenario key and the reason), or `None`.
    pub fn problem(&self, tunnel_width_m: f64) -> Option<(&'static str, &'static str)> {
        let [w, l] = self.vehicle_size_m;
        let speed_ok = |v: f64| v.is_finite() && (0.0..=30.0).contains(&v);
        if self.people > 1000 || self.vehicles > 1000 {
            Some(("traffic.people", "at most 1000 people and 1000 vehicles"))
        } else if !speed_ok(self.person_speed_mps) {
            Some(("traffic.person_speed_mps", "must lie in [0, 30] m/s"))
        } else if !speed_ok(self.vehicle_speed_mps) {
            Some(("traffic.vehicle_speed_mps", "must lie in [0, 30] m/s"))
        } else if !(self.person_radius_m.is_finite()
            && self.person_radius_m > 0.0
            && 2.0 * self.person_radius_m < tunnel_width_m)
        {
            Some((
                "traffic.person_radius_m",
                "must be positive and fit the tunnel",
            ))
        } else if !(w.is_finite() && l.is_finite() && w > 0.0 && l > 0.0 && w < tunnel_width_m) {
            Some((
                "traffic.vehicle_size_m",
                "must be [width_m, length_m], positive, narrower than the tunnel",
            ))
        } else {
            None
        }
    }
}

/// An obstacle's outline at one instant, world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Obstacle {
    /// A person: a circle.
    Circle {
        /// Centre `(x, y)`, metres.
        centre: (f64, f64),
        /// Radius, metres.
        radius_m: f64,
    },
    /// A vehicle: a box.
    Box {
        /// Centre `(x, y)`, metres.
        centre: (f64, f64),
        /// Direction of its length, radians.
        heading_rad: f64,
        /// Half its length and half its width, metres.
        half_size_m: (f64, f64),
    },
}

impl Obstacle {
    /// Where a ray from `origin` along the unit vector `dir` first meets the outline,
    /// metres, if ahead of the origin (an origin inside the outline meets it at 0).
    pub fn ray_hit(&self, origin: (f64, f64), dir: (f64, f64)) -> Option<f64> {
        match *self {
            Obstacle::Circle { centre, radius_m } => {
                let (ox, oy) = (origin.0 - centre.0, origin.1 - centre.1);
                let b = ox * dir.0 + oy * dir.1;
                let c = ox * ox + oy * oy - radius_m * radius_m;
                if c <= 0.0 {
                    return Some(0.0);
                }
                let disc = b * b - c;
                let t = -b - disc.max(0.0).sqrt();
                (disc >= 0.0 && t >= 0.0).then_some(t)
            }
            Obstacle::Box {
                centre,
                heading_rad,
                half_size_m: (hl, hw),
            } => {
                let (s, c) = heading_rad.sin_cos();
                let (px, py) = (origin.0 - centre.0, origin.1 - centre.1);
                // Into the box frame: x along its length.
                let o = (c * px + s * py, -s * px + c * py);
                let d = (c * dir.0 + s * dir.1, -s * dir.0 + c * dir.1);
                let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
                for (oi, di, h) in [(o.0, d.0, hl), (o.1, d.1, hw)] {
                    if di.abs() < 1e-15 {
                        if oi.abs() > h {
                            return None;
                        }
                    } else {
                        let (a, b) = ((-h - oi) / di, (h - oi) / di);
                        t0 = t0.max(a.min(b));
                        t1 = t1.min(a.max(b));
                    }
                }
                (t0 <= t1).then_some(t0)
            }
        }
    }

    /// The nearest hit of a ray on any of `obstacles` within `max_range_m`.
    pub fn nearest_hit(
        obstacles: &[Obstacle],
        origin: (f64, f64),
        dir: (f64, f64),
        max_range_m: f64,
    ) -> Option<f64> {
        obstacles
            .iter()
            .filter_map(|o| o.ray_hit(origin, dir))
            .filter(|&t| t <= max_range_m)
            .min_by(f64::total_cmp)
    }
}

/// One mover: where it started and how it goes.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Mover {
    start_m: f64,
    /// Signed speed along the chainage, m/s.
    speed_mps: f64,
    lateral_m: f64,
    person: bool,
}

/// The people and vehicles of a run.
#[derive(Debug, Clone)]
pub struct Traffic {
    spec: TrafficSpec,
    movers: Vec<Mover>,
    /// The stretch they move on, chainage metres.
    from_m: f64,
    to_m: f64,
}

impl Traffic {
    /// Places `spec`'s people and vehicles at random on the stretch `[start_m, end_m]` of
    /// `line` (widened by [`MARGIN_M`], within the line), each going either way, inside a
    /// tunnel `width_m` wide.
    pub fn new(
        spec: TrafficSpec,
        line: &CenterLine,
        (start_m, end_m): (f64, f64),
        width_m: f64,
        seed: u64,
    ) -> Self {
        let mut rng = Pcg32::new(seed, 0x7aff1c);
        let from_m = (start_m.min(end_m) - MARGIN_M).max(0.0);
        let to_m = (start_m.max(end_m) + MARGIN_M)
            .min(line.length_m())
            .max(from_m);
        let mut movers = Vec::new();
        let kinds = std::iter::repeat_n(true, spec.people as usize)
            .chain(std::iter::repeat_n(false, spec.vehicles as usize));
        for person in kinds {
            let (speed, half_width) = if person {
                (spec.person_speed_mps, spec.person_radius_m)
            } else {
                (spec.vehicle_speed_mps, 0.5 * spec.vehicle_size_m[0])
            };
            // Keep clear of the walls by 0.1 m; a box on the centre line if it barely fits.
            let room = (0.5 * width_m - half_width - 0.1).max(0.0);
            let draw =
                |rng: &mut Pcg32, lo: f64, hi: f64| lo + f64::from(rng.uniform01()) * (hi - lo);
            let start = draw(&mut rng, from_m, to_m);
            let lateral = draw(&mut rng, -room, room);
            let direction = if rng.below(2) == 0 { 1.0 } else { -1.0 };
            movers.push(Mover {
                start_m: start,
                speed_mps: direction * speed,
                lateral_m: lateral,
                person,
            });
        }
        Self {
            spec,
            movers,
            from_m,
            to_m,
        }
    }

    /// No people, no vehicles.
    pub fn is_empty(&self) -> bool {
        self.movers.is_empty()
    }

    /// Every obstacle's outline at time `t_s` (appended to `out`, which is cleared first).
    pub fn obstacles_at(&self, line: &CenterLine, t_s: f64, out: &mut Vec<Obstacle>) {
        out.clear();
        let span = self.to_m - self.from_m;
        for m in &self.movers {
            // Back and forth between the ends: a triangle wave over the stretch.
            let s = if span > 0.0 {
                let u = (m.start_m - self.from_m + m.speed_mps * t_s).rem_euclid(2.0 * span);
                self.from_m + if u <= span { u } else { 2.0 * span - u }
            } else {
                self.from_m
            };
            let centre = line.offset_point(s, m.lateral_m);
            out.push(if m.person {
                Obstacle::Circle {
                    centre,
                    radius_m: self.spec.person_radius_m,
                }
            } else {
                let [w, l] = self.spec.vehicle_size_m;
                Obstacle::Box {
                    centre,
                    heading_rad: line.pose_at(s).2,
                    half_size_m: (0.5 * l, 0.5 * w),
                }
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::centerline::CurvePiece;

    #[test]
    fn rays_meet_circles_and_boxes_where_they_are() {
        let person = Obstacle::Circle {
            centre: (5.0, 0.0),
            radius_m: 0.25,
        };
        assert!((person.ray_hit((0.0, 0.0), (1.0, 0.0)).unwrap() - 4.75).abs() < 1e-12);
        assert_eq!(person.ray_hit((0.0, 0.0), (-1.0, 0.0)), None, "behind");
        assert_eq!(person.ray_hit((0.0, 1.0), (1.0, 0.0)), None, "passes by");
        let car = Obstacle::Box {
            centre: (10.0, 0.0),
            heading_rad: std::f64::consts::FRAC_PI_2,
            half_size_m: (1.5, 1.0),
        };
        // Turned 90°: its width (2 m) lies along x, its length along y.
        assert!((car.ray_hit((0.0, 0.0), (1.0, 0.0)).unwrap() - 9.0).abs() < 1e-9);
        assert!((car.ray_hit((10.0, -5.0), (0.0, 1.0)).unwrap() - 3.5).abs() < 1e-9);
        assert_eq!(car.ray_hit((0.0, 2.0), (1.0, 0.0)), None);
        let nearest = Obstacle::nearest_hit(&[car, person], (0.0, 0.0), (1.0, 0.0), 80.0);
        assert!((nearest.unwrap() - 4.75).abs() < 1e-12);
        assert_eq!(
            Obstacle::nearest_hit(&[car], (0.0, 0.0), (1.0, 0.0), 5.0),
            None
        );
    }

    #[test]
    fn movers_stay_on_their_stretch_at_their_speed_and_inside_the_tunnel() {
        let line = CenterLine::from_pieces(&[CurvePiece {
            length_m: 500.0,
            curvature_per_m: 0.0,
        }])
        .unwrap();
        let spec = TrafficSpec {
            people: 3,
            vehicles: 2,
            ..TrafficSpec::default()
        };
        let traffic = Traffic::new(spec, &line, (100.0, 200.0), 5.0, 7);
        let mut a = Vec::new();
        let mut b = Vec::new();
        for k in 0..500 {
            let t = f64::from(k) * 0.5;
            traffic.obstacles_at(&line, t, &mut a);
            traffic.obstacles_at(&line, t + 0.1, &mut b);
            assert_eq!(a.len(), 5);
            for (i, (p, q)) in a.iter().zip(&b).enumerate() {
                let (c0, c1, inset) = match (p, q) {
                    (Obstacle::Circle { centre: c0, .. }, Obstacle::Circle { centre: c1, .. }) => {
                        (*c0, *c1, 0.25)
                    }
                    (Obstacle::Box { centre: c0, .. }, Obstacle::Box { centre: c1, .. }) => {
                        (*c0, *c1, 1.0)
                    }
                    _ => panic!("kinds change"),
                };
                assert!((60.0..=240.0).contains(&c0.0), "{c0:?}");
                assert!(c0.1.abs() + inset <= 2.5, "{i}: {c0:?} touches a wall");
                let moved = (c1.0 - c0.0).hypot(c1.1 - c0.1);
                let v = if i < 3 { 1.4 } else { 5.0 };
                assert!(moved <= v * 0.1 + 1e-9, "{i} moved {moved}");
            }
        }
        // Deterministic from the seed.
        let again = Traffic::new(spec, &line, (100.0, 200.0), 5.0, 7);
        again.obstacles_at(&line, 249.5, &mut b);
        traffic.obstacles_at(&line, 249.5, &mut a);
        assert_eq!(a, b);
        assert!(Traffic::new(TrafficSpec::default(), &line, (0.0, 1.0), 5.0, 1).is_empty());
    }

    #[test]
    fn bad_specs_name_their_key() {
        let bad = TrafficSpec {
            vehicle_size_m: [6.0, 3.0],
            ..TrafficSpec::default()
        };
        assert_eq!(bad.problem(5.0).unwrap().0, "traffic.vehicle_size_m");
        let bad = TrafficSpec {
            person_speed_mps: f64::NAN,
            ..TrafficSpec::default()
        };
        assert_eq!(bad.problem(5.0).unwrap().0, "traffic.person_speed_mps");
        assert!(TrafficSpec::default().problem(5.0).is_none());
    }
}
