//! Piecewise-constant discrete distributions (light selection by power, guided-pdf cells).

/// A discrete distribution over `n` items proportional to non-negative weights.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    /// Cumulative weights normalised to end at 1; `cdf[0] = 0`, length n + 1.
    cdf: Vec<f32>,
    /// Probability of each item.
    pmf: Vec<f32>,
    total: f64,
}

impl Distribution1D {
    /// Builds the distribution; returns `None` if there are no weights, any weight is negative or
    /// non-finite, or all are zero.
    pub fn new(weights: &[f32]) -> Option<Self> {
        // No early exit: the test over all weights is then a few vector instructions.
        let valid = weights.iter().fold(true, |ok, w| ok & w.is_finite() & (*w >= 0.0));
        if weights.is_empty() || !valid {
            return None;
        }
        let total: f64 = weights.iter().map(|&w| w as f64).sum();
        if total <= 0.0 {
            return None;
        }
        // Eight running sums at a time, then their divisions by `total` in a loop of their own:
        // the divisions (most of the build's time when interleaved with the sums; a Jensen grid
        // has 64 cells) then run four to a vector instruction, each rounded as before.
        let mut cdf = Vec::with_capacity(weights.len() + 1);
        cdf.push(0.0);
        let mut acc = 0.0f64;
        for chunk in weights.chunks(8) {
            let mut sums = [0.0f64; 8];
            for (s, &w) in sums.iter_mut().zip(chunk) {
                acc += w as f64;
                *s = acc;
            }
            let quotients = sums.map(|s| (s / total) as f32);
            cdf.extend_from_slice(&quotients[..chunk.len()]);
        }
        *cdf.last_mut().unwrap() = 1.0;
        let pmf = weights.iter().map(|&w| (w as f64 / total) as f32).collect();
        Some(Self { cdf, pmf, total })
    }

    pub fn len(&self) -> usize {
        self.pmf.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }

    /// Sum of the weights the distribution was built from.
    pub fn total(&self) -> f64 {
        self.total
    }

    /// Probability of item `i`.
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf[i]
    }

    /// Picks an item with `u ∈ [0,1)`; returns the item, its probability and `u` remapped to
    /// [0,1) within the item (so one uniform number can be reused).
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32, f32) {
        Self::sample_slices(&self.cdf, &self.pmf, u)
    }

    /// The cumulative weights (length n + 1, from 0 to 1) and the probabilities (length n),
    /// for storing a distribution flat among others ([`Distribution1D::sample_slices`]).
    pub fn slices(&self) -> (&[f32], &[f32]) {
        (&self.cdf, &self.pmf)
    }

    /// [`Distribution1D::sample`] on the slices [`Distribution1D::slices`] gave.
    #[inline]
    pub fn sample_slices(cdf: &[f32], pmf: &[f32], u: f32) -> (usize, f32, f32) {
        // Largest i with cdf[i] <= u, skipping zero-probability items.
        let mut i = cdf.partition_point(|&c| c <= u).saturating_sub(1);
        i = i.min(pmf.len() - 1);
        while pmf[i] == 0.0 && i > 0 {
            i -= 1;
        }
        while pmf[i] == 0.0 {
            i += 1;
        }
        let width = cdf[i + 1] - cdf[i];
        let u_rem = if width > 0.0 {
            ((u - cdf[i]) / width).clamp(0.0, 1.0 - f32::EPSILON)
        } else {
            0.0
        };
        (i, pmf[i], u_rem)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn sampling_frequencies_match_pmf() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0, 4.0]).unwrap();
        let mut counts = [0u32; 4];
        let mut rng = Rng::for_task(3, [0, 0, 0]);
        let n = 80_000;
        for _ in 0..n {
            let (i, p, u) = d.sample(rng.uniform());
            assert_eq!(p, d.pmf(i));
            assert!((0.0..1.0).contains(&u));
            counts[i] += 1;
        }
        assert_eq!(counts[1], 0);
        let expected = [0.125, 0.0, 0.375, 0.5];
        let chi2 = crate::sampling::chi2::chi2_statistic(
            &counts.iter().map(|&c| c as f64).collect::<Vec<_>>(),
            &expected.iter().map(|&p| p * n as f64).collect::<Vec<_>>(),
            5.0,
        );
        assert!(chi2.p_value > 1e-4, "{chi2:?}");
    }

    #[test]
    fn rejects_degenerate_weights() {
        assert!(Distribution1D::new(&[]).is_none());
        assert!(Distribution1D::new(&[0.0, 0.0]).is_none());
        assert!(Distribution1D::new(&[1.0, f32::NAN]).is_none());
        assert!(Distribution1D::new(&[1.0, -1.0]).is_none());
    }
}
