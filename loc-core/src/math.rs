//! The one maths library of the core.
//!
//! Every transcendental function the core uses is called through this module, which
//! forwards to [`libm`]. `libm` is a pure-Rust port of musl's libm: the host tests and the
//! Cortex-M firmware therefore compute bit-identical results, unlike `f32::atan2` (std's
//! on the host) versus an approximation on the target.

use core::f32::consts::PI;

/// Sine of an angle in radians.
#[inline]
pub fn sin(angle_rad: f32) -> f32 {
    libm::sinf(angle_rad)
}

/// Cosine of an angle in radians.
#[inline]
pub fn cos(angle_rad: f32) -> f32 {
    libm::cosf(angle_rad)
}

/// Sine and cosine of an angle in radians, `(sin, cos)`.
#[inline]
pub fn sin_cos(angle_rad: f32) -> (f32, f32) {
    libm::sincosf(angle_rad)
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

/// Absolute value.
#[inline]
pub fn abs(x: f32) -> f32 {
    libm::fabsf(x)
}

/// Largest integer value not greater than `x`.
#[inline]
pub fn floor(x: f32) -> f32 {
    libm::floorf(x)
}

/// Hypotenuse `sqrt(x² + y²)` without undue overflow.
#[inline]
pub fn hypot(x: f32, y: f32) -> f32 {
    libm::hypotf(x, y)
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
    fn atan2_matches_quadrants() {
        assert!(abs(atan2(1.0, 1.0) - PI / 4.0) < 1e-6);
        assert!(abs(atan2(1.0, -1.0) - 3.0 * PI / 4.0) < 1e-6);
        assert!(abs(atan2(-1.0, -1.0) + 3.0 * PI / 4.0) < 1e-6);
    }
}
