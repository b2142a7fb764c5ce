//! Stripper tests on ray-cast synthetic tunnels (self-contained: vehicle-frame polylines).

use super::*;
use crate::rng::Pcg32;

/// Ray-casts beams from −95° to +95° (0.1667° steps) from the origin against segments.
fn cast(segments: &[(Point2, Point2)], noise_m: f32, seed: u64) -> ([Point2; 1141], usize) {
    let mut out = [Point2::ORIGIN; 1141];
    let mut n = 0;
    let mut rng = Pcg32::seeded(seed);
    for i in 0..1141 {
        let a = (-95.0 + i as f32 * (190.0 / 1140.0)).to_radians();
        let d = Point2::new(math::cos(a), math::sin(a));
        let mut best = f32::INFINITY;
        for &(p, q) in segments {
            let e = q.sub(p);
            let den = d.cross(e);
            if den.abs() < 1e-9 {
                continue;
            }
            let t = p.cross(e) / den;
            let s = p.cross(d) / den;
            if t > 0.0 && (0.0..=1.0).contains(&s) && t < best {
                best = t;
            }
        }
        if best < 80.0 {
            out[n] = d.scale(best + rng.normal(0.0, noise_m));
            n += 1;
        }
    }
    (out, n)
}

/// A straight 5 m tunnel along x (walls y = ±2.5 about `y0`) with triangles (W 0.6, H 0.2)
/// on the left wall every 9 m, as vehicle-frame segments after rotating by `yaw`.
fn straight(y0: f32, yaw: f32) -> heapless::Vec<(Point2, Point2), 64> {
    let mut v = heapless::Vec::new();
    let rot = |p: Point2| {
        let (s, c) = math::sin_cos(yaw);
        Point2::new(c * p.x_m - s * p.y_m, s * p.x_m + c * p.y_m)
    };
    let l = 2.5 - y0;
    let r = -2.5 - y0;
    let mut x = -10.0;
    for k in 0..12 {
        let c = 3.0 + 9.0 * k as f32;
        v.push((rot(Point2::new(x, l)), rot(Point2::new(c - 0.3, l))))
            .unwrap();
        v.push((rot(Point2::new(c - 0.3, l)), rot(Point2::new(c, l - 0.2))))
            .unwrap();
        v.push((rot(Point2::new(c, l - 0.2)), rot(Point2::new(c + 0.3, l))))
            .unwrap();
        x = c + 0.3;
    }
    v.push((rot(Point2::new(x, l)), rot(Point2::new(120.0, l))))
        .unwrap();
    v.push((rot(Point2::new(-10.0, r)), rot(Point2::new(120.0, r))))
        .unwrap();
    v
}

/// A tunnel curving left with centre-line radius 50 m, vehicle on the centre line, as
/// polylines of 1 m chords (no landmarks).
fn curved() -> heapless::Vec<(Point2, Point2), 256> {
    let mut v = heapless::Vec::new();
    for (radius, _) in [(47.5f32, 0), (52.5, 1)] {
        for k in -5..100 {
            let a0 = k as f32 * 0.02;
            let a1 = a0 + 0.02;
            let p = |a: f32| Point2::new(radius * math::sin(a), 50.0 - radius * math::cos(a));
            v.push((p(a0), p(a1))).unwrap();
        }
    }
    v
}

fn strip(points: &[Point2]) -> ([PointLabel; 1141], StripSummary) {
    let mut labels = [PointLabel::Outlier; 1141];
    let s = strip_walls(points, &StripConfig::default(), &mut labels);
    (labels, s)
}

#[test]
fn straight_tunnel_walls_and_landmarks() {
    let segs = straight(0.0, 0.0);
    let (pts, n) = cast(&segs, 0.01, 1);
    let (labels, s) = strip(&pts[..n]);
    let l = s.left.unwrap();
    let r = s.right.unwrap();
    assert!((l.cubic.eval(5.0) - 2.5).abs() < 0.01, "{:?}", l);
    assert!((r.cubic.eval(5.0) + 2.5).abs() < 0.01, "{:?}", r);
    // Every point on a landmark flank more than 5 cm from the wall must be a landmark point.
    for (p, lab) in pts[..n].iter().zip(labels.iter()) {
        if p.norm() > StripConfig::default().max_fit_range_m {
            // Far points: wall points of the straight walls, never landmarks.
            assert_ne!(*lab, PointLabel::Landmark, "{p:?}");
        } else if p.y_m > 0.0 && p.y_m < 2.44 {
            assert_eq!(*lab, PointLabel::Landmark, "{p:?}");
        } else if p.y_m > 2.47 {
            assert_eq!(*lab, PointLabel::LeftWall, "{p:?}");
        } else if p.y_m < -2.47 {
            assert_eq!(*lab, PointLabel::RightWall, "{p:?}");
        }
    }
    assert!(s.counts.landmark > 20, "{:?}", s.counts);
    assert!(s.counts.outlier < 5, "{:?}", s.counts);
}

#[test]
fn off_centre_and_turned_vehicle() {
    let segs = straight(1.2, 4f32.to_radians());
    let (pts, n) = cast(&segs, 0.01, 2);
    let (_, s) = strip(&pts[..n]);
    let l = s.left.unwrap();
    let r = s.right.unwrap();
    // Left wall y = 1.3 rotated by 4°: at x = 10, y ≈ 1.3/cos + 10·tan(4°).
    let expect = |y0: f32| y0 / 4f32.to_radians().cos() + 10.0 * 4f32.to_radians().tan();
    assert!((l.cubic.eval(10.0) - expect(1.3)).abs() < 0.02);
    assert!((r.cubic.eval(10.0) - expect(-3.7)).abs() < 0.02);
    assert!(s.counts.landmark > 10);
}

#[test]
fn curved_tunnel_is_all_wall() {
    let segs = curved();
    let (pts, n) = cast(&segs, 0.01, 3);
    let (_, s) = strip(&pts[..n]);
    assert!(s.left.is_some() && s.right.is_some());
    let c = s.counts;
    let walls = c.left_wall + c.right_wall;
    // No landmarks in this tunnel: almost nothing in range may be labelled one.
    assert!(c.landmark + c.outlier < walls / 50, "{c:?} walls {walls}");
    let l = s.left.unwrap().cubic;
    assert!((l.eval(10.0) - (50.0 - (47.5f32 * 47.5 - 100.0).sqrt())).abs() < 0.02);
}

#[test]
fn degenerate_inputs_never_panic() {
    let mut labels = [PointLabel::LeftWall; 8];
    let s = strip_walls::<Point2>(&[], &StripConfig::default(), &mut labels);
    assert!(s.left.is_none() && s.right.is_none());
    let one = [Point2::new(1.0, 1.0)];
    let s = strip_walls(&one, &StripConfig::default(), &mut labels);
    assert_eq!(labels[0], PointLabel::Outlier);
    assert_eq!(s.counts.outlier, 1);
    let same = [Point2::new(3.0, 2.0); 8];
    let _ = strip_walls(&same, &StripConfig::default(), &mut labels);
    let nan = [Point2::new(f32::NAN, 1.0); 8];
    let s = strip_walls(&nan, &StripConfig::default(), &mut labels);
    assert_eq!(s.counts.out_of_range, 8);
    // More points than labels: only the labelled prefix is processed.
    let many = [Point2::new(2.0, 2.5); 20];
    let s = strip_walls(&many, &StripConfig::default(), &mut labels);
    assert_eq!(
        s.counts.left_wall + s.counts.right_wall + s.counts.landmark + s.counts.outlier,
        8
    );
}

#[test]
fn deterministic() {
    let segs = straight(0.3, 0.02);
    let (pts, n) = cast(&segs, 0.01, 4);
    let (la, sa) = strip(&pts[..n]);
    let (lb, sb) = strip(&pts[..n]);
    assert_eq!(sa, sb);
    assert_eq!(la, lb);
}
