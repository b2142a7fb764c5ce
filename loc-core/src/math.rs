//! The one maths library of the core.
//!
//! Every transcendental function the core uses is called through this module, which
//! forwards to [`libm`]. `libm` is a pure-Rust port of musl's libm: the host tests and the
//! Cortex-M firmware therefore compute bit-identical results, unlike `f32::atan2` (std's
//! on the host) versus an approximation on the target.

use core::f32::consts::PI;

/// Largest |angle| in radians that the single-precision reduction below handles with full
/// f32 accuracy (Cephes' bound for a three-part Cody–Waite split of π/2); beyond it the
/// functions fall back to libm's (slow, f64-based) reduction.
const FAST_REDUCTION_LIMIT_RAD: f32 = 8192.0;

// π/2 split into three parts whose leading parts have few significant bits, so `n * PART`
// is exact in f32 for |n| < 2^13 (Cody–Waite).
const PIO2_HI: f32 = 1.570_312_5;
const PIO2_MID: f32 = 4.837_513e-4;
const PIO2_LO: f32 = 7.549_79e-8;

/// Minimax kernels for |r| ≤ π/4 (musl's `__sindf`/`__cosdf` coefficients, evaluated in f32).
#[inline]
fn sin_kernel(r: f32) -> f32 {
    const S1: f32 = -0.166_666_67;
    const S2: f32 = 0.008_333_329;
    const S3: f32 = -1.983_933_5e-4;
    const S4: f32 = 2.718_311_5e-6;
    let z = r * r;
    r + r * z * (S1 + z * S2 + z * z * (S3 + z * S4))
}

#[inline]
fn cos_kernel(r: f32) -> f32 {
    const C0: f32 = -0.5;
    const C1: f32 = 0.041_666_623;
    const C2: f32 = -1.388_676_4e-3;
    const C3: f32 = 2.439_045e-5;
    let z = r * r;
    1.0 + z * (C0 + z * (C1 + z * (C2 + z * C3)))
}

/// Reduces `angle_rad` to `r` in [-π/4, π/4] and the quadrant `n mod 4`.
#[inline]
fn reduce(angle_rad: f32) -> (f32, u32) {
    let n = libm::roundf(angle_rad * core::f32::consts::FRAC_2_PI);
    let r = ((angle_rad - n * PIO2_HI) - n * PIO2_MID) - n * PIO2_LO;
    // `n` is integral and |n| < 2^13 here, so the cast is exact; wrapping keeps the quadrant.
    (r, (n as i32 as u32) & 3)
}

/// Sine of an angle in radians.
///
/// Single-precision throughout (the Cortex-M4F FPU has no f64: libm's `sinf` costs ~1 250
/// instructions there, this ~40): within 2 ulp of the true value for |angle| ≤ 8192 rad,
/// libm's result beyond.
#[inline]
pub fn sin(angle_rad: f32) -> f32 {
    sin_cos(angle_rad).0
}

/// Cosine of an angle in radians; accuracy and cost as [`sin`].
#[inline]
pub fn cos(angle_rad: f32) -> f32 {
    sin_cos(angle_rad).1
}

/// Sine and cosine of an angle in radians, `(sin, cos)`; accuracy and cost as [`sin`].
/// NaN or infinite input gives `(NaN, NaN)`.
#[inline]
pub fn sin_cos(angle_rad: f32) -> (f32, f32) {
    if angle_rad.is_nan() || abs(angle_rad) > FAST_REDUCTION_LIMIT_RAD {
        return libm::sincosf(angle_rad);
    }
    let (r, quadrant) = reduce(angle_rad);
    let (s, c) = (sin_kernel(r), cos_kernel(r));
    match quadrant {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// Four-quadrant arctangent of `y / x`, in radians within `[-π, π]`.
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    libm::atan2f(y, x)
}

/// Square root; NaN for negative input.
#[inline]
pub fn sqrt(x: f32) -> f32 {
    libm::sqrtf(x)
}

/// Natural logarithm; NaN for negative input, −∞ at 0.
#[inline]
pub fn ln(x: f32) -> f32 {
    libm::logf(x)
}

/// `e^x` (libm's `expf`).
#[inline]
pub fn exp(x: f32) -> f32 {
    libm::expf(x)
}

/// Absolute value.
#[inline]
pub fn abs(x: f32) -> f32 {
    libm::fabsf(x)
}

/// Largest integer value not greater than `x`.
///
/// Below 2²³ in magnitude (every f32 beyond is an integer) through an `i32` conversion:
/// a few instructions where libm's bit manipulation takes about 30 on the Cortex-M4F, and
/// the same result, signed zeros included. NaN and larger values go to libm.
#[inline]
pub fn floor(x: f32) -> f32 {
    if abs(x) < 8_388_608.0 {
        // Exact: |x| < 2^23 fits an i32 and converts back exactly.
        let t = x as i32 as f32;
        if t > x {
            t - 1.0
        } else if t < x {
            t
        } else {
            x
        }
    } else {
        libm::floorf(x)
    }
}

/// Hypotenuse `sqrt(x² + y²)` without undue overflow.
#[inline]
pub fn hypot(x: f32, y: f32) -> f32 {
    libm::hypotf(x, y)
}

/// The larger of `a` and `b`; the other one when either is NaN (as `f32::max`).
///
/// Written as comparisons: `f32::max` is a call to `fmaxf` on the Cortex-M4F (its FPU has no
/// `VMAXNM`), about 15 instructions where this takes 3–4, and hot loops call it per point.
#[inline]
pub fn max(a: f32, b: f32) -> f32 {
    if a >= b || b.is_nan() {
        a
    } else {
        b
    }
}

/// The smaller of `a` and `b`; the other one when either is NaN (as `f32::min`). See
/// [`max`] for why it is not `f32::min`.
#[inline]
pub fn min(a: f32, b: f32) -> f32 {
    if a <= b || b.is_nan() {
        a
    } else {
        b
    }
}

/// A count as the `u16` the core's reports use, saturating at `u16::MAX` (counts are bounded
/// by the fixed capacities, so this never clips in practice).
#[inline]
pub fn saturating_u16<T: TryInto<u16>>(count: T) -> u16 {
    count.try_into().unwrap_or(u16::MAX)
}

/// Wraps an angle in radians into `(-π, π]`.
///
/// Non-finite input is returned unchanged (the caller's validity checks reject it).
#[inline]
pub fn wrap_angle(angle_rad: f32) -> f32 {
    if !angle_rad.is_finite() {
        return angle_rad;
    }
    let two_pi = 2.0 * PI;
    let mut a = angle_rad - two_pi * floor((angle_rad + PI) / two_pi);
    // floor() rounding can leave `a` exactly at -π; map it to +π to keep the interval half-open.
    if a <= -PI {
        a += two_pi;
    }
    if a > PI {
        a -= two_pi;
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_angle_stays_in_half_open_interval() {
        for k in -1000..1000 {
            let a = k as f32 * 0.37;
            let w = wrap_angle(a);
            assert!(w > -PI - 1e-6 && w <= PI + 1e-6, "{a} -> {w}");
            assert!(abs(sin(w) - sin(a)) < 1e-3 && abs(cos(w) - cos(a)) < 1e-3);
        }
        assert_eq!(wrap_angle(0.0), 0.0);
        assert!(wrap_angle(f32::NAN).is_nan());
    }

    #[test]
    fn fast_sin_cos_matches_libm() {
        let mut worst = 0.0f32;
        let mut a = -200.0f32;
        while a < 200.0 {
            let (s, c) = sin_cos(a);
            let (ls, lc) = libm::sincosf(a);
            worst = worst.max(abs(s - ls)).max(abs(c - lc));
            a += 0.000_731;
        }
        assert!(worst < 4e-7, "worst abs error {worst}");
        for big in [1.0e4f32, -3.0e6, 1.0e30] {
            assert_eq!(sin_cos(big), libm::sincosf(big));
        }
        let (s, c) = sin_cos(f32::NAN);
        assert!(s.is_nan() && c.is_nan());
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
    }

    #[test]
    fn floor_matches_libm() {
        let mut x = -70_000.0f32;
        while x < 70_000.0 {
            for v in [x, -x, x + 0.5, x - 0.25, x * 1.0e-4] {
                assert_eq!(floor(v).to_bits(), libm::floorf(v).to_bits(), "floor({v})");
            }
            x += 7.123;
        }
        for v in [
            0.0f32,
            -0.0,
            -0.5,
            0.5,
            -1.0,
            8_388_607.5,
            -8_388_607.5,
            8_388_608.0,
            1.0e30,
            -1.0e30,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
        ] {
            assert_eq!(floor(v).to_bits(), libm::floorf(v).to_bits(), "floor({v})");
        }
        assert!(floor(f32::NAN).is_nan());
    }

    #[test]
    fn max_min_match_std_including_nan() {
        let values = [
            -1.5f32,
            0.0,
            2.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        for a in values {
            for b in values {
                let same = |x: f32, y: f32| x == y || (x.is_nan() && y.is_nan());
                assert!(same(max(a, b), a.max(b)), "max({a}, {b})");
                assert!(same(min(a, b), a.min(b)), "min({a}, {b})");
            }
        }
    }

    #[test]
    fn atan2_matches_quadrants() {
        assert!(abs(atan2(1.0, 1.0) - PI / 4.0) < 1e-6);
        assert!(abs(atan2(1.0, -1.0) - 3.0 * PI / 4.0) < 1e-6);
        assert!(abs(atan2(-1.0, -1.0) + 3.0 * PI / 4.0) < 1e-6);
    }
}
