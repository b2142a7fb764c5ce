//! The localiser's map of a simulated world: the design (ideal walls at ± width / 2 and
//! every landmark of the layout as designed, missing or damaged ones included) in
//! loc-core's stored map, the same fixed-capacity [`TunnelMap`] the firmware uses.
//!
//! loc-core places a landmark by arc length along its wall polyline; the simulator places
//! it by centre-line chainage. The conversion projects the designed anchor onto the design
//! wall polyline, so both agree to the polyline's simplification tolerance.

use loc_core::geometry::Point2;
use loc_core::landmark::LandmarkShape;
use loc_core::map::{LandmarkPlacement, MapError, MapLandmark, TunnelMap, WallSide as CoreWall};

use crate::landmarks::LandmarkChoice;
use crate::world::layout::WallSide;
use crate::world::World;

/// Largest distance a dropped vertex of the design walls may be from the stored polyline,
/// metres. Not "well under the lidar's noise" is the test: an error shared by every point of
/// a wall is not averaged away. Chords through the walls' points at 2 mm put every
/// localiser 1.3 mm to the inside of each curve (now moved to straddle it, see
/// `World::wall_polyline`); left at 2 mm, the straddling chords still swing ±0.7 mm, and
/// 200 m of `tunnel-1km` localised 4.47 / 3.94 / 3.94 mm (seeds 1–3) against 4.33 / 3.87 /
/// 3.98 at 0.5 mm and 4.31 / 3.86 / 3.99 at 0.05 mm. At 0.5 mm the kilometre's map holds
/// 1383 segments (890 at 2 mm), a third of the stored map's capacity.
pub const WALL_TOLERANCE_M: f64 = 0.0005;

/// Cell size of the stored map's index, metres.
pub const MAP_CELL_M: f32 = 2.0;

fn to_points(pts: &[(f64, f64)]) -> Vec<Point2> {
    pts.iter()
        .map(|&(x, y)| Point2::new(x as f32, y as f32))
        .collect()
}

/// Arc length along `poly` of the point of `poly` closest to `p`, metres.
fn arc_length_of(poly: &[(f64, f64)], p: (f64, f64)) -> f64 {
    let mut best = (f64::INFINITY, 0.0);
    let mut acc = 0.0;
    for w in poly.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let len2 = dx * dx + dy * dy;
        let len = len2.sqrt();
        if len2 > 0.0 {
            let t = (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / len2).clamp(0.0, 1.0);
            let d2 = (p.0 - a.0 - t * dx).powi(2) + (p.1 - a.1 - t * dy).powi(2);
            if d2 < best.0 {
                best = (d2, acc + t * len);
            }
        }
        acc += len;
    }
    best.1
}

/// A world-frame polyline, `(x, y)` metres.
pub type Polyline = Vec<(f64, f64)>;

/// The design walls as the stored map holds them: `(left, right)` world polylines.
pub fn design_walls(world: &World) -> (Polyline, Polyline) {
    (
        world.wall_polyline(WallSide::Left, false, WALL_TOLERANCE_M),
        world.wall_polyline(WallSide::Right, false, WALL_TOLERANCE_M),
    )
}

/// The landmark placements of the design, in loc-core's terms (wall, arc length, shape).
pub fn design_placements(world: &World, choice: &LandmarkChoice) -> Vec<LandmarkPlacement> {
    let LandmarkChoice::Shape(shape) = choice else {
        return Vec::new();
    };
    let (left, right) = design_walls(world);
    world
        .placements()
        .iter()
        .map(|p| {
            let (poly, wall) = match p.wall {
                WallSide::Left => (&left, CoreWall::Left),
                WallSide::Right => (&right, CoreWall::Right),
            };
            let lateral = match p.wall {
                WallSide::Left => world.width_m() / 2.0,
                WallSide::Right => -world.width_m() / 2.0,
            };
            let anchor = world.centerline().offset_point(p.s_m, lateral);
            let s = arc_length_of(poly, anchor);
            let LandmarkShape { model, genome } = *shape;
            LandmarkPlacement::new(wall, s as f32, model, genome)
        })
        .collect()
}

/// Vertex spacing of an as-built map's walls, metres: the roughness below it is texture
/// the matcher's roughness model absorbs, and a 1 km tunnel's two walls (2 000 segments)
/// plus its landmarks stay within the firmware's [`TunnelMap`] (4 096 segments).
pub const AS_BUILT_STATION_M: f64 = 1.0;

/// The true walls as an as-built map holds them ([`World::wall_polyline_smoothed`]).
pub fn as_built_walls(world: &World) -> (Polyline, Polyline) {
    (
        world.wall_polyline_smoothed(WallSide::Left, AS_BUILT_STATION_M),
        world.wall_polyline_smoothed(WallSide::Right, AS_BUILT_STATION_M),
    )
}

/// Where `p` sits against `wall`'s polyline `poly`, in a landmark placement's terms:
/// `(arc length of its foot, stand-off)`, the stand-off positive into the tunnel (to the
/// right of the left wall's direction, to the left of the right wall's).
pub fn wall_position(poly: &[(f64, f64)], wall: CoreWall, p: (f64, f64)) -> (f64, f64) {
    let s = arc_length_of(poly, p);
    let (foot, tangent) = point_at(poly, s);
    let (dx, dy) = (p.0 - foot.0, p.1 - foot.1);
    let left_of = tangent.0 * dy - tangent.1 * dx;
    match wall {
        CoreWall::Left => (s, -left_of),
        CoreWall::Right => (s, left_of),
    }
}

/// A stored landmark's polyline (its segments' vertices in order), world frame.
pub fn landmark_vertices(map: &TunnelMap, lm: &MapLandmark) -> Vec<Point2> {
    let first = usize::from(lm.first_segment);
    let segs = map
        .segments()
        .get(first..first + usize::from(lm.segment_count))
        .unwrap_or(&[]);
    let mut out: Vec<Point2> = segs.iter().map(|s| s.segment.a).collect();
    if let Some(last) = segs.last() {
        out.push(last.segment.b);
    }
    out
}

/// The point at arc length `s_m` along `poly` (clamped to its ends) and the unit tangent
/// there.
pub fn point_at(poly: &[(f64, f64)], s_m: f64) -> ((f64, f64), (f64, f64)) {
    let mut acc = 0.0;
    let mut last = ((0.0, 0.0), (1.0, 0.0));
    for w in poly.windows(2) {
        let (a, b) = (w[0], w[1]);
        let len = (b.0 - a.0).hypot(b.1 - a.1);
        if len <= 0.0 {
            continue;
        }
        let t = ((b.0 - a.0) / len, (b.1 - a.1) / len);
        let u = ((s_m - acc) / len).clamp(0.0, 1.0);
        last = ((a.0 + u * (b.0 - a.0), a.1 + u * (b.1 - a.1)), t);
        if s_m <= acc + len {
            return last;
        }
        acc += len;
    }
    last
}

/// The landmarks as installed, on the walls of an as-built map: each present landmark's
/// true anchor (centre of its base) projected onto its wall polyline, the distance off it
/// as the stand-off. Missing landmarks are left out (a survey cannot see them).
pub fn as_built_placements(
    world: &World,
    choice: &LandmarkChoice,
    walls: &(Polyline, Polyline),
) -> Vec<LandmarkPlacement> {
    let LandmarkChoice::Shape(shape) = choice else {
        return Vec::new();
    };
    world
        .placements()
        .iter()
        .enumerate()
        .filter_map(|(i, p)| {
            let poly = world.landmark_polyline(i, true);
            let (first, last) = (*poly.first()?, *poly.last()?);
            let anchor = ((first.0 + last.0) / 2.0, (first.1 + last.1) / 2.0);
            let (wall_poly, wall) = match p.wall {
                WallSide::Left => (&walls.0, CoreWall::Left),
                WallSide::Right => (&walls.1, CoreWall::Right),
            };
            let (s, standoff) = wall_position(wall_poly, wall, anchor);
            let LandmarkShape { model, genome } = *shape;
            Some(LandmarkPlacement {
                offset_m: standoff as f32,
                ..LandmarkPlacement::new(wall, s as f32, model, genome)
            })
        })
        .collect()
}

/// The true as-built map of `world` (what a perfect survey would store): walls every
/// [`AS_BUILT_STATION_M`], every present landmark where it was installed.
pub fn build_as_built(world: &World, choice: &LandmarkChoice) -> Result<Box<TunnelMap>, MapError> {
    let walls = as_built_walls(world);
    let placements = as_built_placements(world, choice, &walls);
    let mut map = Box::<TunnelMap>::default();
    map.rebuild(
        &to_points(&walls.0),
        &to_points(&walls.1),
        &placements,
        MAP_CELL_M,
    )?;
    Ok(map)
}

/// Builds the stored map of `world`'s design into `map` (reused in place: it is large).
pub fn build_into(
    map: &mut TunnelMap,
    world: &World,
    choice: &LandmarkChoice,
) -> Result<(), MapError> {
    let (left, right) = design_walls(world);
    let placements = design_placements(world, choice);
    map.rebuild(
        &to_points(&left),
        &to_points(&right),
        &placements,
        MAP_CELL_M,
    )
}

/// Builds the stored map of `world`'s design on the heap.
pub fn build(world: &World, choice: &LandmarkChoice) -> Result<Box<TunnelMap>, MapError> {
    let mut map = Box::<TunnelMap>::default();
    build_into(&mut map, world, choice)?;
    Ok(map)
}

/// The map file loc-core reads (header, version, CRC-32, postcard payload): what
/// `export-map` writes for the firmware's flash.
pub fn to_file_bytes(map: &TunnelMap) -> Result<Vec<u8>, MapError> {
    let mut buf = vec![0u8; map.serialized_len()];
    let n = map.to_slice(&mut buf)?;
    buf.truncate(n);
    Ok(buf)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::named::named;
    use loc_core::map::MapQuery;

    #[test]
    fn the_kilometre_fits_the_firmware_map_and_matches_the_design() {
        let s = named("tunnel-1km").unwrap();
        let world = s.build_world().unwrap();
        let choice = s.landmark_choice().unwrap();
        let map = build(&world, &choice).unwrap();
        assert_eq!(map.landmarks().len(), world.placements().len());
        // Every designed landmark's world polyline coincides with the stored one.
        for (i, lm) in map.landmarks().iter().enumerate() {
            let designed = world.landmark_polyline(i, false);
            let first = map.segments()[usize::from(lm.first_segment)].segment.a;
            let d =
                (f64::from(first.x_m) - designed[0].0).hypot(f64::from(first.y_m) - designed[0].1);
            assert!(d < 0.01, "landmark {i}: {d} m apart");
        }
        // A ray across the tunnel from the centre line meets a wall at half the width.
        let (x, y, h) = world.centerline().pose_at(500.0);
        let hit = map
            .raycast(
                Point2::new(x as f32, y as f32),
                (h + std::f64::consts::FRAC_PI_2) as f32,
                10.0,
            )
            .unwrap();
        assert!((hit.range_m - 2.5).abs() < 0.01, "{}", hit.range_m);
        // The file round-trips through loc-core's loader, and is tens of KiB.
        let bytes = to_file_bytes(&map).unwrap();
        assert!(bytes.len() < 64 * 1024, "{} bytes", bytes.len());
        let mut back = Box::<TunnelMap>::default();
        back.load_from_bytes(&bytes).unwrap();
        assert_eq!(back.segments().len(), map.segments().len());
        assert_eq!(back.landmarks().len(), map.landmarks().len());
    }

    #[test]
    fn the_as_built_map_holds_the_installed_landmarks_on_the_true_walls() {
        let mut s = named("tunnel-1km").unwrap();
        s.landmarks.install_sd_m = 0.03;
        s.landmarks.install_standoff_sd_m = 0.005;
        s.landmarks.missing_every = Some(7);
        let world = s.build_world().unwrap();
        let choice = s.landmark_choice().unwrap();
        let map = build_as_built(&world, &choice).unwrap();
        let present: Vec<usize> = (0..world.placements().len())
            .filter(|&i| !world.landmark_polyline(i, true).is_empty())
            .collect();
        assert_eq!(map.landmarks().len(), present.len());
        // Each stored landmark's base starts where the installed one does, to the wall's
        // smoothing (the true base follows the centre line's heading, the map's the wall's).
        for (lm, &i) in map.landmarks().iter().zip(&present) {
            let built = world.landmark_polyline(i, true);
            let a = map.segments()[usize::from(lm.first_segment)].segment.a;
            let d = (f64::from(a.x_m) - built[0].0).hypot(f64::from(a.y_m) - built[0].1);
            assert!(d < 0.006, "landmark {i}: {d} m apart");
        }
        assert!(to_file_bytes(&map).unwrap().len() < 64 * 1024);
    }
}
