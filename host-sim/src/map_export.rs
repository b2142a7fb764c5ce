//! `export-map`: the stored map a localiser gets, as people-readable JSON (wall and
//! landmark polylines in world coordinates, metres) built from loc-core's map itself, so
//! what is written is what the localiser holds.

use serde::Serialize;

use loc_core::map::{TunnelMap, WallSide};

/// One landmark in the JSON export.
#[derive(Debug, Clone, Serialize)]
pub struct LandmarkJson {
    /// Index in the map.
    pub id: usize,
    /// Model code, "P1"…"F4".
    pub model: String,
    /// Genes W,H,D[,h1..h6].
    pub genes: Vec<f32>,
    /// Wall: "left" or "right".
    pub wall: String,
    /// Arc length along that wall to the landmark's centre, metres.
    pub s_m: f32,
    /// Polyline, world frame, `[x, y]` metres.
    pub polyline: Vec<[f32; 2]>,
}

/// The whole map in the JSON export.
#[derive(Debug, Clone, Serialize)]
pub struct MapJson {
    /// Left wall polyline, world frame, `[x, y]` metres.
    pub left_wall: Vec<[f32; 2]>,
    /// Right wall polyline.
    pub right_wall: Vec<[f32; 2]>,
    /// Landmarks.
    pub landmarks: Vec<LandmarkJson>,
    /// Segments in all (walls + landmarks).
    pub segments: usize,
}

/// The map as JSON data.
pub fn to_json(map: &TunnelMap) -> MapJson {
    let pts = |side| map.wall_vertices(side).map(|p| [p.x_m, p.y_m]).collect();
    let landmarks = map
        .landmarks()
        .iter()
        .enumerate()
        .map(|(id, lm)| {
            let polyline: Vec<[f32; 2]> = crate::stored_map::landmark_vertices(map, lm)
                .iter()
                .map(|p| [p.x_m, p.y_m])
                .collect();
            let shape = lm.placement.shape;
            MapJson::landmark(id, shape, lm.placement.wall, lm.placement.s_m, polyline)
        })
        .collect();
    MapJson {
        left_wall: pts(WallSide::Left),
        right_wall: pts(WallSide::Right),
        landmarks,
        segments: map.segments().len(),
    }
}

impl MapJson {
    fn landmark(
        id: usize,
        shape: loc_core::landmark::LandmarkShape,
        wall: WallSide,
        s_m: f32,
        polyline: Vec<[f32; 2]>,
    ) -> LandmarkJson {
        LandmarkJson {
            id,
            model: shape.model.code().into(),
            genes: shape.genome.to_genes()[..shape.model.gene_count()].to_vec(),
            wall: match wall {
                WallSide::Left => "left".into(),
                WallSide::Right => "right".into(),
            },
            s_m,
            polyline,
        }
    }

    /// Pretty-printed JSON text.
    pub fn to_pretty(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::named::named;
    use crate::stored_map;

    #[test]
    fn json_holds_walls_and_every_landmark_polyline() {
        let s = named("paper-10m").unwrap();
        let world = s.build_world().unwrap();
        let map = stored_map::build(&world, &s.landmark_choice().unwrap()).unwrap();
        let j = to_json(&map);
        assert_eq!(j.left_wall.len(), 2);
        assert!((j.left_wall[0][1] - 2.0).abs() < 1e-6);
        assert_eq!(j.landmarks.len(), world.placements().len());
        for (lm, i) in j.landmarks.iter().zip(0..) {
            let designed = world.landmark_polyline(i, false);
            assert_eq!(lm.polyline.len(), designed.len());
            assert!((f64::from(lm.polyline[1][0]) - designed[1].0).abs() < 1e-3);
            assert_eq!(lm.model, "P1");
        }
        let text = j.to_pretty();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert!(v["landmarks"][0]["polyline"].is_array());
    }
}
