//! Landmark layout along the walls: where each landmark goes (§4.4 spacing), and which
//! ones are missing or damaged in the true tunnel.
//!
//! Spacing follows the paper: consecutive landmarks on a wall are `d ~ U[D − 0.625,
//! D + 0.625]` m apart, starting at a first chainage. Each wall draws its own sequence so
//! the two walls' landmarks are not mirror images.

use loc_core::rng::Pcg32;

/// Half-width of the spacing interval of §4.4, metres.
pub const SPACING_JITTER_M: f64 = 0.625;

/// Which wall.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum WallSide {
    /// Left of the direction of increasing chainage.
    Left,
    /// Right of the direction of increasing chainage.
    Right,
}

/// Which walls carry landmarks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum WallChoice {
    /// Only the left wall.
    Left,
    /// Only the right wall.
    Right,
    /// Both walls, each with its own spacing draw.
    #[default]
    Both,
}

impl WallChoice {
    /// The walls selected, left first.
    pub fn sides(self) -> &'static [WallSide] {
        match self {
            WallChoice::Left => &[WallSide::Left],
            WallChoice::Right => &[WallSide::Right],
            WallChoice::Both => &[WallSide::Left, WallSide::Right],
        }
    }
}

/// Which designed landmarks are absent from the true tunnel (fallen off, never installed).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Omission {
    /// All present.
    #[default]
    None,
    /// Every n-th landmark of each wall is missing (n ≥ 2; n = 5 is "one in five").
    EveryNth(u32),
    /// Each landmark is missing with this probability (0–1).
    RandomFraction(f64),
}

/// How the damaged landmarks are damaged.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DamageKind {
    /// Bent: the profile is rotated about its start by this angle (radians), lifting its
    /// far end off the wall.
    Bent {
        /// Rotation angle, radians (positive lifts the far end into the tunnel).
        angle_rad: f64,
    },
    /// Partly missing: only this fraction (0–1) of the width, from the start, remains.
    PartlyMissing {
        /// Fraction of the width that remains.
        keep_fraction: f64,
    },
}

/// Which present landmarks are damaged, and how.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Damage {
    /// Probability (0–1) that a present landmark is damaged.
    pub fraction: f64,
    /// The damage applied.
    pub kind: DamageKind,
}

/// The state of one landmark in the true tunnel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Condition {
    /// As designed.
    Intact,
    /// Absent (but still in the stored map).
    Missing,
    /// Present with damage.
    Damaged(DamageKind),
}

/// One landmark of the layout.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// The wall it is on.
    pub wall: WallSide,
    /// Chainage of its centre, metres.
    pub s_m: f64,
    /// Its state in the true tunnel.
    pub condition: Condition,
    /// Where it was mounted against its design mark: `(along_m, standoff_m)`, along the
    /// wall (direction of increasing chainage) and off the wall surface into the tunnel
    /// (brackets, shotcrete lumps), metres. `(0, 0)` unless the installation error is drawn
    /// ([`draw_installation_errors`]); the design map never sees it.
    pub installed_off_m: (f64, f64),
}

impl Placement {
    /// A landmark at its design mark, installed exactly there.
    pub fn at_mark(wall: WallSide, s_m: f64, condition: Condition) -> Self {
        Self {
            wall,
            s_m,
            condition,
            installed_off_m: (0.0, 0.0),
        }
    }
}

/// Draws each landmark's installation error: Gaussian, `along_sd_m` along the wall and
/// `standoff_sd_m` off it (the stand-off folded to be non-negative: a landmark cannot sit
/// behind the wall surface). Both σ 0 leaves the layout untouched and draws nothing.
pub fn draw_installation_errors(
    placements: &mut [Placement],
    along_sd_m: f64,
    standoff_sd_m: f64,
    rng: &mut Pcg32,
) {
    if along_sd_m <= 0.0 && standoff_sd_m <= 0.0 {
        return;
    }
    for p in placements {
        let along = along_sd_m * f64::from(rng.gaussian());
        let standoff = (standoff_sd_m * f64::from(rng.gaussian())).abs();
        p.installed_off_m = (along, standoff);
    }
}

/// Parameters of a layout.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LayoutSpec {
    /// Nominal spacing D, metres (> 0).
    pub spacing_m: f64,
    /// Chainage of the first landmark on each wall, metres.
    pub first_m: f64,
    /// Last chainage a landmark centre may have, metres.
    pub last_m: f64,
    /// Walls that carry landmarks.
    pub walls: WallChoice,
    /// Missing landmarks.
    pub omission: Omission,
    /// Damaged landmarks, if any.
    pub damage: Option<Damage>,
}

/// Draws the layout: positions per wall with §4.4 spacing, then omissions and damage.
/// Deterministic for a given generator state.
pub fn place_landmarks(spec: &LayoutSpec, rng: &mut Pcg32) -> Vec<Placement> {
    let mut out = Vec::new();
    if !(spec.spacing_m.is_finite() && spec.spacing_m > 0.0) {
        return out;
    }
    for &wall in spec.walls.sides() {
        let mut s = spec.first_m;
        let mut index_on_wall = 0u32;
        while s <= spec.last_m {
            index_on_wall += 1;
            let missing = match spec.omission {
                Omission::None => false,
                Omission::EveryNth(n) => n >= 1 && index_on_wall % n == 0,
                Omission::RandomFraction(f) => f64::from(rng.uniform01()) < f,
            };
            let condition = if missing {
                Condition::Missing
            } else {
                match spec.damage {
                    Some(d) if f64::from(rng.uniform01()) < d.fraction => {
                        Condition::Damaged(d.kind)
                    }
                    _ => Condition::Intact,
                }
            };
            out.push(Placement::at_mark(wall, s, condition));
            // Spacing never below a small positive gap, whatever D is.
            let lo = (spec.spacing_m - SPACING_JITTER_M).max(0.05);
            let hi = (spec.spacing_m + SPACING_JITTER_M).max(lo);
            s += lo + (hi - lo) * f64::from(rng.uniform01());
        }
    }
    out
}

/// Applies damage to a landmark profile given as `(along_m, height_m)` points in the
/// landmark's local frame (along the wall from its start, height into the tunnel).
pub fn damaged_profile(profile: &[(f64, f64)], kind: DamageKind) -> Vec<(f64, f64)> {
    match kind {
        DamageKind::Bent { angle_rad } => {
            let Some(&(u0, h0)) = profile.first() else {
                return Vec::new();
            };
            let (s, c) = angle_rad.sin_cos();
            profile
                .iter()
                .map(|&(u, h)| {
                    let (du, dh) = (u - u0, h - h0);
                    (u0 + c * du - s * dh, h0 + s * du + c * dh)
                })
                .collect()
        }
        DamageKind::PartlyMissing { keep_fraction } => {
            let (Some(&(u0, _)), Some(&(u1, _))) = (profile.first(), profile.last()) else {
                return Vec::new();
            };
            let cut = u0 + (u1 - u0) * keep_fraction.clamp(0.0, 1.0);
            let mut out: Vec<(f64, f64)> = Vec::new();
            for w in profile.windows(2) {
                let ((ua, ha), (ub, hb)) = (w[0], w[1]);
                if out.is_empty() {
                    out.push((ua, ha));
                }
                if ub <= cut {
                    out.push((ub, hb));
                } else {
                    if ua < cut && ub > ua {
                        let t = (cut - ua) / (ub - ua);
                        out.push((cut, ha + t * (hb - ha)));
                    }
                    break;
                }
            }
            // The broken edge drops straight back to the wall.
            if let Some(&(u, h)) = out.last() {
                if h.abs() > 1e-9 {
                    out.push((u, 0.0));
                }
            }
            out
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(omission: Omission) -> LayoutSpec {
        LayoutSpec {
            spacing_m: 9.0,
            first_m: 2.0,
            last_m: 1000.0,
            walls: WallChoice::Both,
            omission,
            damage: None,
        }
    }

    #[test]
    fn spacing_stays_in_the_paper_interval() {
        let mut rng = Pcg32::seeded(2);
        let p = place_landmarks(&spec(Omission::None), &mut rng);
        for wall in [WallSide::Left, WallSide::Right] {
            let s: Vec<f64> = p.iter().filter(|l| l.wall == wall).map(|l| l.s_m).collect();
            assert!((s[0] - 2.0).abs() < 1e-12);
            assert!(s.len() > 100);
            for w in s.windows(2) {
                let d = w[1] - w[0];
                assert!((9.0 - 0.625..=9.0 + 0.625).contains(&d), "{d}");
            }
        }
        let left: Vec<f64> = p
            .iter()
            .filter(|l| l.wall == WallSide::Left)
            .map(|l| l.s_m)
            .collect();
        let right: Vec<f64> = p
            .iter()
            .filter(|l| l.wall == WallSide::Right)
            .map(|l| l.s_m)
            .collect();
        assert_ne!(left[1], right[1], "walls draw independent spacings");
    }

    #[test]
    fn every_fifth_missing() {
        let mut rng = Pcg32::seeded(2);
        let p = place_landmarks(&spec(Omission::EveryNth(5)), &mut rng);
        let left: Vec<&Placement> = p.iter().filter(|l| l.wall == WallSide::Left).collect();
        for (i, l) in left.iter().enumerate() {
            assert_eq!(l.condition == Condition::Missing, (i + 1) % 5 == 0);
        }
    }

    #[test]
    fn damage_shapes() {
        let tri = [(0.0, 0.0), (0.2, 0.1), (0.4, 0.0)];
        let half = damaged_profile(
            &tri,
            DamageKind::PartlyMissing {
                keep_fraction: 0.25,
            },
        );
        assert_eq!(half, vec![(0.0, 0.0), (0.1, 0.05), (0.1, 0.0)]);
        let bent = damaged_profile(&tri, DamageKind::Bent { angle_rad: 0.1 });
        assert_eq!(bent[0], (0.0, 0.0));
        assert!(
            bent[2].1 > 0.03,
            "far end lifted off the wall: {:?}",
            bent[2]
        );
        assert!(damaged_profile(&[], DamageKind::Bent { angle_rad: 0.1 }).is_empty());
    }
}
