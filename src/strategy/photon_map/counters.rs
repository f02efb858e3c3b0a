//! Work counted while rendering: gather rays, estimates, lookups, cache hits and misses,
//! summed over threads.

use std::sync::atomic::{AtomicU64, Ordering};

/// Work counted while rendering (cumulative since `prepare`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PhotonMapCounters {
    /// Final-gather rays, primary and secondary.
    pub gather_rays: u64,
    /// Secondary gathers started.
    pub secondary_gathers: u64,
    /// Global-map density estimates (full N-nearest radiance estimates).
    pub map_estimates: u64,
    /// Precomputed-irradiance lookups.
    pub irradiance_lookups: u64,
    /// Caustic-map radiance estimates.
    pub caustic_estimates: u64,
    /// Final gathers at camera-path hits (each of `gather_rays` rays), the irradiance cache's
    /// records included.
    pub final_gathers: u64,
    /// Camera-path hits shaded from the irradiance cache.
    pub cache_lookups: u64,
    /// Camera-path Lambertian hits where the cache had no valid record (full final gather).
    pub cache_misses: u64,
}

#[derive(Default)]
pub(super) struct AtomicCounters([AtomicU64; 8]);

impl AtomicCounters {
    pub(super) fn add(&self, c: &PhotonMapCounters) {
        let v = [
            c.gather_rays,
            c.secondary_gathers,
            c.map_estimates,
            c.irradiance_lookups,
            c.caustic_estimates,
            c.final_gathers,
            c.cache_lookups,
            c.cache_misses,
        ];
        for (a, x) in self.0.iter().zip(v) {
            if x != 0 {
                a.fetch_add(x, Ordering::Relaxed);
            }
        }
    }

    pub(super) fn get(&self) -> PhotonMapCounters {
        let v = |i: usize| self.0[i].load(Ordering::Relaxed);
        PhotonMapCounters {
            gather_rays: v(0),
            secondary_gathers: v(1),
            map_estimates: v(2),
            irradiance_lookups: v(3),
            caustic_estimates: v(4),
            final_gathers: v(5),
            cache_lookups: v(6),
            cache_misses: v(7),
        }
    }

    pub(super) fn reset(&self) {
        for a in &self.0 {
            a.store(0, Ordering::Relaxed);
        }
    }
}
