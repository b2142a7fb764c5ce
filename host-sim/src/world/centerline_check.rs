//! Can a tunnel of a given width follow this centre line? Its walls are the centre line
//! offset by half the width on each side; they fold over where the line bends tighter than
//! half the width, and they cross where the line turns back on itself or comes back within
//! a width of an earlier stretch. Such a line is a survey error (a spike, points out of
//! order, a loop closed twice), and a simulation of it would be nonsense: it is refused
//! with the place — chainage, and the CSV line for a surveyed line.

use std::collections::HashMap;
use std::fmt;

use super::centerline::CenterLine;

/// Heading change between two consecutive survey chords beyond which the line turns back,
/// radians (150°).
pub const TURN_BACK_RAD: f64 = 150.0 * std::f64::consts::PI / 180.0;

/// Where on the centre line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Place {
    /// Chainage, metres.
    pub s_m: f64,
    /// The CSV line of the nearest surveyed point, when the line is surveyed.
    pub line: Option<usize>,
}

impl fmt::Display for Place {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "chainage {:.2} m", self.s_m)?;
        if let Some(l) = self.line {
            write!(f, " (CSV line {l})")?;
        }
        Ok(())
    }
}

/// Why a tunnel cannot follow the centre line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GeometryIssue {
    /// The line reverses between two survey chords.
    TurnsBack {
        /// Where.
        at: Place,
        /// The heading change, radians.
        turn_rad: f64,
    },
    /// The line bends tighter than half the tunnel width: the inner wall folds over.
    TooTight {
        /// Where.
        at: Place,
        /// The bend's radius over one tunnel width of chainage, metres.
        radius_m: f64,
        /// Half the tunnel width, metres.
        half_width_m: f64,
    },
    /// The line comes back within a tunnel width of an earlier stretch: the walls cross.
    RunsIntoItself {
        /// The later place.
        at: Place,
        /// The earlier one.
        earlier: Place,
        /// Their distance, metres.
        distance_m: f64,
    },
}

impl fmt::Display for GeometryIssue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GeometryIssue::TurnsBack { at, turn_rad } => write!(
                f,
                "the centre line turns back at {at} ({:.0}° between two survey chords): a survey point out of order or a spike; remove or reorder it",
                turn_rad.to_degrees()
            ),
            GeometryIssue::TooTight {
                at,
                radius_m,
                half_width_m,
            } => write!(
                f,
                "the centre line bends with a radius of {radius_m:.2} m at {at}, tighter than half the tunnel width ({half_width_m:.2} m): the inner wall would fold over; smooth the survey or check the width"
            ),
            GeometryIssue::RunsIntoItself {
                at,
                earlier,
                distance_m,
            } => write!(
                f,
                "the centre line at {at} comes within {distance_m:.2} m of itself at {earlier}, less than the tunnel width: the walls would cross; is a stretch surveyed twice or the loop closed twice?"
            ),
        }
    }
}

impl std::error::Error for GeometryIssue {}

/// Checks that a tunnel `width_m` wide can follow `line`.
pub fn check(line: &CenterLine, width_m: f64) -> Result<(), GeometryIssue> {
    let samples = line.samples();
    let place = |i: usize| Place {
        s_m: samples.get(i).map_or(0.0, |s| s.s_m),
        line: line.source_line(i),
    };
    // Reversals between consecutive chords (headings are unwrapped chord directions).
    for (i, w) in samples.windows(2).enumerate() {
        let turn_rad = (w[1].heading_rad - w[0].heading_rad).abs();
        if turn_rad > TURN_BACK_RAD {
            return Err(GeometryIssue::TurnsBack {
                at: place(i + 1),
                turn_rad,
            });
        }
    }
    // The mean curvature over one tunnel width of chainage: R < W/2 turns more than 2 rad.
    let half_width_m = width_m / 2.0;
    let mut j = 0usize;
    for (i, a) in samples.iter().enumerate() {
        j = j.max(i);
        while samples.get(j).is_some_and(|b| b.s_m - a.s_m < width_m) {
            j += 1;
        }
        let Some(b) = samples.get(j) else { break };
        let turn_rad = (b.heading_rad - a.heading_rad).abs();
        let radius_m = (b.s_m - a.s_m) / turn_rad;
        if radius_m < half_width_m {
            return Err(GeometryIssue::TooTight {
                at: place(i),
                radius_m,
                half_width_m,
            });
        }
    }
    runs_into_itself(line, width_m, &place)
}

/// Points every half width along the line, hashed in a grid of one width: any two more
/// than two widths apart along the line but closer than 0.9 widths in space. (A bend of
/// exactly half the width brings points two widths apart along it to 0.91 widths.)
fn runs_into_itself(
    line: &CenterLine,
    width_m: f64,
    place: &dyn Fn(usize) -> Place,
) -> Result<(), GeometryIssue> {
    let step_m = width_m / 2.0;
    let n = (line.length_m() / step_m).ceil() as usize + 1;
    let cell = |x: f64, y: f64| ((x / width_m).floor() as i64, (y / width_m).floor() as i64);
    let mut grid: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
    let points: Vec<(f64, f64, f64)> = (0..n)
        .map(|k| {
            let s = (k as f64 * step_m).min(line.length_m());
            let (x, y, _) = line.pose_at(s);
            (s, x, y)
        })
        .collect();
    let nearest_sample = |s_m: f64| {
        line.samples()
            .partition_point(|p| p.s_m < s_m)
            .min(line.samples().len() - 1)
    };
    for (k, &(s, x, y)) in points.iter().enumerate() {
        let (cx, cy) = cell(x, y);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for &m in grid.get(&(cx + dx, cy + dy)).into_iter().flatten() {
                    let (s0, x0, y0) = points[m];
                    let distance_m = (x - x0).hypot(y - y0);
                    if s - s0 > 2.0 * width_m && distance_m < 0.9 * width_m {
                        return Err(GeometryIssue::RunsIntoItself {
                            at: Place {
                                s_m: s,
                                ..place(nearest_sample(s))
                            },
                            earlier: Place {
                                s_m: s0,
                                ..place(nearest_sample(s0))
                            },
                            distance_m,
                        });
                    }
                }
            }
        }
        grid.entry((cx, cy)).or_default().push(k);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::centerline::CurvePiece;

    fn piece(length_m: f64, radius_m: Option<f64>) -> CurvePiece {
        CurvePiece {
            length_m,
            curvature_per_m: radius_m.map_or(0.0, |r| 1.0 / r),
        }
    }

    #[test]
    fn a_tunnel_follows_bends_down_to_half_its_width() {
        let line = CenterLine::from_pieces(&[
            piece(20.0, None),
            piece(15.0, Some(6.0)),
            piece(20.0, None),
        ])
        .unwrap();
        assert!(check(&line, 4.5).is_ok());
        let e = check(&line, 20.0).unwrap_err();
        assert!(
            matches!(e, GeometryIssue::TooTight { radius_m, .. } if radius_m < 10.0),
            "{e}"
        );
        assert!(
            e.to_string().contains("half the tunnel width (10.00 m)"),
            "{e}"
        );
        // A 6 m radius in a 12.5 m tunnel: measured over one width inside the bend.
        let long = CenterLine::from_pieces(&[
            piece(20.0, None),
            piece(18.0, Some(6.0)),
            piece(20.0, None),
        ])
        .unwrap();
        let e = check(&long, 12.5).unwrap_err();
        assert!(
            matches!(e, GeometryIssue::TooTight { radius_m, .. } if (radius_m - 6.0).abs() < 0.3),
            "{e}"
        );
    }

    #[test]
    fn a_survey_spike_turns_back_and_names_its_line() {
        let csv = "x_m,y_m\n0,0\n10,0\n20,0\n15,0.1\n30,0\n40,0\n";
        let line = CenterLine::parse_csv(csv).unwrap();
        let e = check(&line, 4.0).unwrap_err();
        assert!(matches!(e, GeometryIssue::TurnsBack { .. }), "{e}");
        assert!(e.to_string().contains("CSV line 4"), "{e}");
    }

    #[test]
    fn a_loop_closed_twice_runs_into_itself() {
        // A full circle of radius 30 m, then on: the line crosses its own start.
        let line = CenterLine::from_pieces(&[
            piece(10.0, None),
            piece(2.0 * std::f64::consts::PI * 30.0, Some(30.0)),
            piece(20.0, None),
        ])
        .unwrap();
        let e = check(&line, 4.0).unwrap_err();
        assert!(matches!(e, GeometryIssue::RunsIntoItself { .. }), "{e}");
        // A U-turn of radius 3 m with a 4 m tunnel is fine: the legs are 6 m apart.
        let u = CenterLine::from_pieces(&[
            piece(20.0, None),
            piece(std::f64::consts::PI * 3.0, Some(3.0)),
            piece(20.0, None),
        ])
        .unwrap();
        assert!(check(&u, 4.0).is_ok(), "{:?}", check(&u, 4.0));
        // The same U-turn in a 7 m tunnel: legs 6 m apart are closer than a width.
        assert!(check(&u, 7.0).is_err());
    }

    #[test]
    fn the_shipped_s_bend_passes() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/scenarios/s-bend-400m.csv"
        ))
        .unwrap();
        let line = CenterLine::parse_csv(&text).unwrap();
        assert!(check(&line, 4.5).is_ok(), "{:?}", check(&line, 4.5));
    }

    proptest::proptest! {
        /// Any list of points is either refused or checked, never a panic or an unbounded
        /// allocation.
        #[test]
        fn any_points_are_refused_or_checked(
            pts in proptest::collection::vec(
                proptest::prop_oneof![
                    (-500.0f64..500.0, -500.0f64..500.0),
                    (proptest::num::f64::ANY, proptest::num::f64::ANY),
                ],
                0..40,
            ),
            width_m in 0.5f64..30.0,
        ) {
            if let Ok(line) = CenterLine::from_points(&pts) {
                proptest::prop_assert!(line.length_m() <= crate::world::centerline::MAX_LENGTH_M);
                let _ = check(&line, width_m);
            }
        }
    }
}
