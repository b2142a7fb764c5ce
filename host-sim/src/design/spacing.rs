//! Landmark spacings that identify the vehicle's position: each wall's spacings are drawn
//! from §4.4's `U[D − 0.625, D + 0.625]` m so that every window of `window` consecutive
//! spacings differs from every other window of the wall by at least the tolerance in some
//! spacing — a vehicle that has measured that many spacings knows where it is.
//!
//! Two windows are *indistinguishable* when every pair of corresponding spacings differs by
//! less than the tolerance (Chebyshev distance below it): the lidar measures a spacing to a
//! few millimetres, and the default tolerance (50 mm) leaves room for mounting error.

use loc_core::rng::Pcg32;

use crate::world::layout::SPACING_JITTER_M;

/// Why a layout could not be drawn.
#[derive(Debug, Clone, PartialEq)]
pub enum SpacingError {
    /// No draw kept every window unique.
    NoUniqueLayout {
        /// Spacings drawn before it failed.
        drawn: usize,
        /// The window asked for.
        window: usize,
        /// The tolerance asked for, metres.
        tolerance_m: f64,
    },
}

impl std::fmt::Display for SpacingError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SpacingError::NoUniqueLayout {
                drawn,
                window,
                tolerance_m,
            } => write!(
                f,
                "after {drawn} spacings no draw keeps every window of {window} spacings unique at {:.0} mm: raise --window or lower --spacing-tolerance-mm",
                tolerance_m * 1e3
            ),
        }
    }
}

impl std::error::Error for SpacingError {}

/// True when the windows of `window` spacings starting at `i` and `j` are
/// indistinguishable at `tolerance_m`.
fn same(d: &[f64], i: usize, j: usize, window: usize, tolerance_m: f64) -> bool {
    (0..window).all(|m| (d[i + m] - d[j + m]).abs() < tolerance_m)
}

/// The first pair of indistinguishable windows of `window` spacings, if any.
pub fn ambiguous_pair(d: &[f64], window: usize, tolerance_m: f64) -> Option<(usize, usize)> {
    if window == 0 || d.len() < window {
        return None;
    }
    let n = d.len() + 1 - window;
    (0..n).find_map(|i| {
        ((i + 1)..n)
            .find(|&j| same(d, i, j, window, tolerance_m))
            .map(|j| (i, j))
    })
}

/// The shortest window that tells every position apart (every window of that many
/// spacings unique); the whole sequence when nothing shorter does, `None` for no spacing.
pub fn shortest_unique_window(d: &[f64], tolerance_m: f64) -> Option<usize> {
    (1..=d.len()).find(|&k| ambiguous_pair(d, k, tolerance_m).is_none())
}

/// Draws spacings for a wall from `first_m` up to `last_m` (centre chainages, metres),
/// keeping every window of `window` spacings unique at `tolerance_m`. Returns the centre
/// chainages.
pub fn draw_unique(
    spacing_m: f64,
    first_m: f64,
    last_m: f64,
    window: usize,
    tolerance_m: f64,
    rng: &mut Pcg32,
) -> Result<Vec<f64>, SpacingError> {
    const TRIES: usize = 2000;
    let lo = (spacing_m - SPACING_JITTER_M).max(0.05);
    let hi = spacing_m + SPACING_JITTER_M;
    let mut s = vec![first_m];
    let mut d: Vec<f64> = Vec::new();
    while s[s.len() - 1] + lo <= last_m {
        let mut accepted = false;
        for _ in 0..TRIES {
            let next = lo + (hi - lo) * f64::from(rng.uniform01());
            if s[s.len() - 1] + next > last_m {
                // The tunnel ends: no landmark past it, and nothing to keep unique.
                return Ok(s);
            }
            d.push(next);
            let k = d.len();
            let unique = k < window
                || (0..k - window).all(|i| !same(&d, i, k - window, window, tolerance_m));
            if unique {
                accepted = true;
                break;
            }
            d.pop();
        }
        if !accepted {
            return Err(SpacingError::NoUniqueLayout {
                drawn: d.len(),
                window,
                tolerance_m,
            });
        }
        s.push(s[s.len() - 1] + d[d.len() - 1]);
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_are_compared_spacing_by_spacing() {
        let d = [9.0, 9.5, 9.0, 9.5, 9.2];
        // Windows of 2: (9.0, 9.5) at 0 and at 2 are the same.
        assert_eq!(ambiguous_pair(&d, 2, 0.05), Some((0, 2)));
        // Windows of 3: (9.0, 9.5, 9.0), (9.5, 9.0, 9.5), (9.0, 9.5, 9.2): all differ.
        assert_eq!(ambiguous_pair(&d, 3, 0.05), None);
        assert_eq!(shortest_unique_window(&d, 0.05), Some(3));
        // Within tolerance counts as the same.
        assert_eq!(ambiguous_pair(&[9.0, 9.04], 1, 0.05), Some((0, 1)));
        assert_eq!(ambiguous_pair(&[9.0, 9.06], 1, 0.05), None);
        // A constant sequence identifies no position short of the whole wall.
        assert_eq!(shortest_unique_window(&[9.0; 6], 0.05), Some(6));
        assert_eq!(shortest_unique_window(&[], 0.05), None);
    }

    #[test]
    fn drawn_layouts_keep_every_window_unique_and_stay_in_the_interval() {
        let mut rng = Pcg32::seeded(4);
        let s = draw_unique(9.0, 2.0, 1000.0, 3, 0.05, &mut rng).unwrap();
        assert!(s.len() > 100, "{}", s.len());
        let d: Vec<f64> = s.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(d.iter().all(|&x| (8.375..=9.625).contains(&x)));
        assert_eq!(ambiguous_pair(&d, 3, 0.05), None);
        assert!(shortest_unique_window(&d, 0.05).unwrap() <= 3);
        assert!(*s.last().unwrap() <= 1000.0);
        // An impossible request is refused, not emitted: 1 spacing, 0.5 m tolerance.
        let e = draw_unique(9.0, 2.0, 1000.0, 1, 0.5, &mut Pcg32::seeded(1)).unwrap_err();
        assert!(e.to_string().contains("--window"), "{e}");
    }
}
