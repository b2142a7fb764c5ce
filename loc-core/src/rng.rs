//! A small seeded pseudo-random generator (PCG32, O'Neill 2014) for RANSAC hypothesis
//! sampling and the test kit's noise simulator.
//!
//! Deterministic for a given seed on every target (integer arithmetic plus [`crate::math`]
//! for the Gaussian draws), so host tests reproduce what the MCU computes. Not for
//! cryptography.

use crate::math;

/// PCG-XSH-RR 32-bit output, 64-bit state generator.
#[derive(Debug, Clone)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
    /// The second value of the last Box–Muller pair, not yet returned.
    spare_gaussian: Option<f32>,
}

const MULTIPLIER: u64 = 6_364_136_223_846_793_005;

impl Pcg32 {
    /// A generator from a seed and a stream selector (different streams with the same seed
    /// give independent sequences).
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = Self {
            state: 0,
            inc: (stream << 1) | 1,
            spare_gaussian: None,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    /// A generator from a seed on the default stream.
    pub fn seeded(seed: u64) -> Self {
        Self::new(seed, 0xda3e_39cb_94b9_5bdb)
    }

    /// The next uniformly distributed 32-bit value.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(MULTIPLIER).wrapping_add(self.inc);
        // Truncations are the algorithm: xorshifted low 32 bits, rotation from the top 5.
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// A uniform integer in `[0, bound)`; 0 when `bound` is 0. Unbiased (Lemire's method
    /// with rejection).
    pub fn below(&mut self, bound: u32) -> u32 {
        if bound == 0 {
            return 0;
        }
        let threshold = bound.wrapping_neg() % bound;
        loop {
            let m = u64::from(self.next_u32()) * u64::from(bound);
            // Low 32 bits decide rejection; high 32 bits are the result.
            if (m as u32) >= threshold {
                return (m >> 32) as u32;
            }
        }
    }

    /// A uniform index in `[0, len)` for a slice of `len` elements; 0 when `len` is 0.
    pub fn index(&mut self, len: usize) -> usize {
        let bound = u32::try_from(len).unwrap_or(u32::MAX);
        self.below(bound) as usize
    }

    /// A uniform `f32` in `[0, 1)` with 24 bits of precision.
    pub fn uniform01(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// A uniform `f32` in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.uniform01()
    }

    /// A standard normal draw (mean 0, standard deviation 1), Box–Muller through
    /// [`crate::math`]; every second call returns the cached partner value.
    pub fn gaussian(&mut self) -> f32 {
        if let Some(z) = self.spare_gaussian.take() {
            return z;
        }
        // u1 in (0, 1] so ln(u1) is finite.
        let u1 = 1.0 - self.uniform01();
        let u2 = self.uniform01();
        let r = math::sqrt(-2.0 * libm::logf(u1));
        let (s, c) = math::sin_cos(2.0 * core::f32::consts::PI * u2);
        self.spare_gaussian = Some(r * s);
        r * c
    }

    /// A normal draw with the given mean and standard deviation.
    pub fn normal(&mut self, mean: f32, std_dev: f32) -> f32 {
        mean + std_dev * self.gaussian()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deterministic_and_stream_dependent() {
        let mut a = Pcg32::seeded(42);
        let mut b = Pcg32::seeded(42);
        let mut c = Pcg32::new(42, 7);
        let va: [u32; 4] = core::array::from_fn(|_| a.next_u32());
        let vb: [u32; 4] = core::array::from_fn(|_| b.next_u32());
        let vc: [u32; 4] = core::array::from_fn(|_| c.next_u32());
        assert_eq!(va, vb);
        assert_ne!(va, vc);
    }

    #[test]
    fn below_stays_in_bounds_and_covers() {
        let mut r = Pcg32::seeded(1);
        let mut seen = [false; 7];
        for _ in 0..1000 {
            let v = r.below(7) as usize;
            assert!(v < 7);
            seen[v] = true;
        }
        assert!(seen.iter().all(|&s| s));
        assert_eq!(r.below(0), 0);
    }

    #[test]
    fn gaussian_moments() {
        let mut r = Pcg32::seeded(3);
        let n = 20_000;
        let (mut s1, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let z = f64::from(r.gaussian());
            s1 += z;
            s2 += z * z;
        }
        let mean = s1 / n as f64;
        let var = s2 / n as f64 - mean * mean;
        assert!(mean.abs() < 0.03, "mean {mean}");
        assert!((var - 1.0).abs() < 0.05, "var {var}");
        let u = r.uniform(2.0, 3.0);
        assert!((2.0..3.0).contains(&u));
    }
}
