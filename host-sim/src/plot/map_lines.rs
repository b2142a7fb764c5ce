//! The stored map as world-frame polylines for drawing (plots, Foxglove scene): both walls
//! and every landmark's profile, taken from loc-core's [`TunnelMap`] (what the localiser
//! matches against, for a live run and for a replay of a map file alike).

use loc_core::map::{TunnelMap, WallSide};

/// A world-frame polyline, `(x_m, y_m)`.
pub type Polyline = Vec<(f64, f64)>;

/// The map's drawable lines.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MapLines {
    /// Left wall (of increasing chainage).
    pub left_wall: Polyline,
    /// Right wall.
    pub right_wall: Polyline,
    /// One polyline per landmark profile.
    pub landmarks: Vec<Polyline>,
}

impl MapLines {
    /// The lines of a stored map.
    pub fn of(map: &TunnelMap) -> Self {
        let wall = |side| {
            map.wall_vertices(side)
                .map(|p| (f64::from(p.x_m), f64::from(p.y_m)))
                .collect()
        };
        let segments = map.segments();
        let landmarks = map
            .landmarks()
            .iter()
            .map(|lm| {
                let first = usize::from(lm.first_segment);
                let segs = segments
                    .get(first..first + usize::from(lm.segment_count))
                    .unwrap_or_default();
                segs.iter()
                    .map(|s| s.segment.a)
                    .chain(segs.last().map(|s| s.segment.b))
                    .map(|p| (f64::from(p.x_m), f64::from(p.y_m)))
                    .collect()
            })
            .collect();
        Self {
            left_wall: wall(WallSide::Left),
            right_wall: wall(WallSide::Right),
            landmarks,
        }
    }

    /// Every point of every line.
    pub fn points(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.left_wall
            .iter()
            .chain(&self.right_wall)
            .chain(self.landmarks.iter().flatten())
            .copied()
    }
}
