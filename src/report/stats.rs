//! Statistics over seeds: mean, standard deviation, Student-t confidence intervals and Welch's
//! unequal-variance t-test, implemented here (no statistics crate).
//!
//! The t distribution's CDF is written through the regularised incomplete beta function,
//! `P(T ≤ t) = 1 − ½ I_{ν/(ν+t²)}(ν/2, ½)` for `t ≥ 0` (Abramowitz & Stegun 26.7.1), and
//! `I_x(a, b)` is evaluated by its continued fraction (A&S 26.5.8) with the modified Lentz
//! method. Quantiles invert the CDF by bisection to machine precision, so small samples (two or
//! three seeds) get exact intervals rather than a normal approximation.

use crate::sampling::chi2::ln_gamma;

/// Mean of `v` (NaN for an empty slice).
pub fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// Sample standard deviation with Bessel's correction (0 for fewer than two values).
pub fn std_dev(v: &[f64]) -> f64 {
    if v.len() < 2 {
        return 0.0;
    }
    let m = mean(v);
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
}

/// Confidence level of every interval the reports show.
pub const CONFIDENCE: f64 = 0.95;

/// Mean, standard deviation and confidence interval of one metric over seeds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Summary {
    pub n: usize,
    pub mean: f64,
    pub std_dev: f64,
    /// The [`CONFIDENCE`] interval of the mean; `None` for fewer than two values. With
    /// `h = t_{(1+c)/2, n−1} · s / √n`: for positive values (errors, times: every metric the
    /// reports show) it is computed on the log scale by the delta method,
    /// `mean · exp(±h / mean)`, so it never reaches zero or below and reads symmetrically on
    /// the log axes of the plots (the rule the ratio intervals use); otherwise `mean ± h`.
    pub ci: Option<(f64, f64)>,
}

impl Summary {
    pub fn of(v: &[f64]) -> Summary {
        let (n, mean, std_dev) = (v.len(), mean(v), std_dev(v));
        let ci = (n >= 2).then(|| {
            let half = t_quantile(0.5 + CONFIDENCE / 2.0, (n - 1) as f64) * std_dev / (n as f64).sqrt();
            if v.iter().all(|&x| x > 0.0) && mean.is_finite() {
                let factor = (half / mean).exp();
                (mean / factor, mean * factor)
            } else {
                (mean - half, mean + half)
            }
        });
        Summary { n, mean, std_dev, ci }
    }
}

/// Continued fraction of the incomplete beta function (A&S 26.5.8), modified Lentz method.
fn beta_continued_fraction(a: f64, b: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let clamp = |v: f64| if v.abs() < TINY { TINY } else { v };
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = 1.0 / clamp(1.0 - qab * x / qap);
    let mut h = d;
    for m in 1..=10_000 {
        let m = m as f64;
        let m2 = 2.0 * m;
        // Even step d_{2m}.
        let aa = m * (b - m) * x / ((qam + m2) * (a + m2));
        d = 1.0 / clamp(1.0 + aa * d);
        c = clamp(1.0 + aa / c);
        h *= d * c;
        // Odd step d_{2m+1}.
        let aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
        d = 1.0 / clamp(1.0 + aa * d);
        c = clamp(1.0 + aa / c);
        let delta = d * c;
        h *= delta;
        if (delta - 1.0).abs() < 1e-16 {
            break;
        }
    }
    h
}

/// The regularised incomplete beta function `I_x(a, b)` for a, b > 0 and x ∈ [0, 1].
pub fn incomplete_beta(a: f64, b: f64, x: f64) -> f64 {
    incomplete_beta_split(a, b, x, 1.0 - x)
}

/// `I_x(a, b)` given both `x` and `y = 1 − x`, so that a caller who knows a small `y`
/// exactly keeps its precision.
fn incomplete_beta_split(a: f64, b: f64, x: f64, y: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if y <= 0.0 {
        return 1.0;
    }
    let front = (ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * y.ln()).exp();
    // The continued fraction converges fast for x < (a + 1) / (a + b + 2); use the symmetry
    // I_x(a, b) = 1 − I_{1−x}(b, a) on the other side.
    if x < (a + 1.0) / (a + b + 2.0) {
        front * beta_continued_fraction(a, b, x) / a
    } else {
        1.0 - front * beta_continued_fraction(b, a, y) / b
    }
}

/// CDF of Student's t distribution with `df` > 0 degrees of freedom (not necessarily integer).
pub fn t_cdf(t: f64, df: f64) -> f64 {
    if t.is_nan() || df.is_nan() {
        return f64::NAN;
    }
    if t.is_infinite() {
        return if t > 0.0 { 1.0 } else { 0.0 };
    }
    // Upper tail P(T > |t|) = ½ I_{ν/(ν+t²)}(ν/2, ½).
    let tail = 0.5 * incomplete_beta_split(df / 2.0, 0.5, df / (df + t * t), t * t / (df + t * t));
    if t >= 0.0 { 1.0 - tail } else { tail }
}

/// The `p` quantile of Student's t distribution with `df` degrees of freedom: the t with
/// `t_cdf(t, df) = p`, found by bisection to machine precision.
pub fn t_quantile(p: f64, df: f64) -> f64 {
    let valid = p > 0.0 && p < 1.0 && df > 0.0;
    if !valid {
        return f64::NAN;
    }
    let (mut lo, mut hi) = (-1.0f64, 1.0f64);
    while t_cdf(lo, df) > p {
        lo *= 2.0;
    }
    while t_cdf(hi, df) < p {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid == lo || mid == hi {
            break;
        }
        if t_cdf(mid, df) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Welch's unequal-variance t-test of the hypothesis "the candidate's mean is larger than the
/// baseline's".
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Welch {
    pub t: f64,
    /// Welch–Satterthwaite degrees of freedom.
    pub df: f64,
    /// One-sided p-value `P(T ≥ t)` under equal means.
    pub p_greater: f64,
}

/// Welch's t-test of `candidate` against `baseline`; `None` unless both have two values or
/// more. When both samples have zero variance, p is 0 if the candidate's mean is larger, ½ if
/// the means are equal and 1 otherwise.
pub fn welch(baseline: &[f64], candidate: &[f64]) -> Option<Welch> {
    let (na, nb) = (baseline.len() as f64, candidate.len() as f64);
    if na < 2.0 || nb < 2.0 {
        return None;
    }
    let (ma, mb) = (mean(baseline), mean(candidate));
    let (va, vb) = (std_dev(baseline).powi(2) / na, std_dev(candidate).powi(2) / nb);
    let se2 = va + vb;
    if se2 == 0.0 {
        let p_greater = match mb.partial_cmp(&ma) {
            Some(std::cmp::Ordering::Greater) => 0.0,
            Some(std::cmp::Ordering::Equal) => 0.5,
            _ => 1.0,
        };
        let t = if mb == ma { 0.0 } else { (mb - ma) * f64::INFINITY };
        return Some(Welch {
            t,
            df: na + nb - 2.0,
            p_greater,
        });
    }
    let t = (mb - ma) / se2.sqrt();
    let df = se2 * se2 / (va * va / (na - 1.0) + vb * vb / (nb - 1.0));
    Some(Welch {
        t,
        df,
        p_greater: 1.0 - t_cdf(t, df),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * b.abs().max(1.0)
    }

    #[test]
    fn t_quantiles_match_published_tables() {
        // Two-sided 95 % critical values (the 0.975 quantile), e.g. NIST/SEMATECH e-Handbook
        // table 1.3.6.7.2, to the digits given there and beyond.
        let table = [
            (1.0, 12.706_204_736),
            (2.0, 4.302_652_730),
            (3.0, 3.182_446_305),
            (4.0, 2.776_445_105),
            (5.0, 2.570_581_836),
            (10.0, 2.228_138_852),
            (30.0, 2.042_272_456),
        ];
        for (df, expected) in table {
            let t = t_quantile(0.975, df);
            assert!(close(t, expected, 1e-9), "df {df}: {t} vs {expected}");
        }
        assert!(close(t_quantile(0.95, 1.0), 6.313_751_515, 1e-9));
        // Large df tends to the normal quantile 1.959964.
        assert!(close(t_quantile(0.975, 1e7), 1.959_963_985, 1e-6));
        assert!(close(t_quantile(0.025, 4.0), -2.776_445_105, 1e-9));
        assert!(t_quantile(0.5, 3.0).abs() < 1e-12);
    }

    #[test]
    fn t_cdf_is_symmetric_and_matches_the_cauchy_case() {
        for t in [-3.0, -0.5, 0.0, 0.7, 2.5] {
            assert!(close(t_cdf(t, 7.3) + t_cdf(-t, 7.3), 1.0, 1e-14));
            // df = 1 is the Cauchy distribution: ½ + atan(t) / π.
            let cauchy = 0.5 + f64::atan(t) / std::f64::consts::PI;
            assert!(close(t_cdf(t, 1.0), cauchy, 1e-12), "{t}");
        }
        assert!(close(1.0 - t_cdf(2.0, 10.0), 0.036_694_017, 1e-7));
    }

    #[test]
    fn ln_gamma_matches_factorials() {
        for (n, fact) in [(1.0, 1.0), (2.0, 1.0), (5.0, 24.0), (11.0, 3_628_800.0)] {
            assert!(close(ln_gamma(n), f64::ln(fact), 1e-12), "{n}");
        }
        assert!(close(ln_gamma(0.5), 0.5 * std::f64::consts::PI.ln(), 1e-12));
    }

    #[test]
    fn summary_gives_a_student_t_interval() {
        // With a value that is not positive: the plain interval mean ± h.
        let s = Summary::of(&[0.0, 1.0, 2.0]);
        assert_eq!(s.n, 3);
        assert!(close(s.mean, 1.0, 1e-15) && close(s.std_dev, 1.0, 1e-15));
        let (lo, hi) = s.ci.unwrap();
        let half = 4.302_652_730 / 3f64.sqrt();
        assert!(close(lo, 1.0 - half, 1e-9) && close(hi, 1.0 + half, 1e-9));
        assert!(Summary::of(&[5.0]).ci.is_none());
    }

    /// Positive values (the MSEs of three seeds, say, two decades apart): the interval is
    /// mean · exp(±h / mean), above zero however wide, symmetric on a log axis.
    #[test]
    fn intervals_of_positive_values_stay_above_zero_on_the_log_scale() {
        let s = Summary::of(&[0.01, 0.5, 2.0]);
        let (lo, hi) = s.ci.unwrap();
        let half = 4.302_652_730 * s.std_dev / 3f64.sqrt();
        assert!(half > s.mean, "the plain interval would go below zero");
        assert!(lo > 0.0 && close(lo * hi, s.mean * s.mean, 1e-12));
        assert!(close(hi, s.mean * (half / s.mean).exp(), 1e-8));
    }

    /// The log-scale interval covers the true mean about as often as it claims: 20 000
    /// intervals of 10 exponential draws (mean 1, the skew of per-seed errors).
    #[test]
    fn log_scale_intervals_cover_the_mean_near_their_level() {
        let mut rng = crate::sampling::Rng::for_task(7, [0, 0, 0]);
        let trials = 20_000;
        let covered = (0..trials)
            .filter(|_| {
                let v: Vec<f64> = (0..10).map(|_| -(1.0 - rng.uniform() as f64).ln()).collect();
                let (lo, hi) = Summary::of(&v).ci.unwrap();
                lo <= 1.0 && 1.0 <= hi
            })
            .count();
        let rate = covered as f64 / trials as f64;
        assert!((0.88..=0.98).contains(&rate), "coverage {rate}");
    }

    #[test]
    fn welch_detects_a_shift_and_not_equality() {
        let base = [1.0, 1.1, 0.9, 1.05, 0.95];
        let same = welch(&base, &base).unwrap();
        assert!(close(same.p_greater, 0.5, 1e-12), "{same:?}");
        let worse: Vec<f64> = base.iter().map(|x| x + 0.5).collect();
        assert!(welch(&base, &worse).unwrap().p_greater < 1e-4);
        assert!(welch(&worse, &base).unwrap().p_greater > 0.999);
        // Equal variances and sizes: t = Δ / (s √(2/n)), df = 2(n − 1).
        let w = welch(&[0.0, 2.0], &[2.0, 4.0]).unwrap();
        assert!(
            close(w.t, 2.0 / (2f64.sqrt() * 1.0), 1e-12) && close(w.df, 2.0, 1e-12),
            "{w:?}"
        );
        assert_eq!(welch(&[1.0, 1.0], &[2.0, 2.0]).unwrap().p_greater, 0.0);
        assert!(welch(&[1.0], &[2.0, 3.0]).is_none());
    }
}
