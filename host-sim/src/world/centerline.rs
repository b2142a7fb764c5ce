//! The tunnel's centre line: a planar curve sampled densely by arc length (chainage).
//!
//! Everything along the tunnel (walls, landmarks, the vehicle's path, the along/across
//! error split of the metrics) is placed by chainage `s_m` on this curve. Built from a list
//! of constant-curvature pieces (straights, arcs, S-bends) or from surveyed x,y points
//! (CSV). World frame, metres, radians; computed in `f64` so a kilometre of tunnel keeps
//! sub-millimetre precision.

use std::fmt;

/// Spacing of the stored samples along the curve, metres.
pub const SAMPLE_STEP_M: f64 = 0.05;

/// Longest centre line accepted, metres (a survey in millimetres read as metres is 1000×
/// too long; a longer drive is split into sections).
pub const MAX_LENGTH_M: f64 = 100_000.0;

/// Largest coordinate accepted, metres (UTM northings are below 10 000 km).
pub const MAX_COORDINATE_M: f64 = 1.0e7;

/// One piece of a centre line: a length with constant curvature.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurvePiece {
    /// Length of the piece along the curve, metres (> 0).
    pub length_m: f64,
    /// Signed curvature, 1/m: positive turns left (counter-clockwise), 0 is straight.
    pub curvature_per_m: f64,
}

/// A point of the centre line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CenterSample {
    /// Chainage (arc length from the start), metres.
    pub s_m: f64,
    /// World x, metres.
    pub x_m: f64,
    /// World y, metres.
    pub y_m: f64,
    /// Tangent direction, radians (not wrapped: continuous along the curve).
    pub heading_rad: f64,
}

/// Why a centre line could not be built.
#[derive(Debug, Clone, PartialEq)]
pub enum CenterLineError {
    /// Fewer than two distinct points (or zero total length): give a longer line.
    TooShort,
    /// A piece had a non-positive or non-finite length, or a non-finite curvature.
    BadPiece {
        /// Index of the piece in the list.
        index: usize,
    },
    /// A surveyed point was not finite.
    BadPoint {
        /// Index of the point in the list.
        index: usize,
    },
    /// A surveyed point lies beyond ±[`MAX_COORDINATE_M`].
    OutOfRange {
        /// Index of the point in the list.
        index: usize,
        /// Its larger coordinate's magnitude, metres.
        coordinate_m: f64,
    },
    /// The line is longer than [`MAX_LENGTH_M`].
    TooLong {
        /// Its length (or the length reached when it passed the limit), metres.
        length_m: f64,
    },
}

impl fmt::Display for CenterLineError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CenterLineError::TooShort => write!(
                f,
                "the centre line is too short: give at least two distinct points or a piece with positive length"
            ),
            CenterLineError::BadPiece { index } => write!(
                f,
                "centre-line piece {index} needs a positive, finite length and a finite curvature"
            ),
            CenterLineError::BadPoint { index } => {
                write!(f, "centre-line point {index} is not a finite x,y pair")
            }
            CenterLineError::OutOfRange {
                index,
                coordinate_m,
            } => write!(
                f,
                "centre-line point {index} lies {coordinate_m:.3e} m from the origin, beyond {MAX_COORDINATE_M:.0e} m: give coordinates in metres in a local or projected (e.g. UTM) frame"
            ),
            CenterLineError::TooLong { length_m } => write!(
                f,
                "the centre line reaches {:.4e} km, longer than {} km: is the survey in millimetres? (give metres) A longer drive is split into sections",
                length_m / 1000.0,
                MAX_LENGTH_M / 1000.0
            ),
        }
    }
}

impl std::error::Error for CenterLineError {}

/// A centre line sampled every [`SAMPLE_STEP_M`] (or at the surveyed points' spacing).
///
/// Invariant: at least two samples, chainage strictly increasing from 0.
#[derive(Debug, Clone)]
pub struct CenterLine {
    samples: Vec<CenterSample>,
    /// The CSV line of each sample's point (empty when the line does not come from a CSV).
    lines: Vec<usize>,
}

/// Where a world point lies relative to the centre line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// Chainage of the closest centre-line point, metres.
    pub s_m: f64,
    /// Signed lateral offset, metres: positive to the left of the direction of travel.
    pub lateral_m: f64,
}

impl CenterLine {
    /// Integrates constant-curvature pieces from the origin, heading +x.
    pub fn from_pieces(pieces: &[CurvePiece]) -> Result<Self, CenterLineError> {
        // The length decides the allocation: bound it first.
        let mut total_m = 0.0;
        for (index, p) in pieces.iter().enumerate() {
            if !(p.length_m.is_finite() && p.length_m > 0.0 && p.curvature_per_m.is_finite()) {
                return Err(CenterLineError::BadPiece { index });
            }
            total_m += p.length_m;
            if total_m > MAX_LENGTH_M {
                return Err(CenterLineError::TooLong { length_m: total_m });
            }
        }
        let mut samples = vec![CenterSample {
            s_m: 0.0,
            x_m: 0.0,
            y_m: 0.0,
            heading_rad: 0.0,
        }];
        for p in pieces {
            let n = (p.length_m / SAMPLE_STEP_M).ceil().max(1.0) as usize;
            let ds = p.length_m / n as f64;
            for _ in 0..n {
                let last = *samples.last().unwrap_or(&samples[0]);
                // Exact integration of a constant-curvature arc over ds.
                let k = p.curvature_per_m;
                let th0 = last.heading_rad;
                let th1 = th0 + k * ds;
                let (dx, dy) = if k.abs() < 1e-12 {
                    (ds * th0.cos(), ds * th0.sin())
                } else {
                    ((th1.sin() - th0.sin()) / k, (th0.cos() - th1.cos()) / k)
                };
                samples.push(CenterSample {
                    s_m: last.s_m + ds,
                    x_m: last.x_m + dx,
                    y_m: last.y_m + dy,
                    heading_rad: th1,
                });
            }
        }
        if samples.len() < 2 {
            return Err(CenterLineError::TooShort);
        }
        Ok(Self {
            samples,
            lines: Vec::new(),
        })
    }

    /// A centre line through surveyed points (world x, y in metres), in order. Consecutive
    /// duplicates are dropped; headings are the chord directions, unwrapped.
    pub fn from_points(points: &[(f64, f64)]) -> Result<Self, CenterLineError> {
        Self::from_points_kept(points).map(|(line, _)| line)
    }

    /// [`CenterLine::from_points`], with the index of each sample's point.
    fn from_points_kept(points: &[(f64, f64)]) -> Result<(Self, Vec<usize>), CenterLineError> {
        let mut samples: Vec<CenterSample> = Vec::with_capacity(points.len());
        let mut kept = Vec::with_capacity(points.len());
        for (index, &(x, y)) in points.iter().enumerate() {
            if !(x.is_finite() && y.is_finite()) {
                return Err(CenterLineError::BadPoint { index });
            }
            let coordinate_m = x.abs().max(y.abs());
            if coordinate_m > MAX_COORDINATE_M {
                return Err(CenterLineError::OutOfRange {
                    index,
                    coordinate_m,
                });
            }
            match samples.last() {
                None => samples.push(CenterSample {
                    s_m: 0.0,
                    x_m: x,
                    y_m: y,
                    heading_rad: 0.0,
                }),
                Some(last) => {
                    let d = (x - last.x_m).hypot(y - last.y_m);
                    if d < 1e-9 {
                        continue;
                    }
                    let s_m = last.s_m + d;
                    if s_m > MAX_LENGTH_M {
                        return Err(CenterLineError::TooLong { length_m: s_m });
                    }
                    samples.push(CenterSample {
                        s_m,
                        x_m: x,
                        y_m: y,
                        heading_rad: 0.0,
                    });
                }
            }
            kept.push(index);
        }
        if samples.len() < 2 {
            return Err(CenterLineError::TooShort);
        }
        // Heading of each sample: direction of the chord to the next one (the last copies
        // its predecessor), unwrapped so it is continuous.
        let mut prev = 0.0f64;
        for i in 0..samples.len() {
            let (a, b) = if i + 1 < samples.len() {
                (samples[i], samples[i + 1])
            } else {
                (samples[i - 1], samples[i])
            };
            let raw = (b.y_m - a.y_m).atan2(b.x_m - a.x_m);
            let h = if i == 0 {
                raw
            } else {
                prev + wrap_pi(raw - prev)
            };
            samples[i].heading_rad = h;
            prev = h;
        }
        Ok((
            Self {
                samples,
                lines: Vec::new(),
            },
            kept,
        ))
    }

    /// Reads a centre line from CSV text: one `x,y` pair per line in metres; blank lines,
    /// `#` comments and a non-numeric header line are skipped.
    pub fn parse_csv(text: &str) -> Result<Self, CsvCenterLineError> {
        let mut pts = Vec::new();
        let mut pt_lines = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let line_no = i + 1;
            let t = line.trim();
            if t.is_empty() || t.starts_with('#') {
                continue;
            }
            let mut fields = t.split([',', ';', '\t']).map(str::trim);
            let (fx, fy) = (fields.next().unwrap_or(""), fields.next().unwrap_or(""));
            match (fx.parse::<f64>(), fy.parse::<f64>()) {
                (Ok(x), Ok(y)) => {
                    pts.push((x, y));
                    pt_lines.push(line_no);
                }
                _ if pts.is_empty() && fx.parse::<f64>().is_err() => continue, // header
                _ => {
                    return Err(CsvCenterLineError::BadLine {
                        line: line_no,
                        text: t.to_string(),
                    })
                }
            }
        }
        let at_line = |e: CenterLineError| match e {
            CenterLineError::BadPoint { index } | CenterLineError::OutOfRange { index, .. } => {
                CsvCenterLineError::AtLine {
                    line: pt_lines.get(index).copied().unwrap_or(0),
                    error: e,
                }
            }
            _ => CsvCenterLineError::Geometry(e),
        };
        let (mut line, kept) = Self::from_points_kept(&pts).map_err(at_line)?;
        line.lines = kept
            .iter()
            .map(|&k| pt_lines.get(k).copied().unwrap_or(0))
            .collect();
        Ok(line)
    }

    /// The CSV line of sample `index`'s point, when the line comes from a CSV.
    pub fn source_line(&self, index: usize) -> Option<usize> {
        self.lines.get(index).copied()
    }

    /// Total length, metres.
    pub fn length_m(&self) -> f64 {
        self.samples.last().map_or(0.0, |s| s.s_m)
    }

    /// The stored samples, chainage increasing.
    pub fn samples(&self) -> &[CenterSample] {
        &self.samples
    }

    /// Index `i` with `samples[i].s_m <= s < samples[i+1].s_m` (clamped to the ends).
    fn segment_index(&self, s_m: f64) -> usize {
        let n = self.samples.len();
        match self
            .samples
            .binary_search_by(|p| p.s_m.partial_cmp(&s_m).unwrap_or(std::cmp::Ordering::Less))
        {
            Ok(i) => i.min(n - 2),
            Err(i) => i.saturating_sub(1).min(n - 2),
        }
    }

    /// The point and tangent at chainage `s_m` (linear interpolation; beyond the ends the
    /// line is extended straight along the end tangents). Returns `(x_m, y_m, heading_rad)`.
    pub fn pose_at(&self, s_m: f64) -> (f64, f64, f64) {
        let i = self.segment_index(s_m);
        let (a, b) = (self.samples[i], self.samples[i + 1]);
        let len = b.s_m - a.s_m;
        let t = (s_m - a.s_m) / len;
        if (0.0..=1.0).contains(&t) {
            let h = a.heading_rad + t * (b.heading_rad - a.heading_rad);
            (a.x_m + t * (b.x_m - a.x_m), a.y_m + t * (b.y_m - a.y_m), h)
        } else {
            // Straight extension beyond an end.
            let end = if t < 0.0 { a } else { b };
            let ds = s_m - end.s_m;
            (
                end.x_m + ds * end.heading_rad.cos(),
                end.y_m + ds * end.heading_rad.sin(),
                end.heading_rad,
            )
        }
    }

    /// The point at chainage `s_m`, offset `lateral_m` to the left (negative: right).
    pub fn offset_point(&self, s_m: f64, lateral_m: f64) -> (f64, f64) {
        let (x, y, h) = self.pose_at(s_m);
        (x - lateral_m * h.sin(), y + lateral_m * h.cos())
    }

    /// Projects a world point onto the line, searching chainages within `window_m` of
    /// `s_hint_m` (pass the last known chainage; a full search if the window covers the
    /// line). Used for the along/across-tunnel split of errors and by the path follower.
    pub fn project(&self, x_m: f64, y_m: f64, s_hint_m: f64, window_m: f64) -> Projection {
        let lo = self.segment_index(s_hint_m - window_m);
        let hi = self.segment_index(s_hint_m + window_m);
        let mut best = (f64::INFINITY, 0.0, 0.0);
        for i in lo..=hi {
            let (a, b) = (self.samples[i], self.samples[i + 1]);
            let (dx, dy) = (b.x_m - a.x_m, b.y_m - a.y_m);
            let len2 = dx * dx + dy * dy;
            let mut t = ((x_m - a.x_m) * dx + (y_m - a.y_m) * dy) / len2;
            // Allow extrapolation only past the line's own ends.
            if i > 0 || t > 0.0 {
                t = t.max(0.0);
            }
            if i + 2 < self.samples.len() || t < 1.0 {
                t = t.min(1.0);
            }
            let (px, py) = (a.x_m + t * dx, a.y_m + t * dy);
            let d2 = (x_m - px).powi(2) + (y_m - py).powi(2);
            if d2 < best.0 {
                let len = len2.sqrt();
                let cross = (dx * (y_m - a.y_m) - dy * (x_m - a.x_m)) / len;
                best = (d2, a.s_m + t * len, cross);
            }
        }
        Projection {
            s_m: best.1,
            lateral_m: best.2,
        }
    }
}

/// Why a CSV centre line could not be read.
#[derive(Debug, Clone, PartialEq)]
pub enum CsvCenterLineError {
    /// A line was not an `x,y` pair of numbers.
    BadLine {
        /// 1-based line number.
        line: usize,
        /// The offending text.
        text: String,
    },
    /// The points do not make a usable line.
    Geometry(CenterLineError),
    /// A point is unusable.
    AtLine {
        /// 1-based line number.
        line: usize,
        /// What is wrong with it.
        error: CenterLineError,
    },
}

impl fmt::Display for CsvCenterLineError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CsvCenterLineError::BadLine { line, text } => write!(
                f,
                "centre-line CSV line {line}: expected `x,y` in metres, found `{text}`"
            ),
            CsvCenterLineError::Geometry(e) => write!(f, "centre-line CSV: {e}"),
            CsvCenterLineError::AtLine { line, error } => {
                write!(f, "centre-line CSV line {line}: {error}")
            }
        }
    }
}

impl std::error::Error for CsvCenterLineError {}

/// Wraps an angle into `(-π, π]`.
pub fn wrap_pi(a: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    let mut r = a - two_pi * ((a + std::f64::consts::PI) / two_pi).floor();
    if r <= -std::f64::consts::PI {
        r += two_pi;
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arc_closes_into_a_circle() {
        let r = 20.0;
        let c = CenterLine::from_pieces(&[CurvePiece {
            length_m: std::f64::consts::TAU * r,
            curvature_per_m: 1.0 / r,
        }])
        .unwrap();
        let last = c.samples().last().unwrap();
        assert!(last.x_m.abs() < 1e-6 && last.y_m.abs() < 1e-6);
        let (x, y, h) = c.pose_at(std::f64::consts::PI * r);
        assert!((x).abs() < 1e-6 && (y - 2.0 * r).abs() < 1e-6);
        assert!((h - std::f64::consts::PI).abs() < 1e-9);
    }

    #[test]
    fn projection_gives_chainage_and_signed_offset() {
        let c = CenterLine::from_pieces(&[CurvePiece {
            length_m: 100.0,
            curvature_per_m: 0.0,
        }])
        .unwrap();
        let p = c.project(37.25, 1.5, 0.0, 1000.0);
        assert!((p.s_m - 37.25).abs() < 1e-9 && (p.lateral_m - 1.5).abs() < 1e-9);
        let q = c.project(10.0, -2.0, 9.0, 5.0);
        assert!((q.lateral_m + 2.0).abs() < 1e-9);
        let (x, y) = c.offset_point(5.0, -1.0);
        assert!((x - 5.0).abs() < 1e-12 && (y + 1.0).abs() < 1e-12);
    }

    #[test]
    fn csv_with_header_and_bad_line() {
        let c = CenterLine::parse_csv("x,y\n0,0\n3,4\n# note\n6,8\n").unwrap();
        assert!((c.length_m() - 10.0).abs() < 1e-12);
        let e = CenterLine::parse_csv("0,0\n1,nope\n").unwrap_err();
        assert_eq!(
            e,
            CsvCenterLineError::BadLine {
                line: 2,
                text: "1,nope".into()
            }
        );
        assert!(CenterLine::parse_csv("1,1\n1,1\n").is_err());
    }

    #[test]
    fn bad_pieces_are_rejected() {
        assert_eq!(
            CenterLine::from_pieces(&[CurvePiece {
                length_m: -1.0,
                curvature_per_m: 0.0
            }])
            .unwrap_err(),
            CenterLineError::BadPiece { index: 0 }
        );
        assert_eq!(
            CenterLine::from_pieces(&[]).unwrap_err(),
            CenterLineError::TooShort
        );
    }

    /// Inputs that would make the simulator allocate without bound are refused before any
    /// sampling: a piece of 1e300 m, points at 1e308 m, a survey in millimetres.
    #[test]
    fn absurd_sizes_are_refused_before_allocating() {
        let e = CenterLine::from_pieces(&[CurvePiece {
            length_m: 1e300,
            curvature_per_m: 0.0,
        }])
        .unwrap_err();
        assert!(matches!(e, CenterLineError::TooLong { .. }), "{e}");
        let e = CenterLine::parse_csv("x,y\n0,0\n1e308,0\n").unwrap_err();
        assert!(e.to_string().contains("line 3"), "{e}");
        assert!(e.to_string().contains("beyond"), "{e}");
        // 400 m surveyed in millimetres: 400 km.
        let mm: String = (0..=200).map(|k| format!("{},0\n", k * 2000)).collect();
        let e = CenterLine::parse_csv(&mm).unwrap_err();
        assert!(e.to_string().contains("millimetres"), "{e}");
        // A real UTM survey is fine.
        let utm: String = (0..=100)
            .map(|k| format!("{},{}\n", 512_345.0 + f64::from(k) * 2.0, 7_034_567.0))
            .collect();
        assert!((CenterLine::parse_csv(&utm).unwrap().length_m() - 200.0).abs() < 1e-6);
    }
}
