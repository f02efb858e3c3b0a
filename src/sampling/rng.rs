//! Seeded random-number streams.
//!
//! Every random decision comes from a `Xoshiro256PlusPlus` stream whose seed is derived from
//! the experiment seed and the *task* (pixel and sample index, photon index, chain index …),
//! never from thread scheduling. Rendering the same experiment with the same seed therefore
//! gives a bit-identical image on any number of threads.

use glam::Vec2;
use rand::{Rng as _, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// SplitMix64 finaliser: a bijective 64-bit mixer [Steele et al. 2014].
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Derives the seed of one task's stream from the experiment seed and up to three task
/// coordinates (e.g. `[purpose, pixel, sample index]`). Distinct inputs give unrelated streams.
#[inline]
pub fn stream_seed(seed: u64, task: [u64; 3]) -> u64 {
    let mut h = mix64(seed);
    for t in task {
        h = mix64(h ^ t);
    }
    h
}

/// A random-number stream for one task.
#[derive(Clone, Debug)]
pub struct Rng(Xoshiro256PlusPlus);

impl Rng {
    /// The stream of task `task` under experiment seed `seed`.
    pub fn for_task(seed: u64, task: [u64; 3]) -> Self {
        Self(Xoshiro256PlusPlus::seed_from_u64(stream_seed(seed, task)))
    }

    /// A uniform `f32` in [0, 1), built from the top 24 bits so that 1.0 is never returned.
    #[inline]
    pub fn uniform(&mut self) -> f32 {
        (self.0.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// A uniform point of [0, 1)².
    #[inline]
    pub fn uniform2(&mut self) -> Vec2 {
        Vec2::new(self.uniform(), self.uniform())
    }

    /// A uniform `f64` in [0, 1).
    #[inline]
    pub fn uniform_f64(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// A uniform integer in `0..n` (n > 0), without modulo bias.
    #[inline]
    pub fn below(&mut self, n: u32) -> u32 {
        debug_assert!(n > 0);
        ((self.0.next_u32() as u64 * n as u64) >> 32) as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<f32> = (0..8)
            .map({
                let mut r = Rng::for_task(7, [0, 1, 2]);
                move |_| r.uniform()
            })
            .collect();
        let b: Vec<f32> = (0..8)
            .map({
                let mut r = Rng::for_task(7, [0, 1, 2]);
                move |_| r.uniform()
            })
            .collect();
        let c: Vec<f32> = (0..8)
            .map({
                let mut r = Rng::for_task(7, [0, 1, 3]);
                move |_| r.uniform()
            })
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert!(a.iter().all(|&x| (0.0..1.0).contains(&x)));
    }

    #[test]
    fn uniform_mean_is_one_half() {
        let mut r = Rng::for_task(1, [0, 0, 0]);
        let n = 200_000;
        let mean = (0..n).map(|_| r.uniform() as f64).sum::<f64>() / n as f64;
        // Standard error of the mean of U(0,1) is 1/sqrt(12 n) ≈ 6.5e-4; allow 5 sigma.
        assert!(
            (mean - 0.5).abs() < 5.0 * (1.0 / (12.0 * n as f64)).sqrt(),
            "mean {mean}"
        );
    }
}
