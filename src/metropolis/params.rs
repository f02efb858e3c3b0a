//! The chain's parameters, shared by `mlt` and `mps`: the proposal mix of Fan et al. 2005,
//! eq. (5), path length, B_eye samples, chain count and perturbation sizes.

use crate::error::{Error, Result};
use serde::Deserialize;

/// Proposal probabilities P_type, Σ = 1 [Fan et al. 2005, eq. (5)]. In an experiment file a
/// `proposals` table lists the non-zero ones (missing keys are 0); without the table the
/// default mix applies.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ProposalMix {
    #[serde(default)]
    pub up: f64,
    #[serde(default)]
    pub bd: f64,
    #[serde(default)]
    pub pm: f64,
    #[serde(default)]
    pub cp: f64,
    #[serde(default)]
    pub lp: f64,
    #[serde(default)]
    pub ls: f64,
    /// The multi-chain perturbation (not in Fan et al. 2005; [Veach 1997, §11.4.4]): 0 unless
    /// an experiment asks for it.
    #[serde(default)]
    pub mc: f64,
}

impl Default for ProposalMix {
    /// The paper's Lantern mix (no user paths): BD 0.4, PM 0.2, LP 0.2, LS 0.2.
    fn default() -> Self {
        Self {
            up: 0.0,
            bd: 0.4,
            pm: 0.2,
            cp: 0.0,
            lp: 0.2,
            ls: 0.2,
            mc: 0.0,
        }
    }
}

/// Number of proposal types.
pub const PROPOSALS: usize = 7;

/// The proposal types, in the order of [`ProposalMix`] and of the counters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Proposal {
    Up,
    Bd,
    Pm,
    Cp,
    Lp,
    Ls,
    Mc,
}

impl Proposal {
    pub const ALL: [Proposal; PROPOSALS] = [
        Proposal::Up,
        Proposal::Bd,
        Proposal::Pm,
        Proposal::Cp,
        Proposal::Lp,
        Proposal::Ls,
        Proposal::Mc,
    ];

    pub fn name(self) -> &'static str {
        ["up", "bd", "pm", "cp", "lp", "ls", "mc"][self as usize]
    }
}

impl ProposalMix {
    /// One proposal alone (for timing and tests: a chain of LP alone, say, is not ergodic, and
    /// UP alone is refused by validation).
    pub fn only(p: Proposal) -> Self {
        let mut values = [0.0; PROPOSALS];
        values[p as usize] = 1.0;
        let [up, bd, pm, cp, lp, ls, mc] = values;
        Self {
            up,
            bd,
            pm,
            cp,
            lp,
            ls,
            mc,
        }
    }

    pub fn get(&self, p: Proposal) -> f64 {
        [self.up, self.bd, self.pm, self.cp, self.lp, self.ls, self.mc][p as usize]
    }

    fn validate(&self) -> Result<()> {
        for p in Proposal::ALL {
            let v = self.get(p);
            if !(v.is_finite() && (0.0..=1.0).contains(&v)) {
                crate::bail!("proposals.{}: expected a probability in [0, 1], got {v}", p.name());
            }
        }
        let sum: f64 = Proposal::ALL.iter().map(|&p| self.get(p)).sum();
        if (sum - 1.0).abs() > 1e-6 {
            crate::bail!(
                "proposals: the probabilities up, bd, pm, cp, lp, ls, mc must sum to 1, got {sum} \
                 (up {}, bd {}, pm {}, cp {}, lp {}, ls {}, mc {})",
                self.up,
                self.bd,
                self.pm,
                self.cp,
                self.lp,
                self.ls,
                self.mc
            );
        }
        if self.up > 0.0 && self.bd == 0.0 {
            crate::bail!(
                "proposals: up > 0 needs bd > 0 (UP is combined with BD, which gives every path a \
                 way back [Fan et al. 2005, eq. (7)])"
            );
        }
        Ok(())
    }

    pub(super) fn choose(&self, u: f64) -> Proposal {
        let mut acc = 0.0;
        for p in Proposal::ALL {
            acc += self.get(p);
            if u < acc {
                return p;
            }
        }
        *Proposal::ALL
            .iter()
            .rev()
            .find(|&&p| self.get(p) > 0.0)
            .unwrap_or(&Proposal::Bd)
    }
}

/// Chain parameters shared by `mlt` and `mps`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct MetropolisParams {
    pub proposals: ProposalMix,
    /// Maximum scattering events of a path (edges − 1), as `path`'s `max_depth`.
    pub max_depth: u32,
    /// Path-tracing samples (whole-image eye paths) for B_eye and the chains' first states;
    /// absent: [`B_SAMPLES_PER_CHAIN`] per chain ([`Self::b_samples`]).
    pub b_samples: Option<u64>,
    /// Independent chains (fixed, so results do not depend on the thread count). **Decision:
    /// many short chains (default 8192).** Every chain starts from a path resampled ∝ f/p, so a
    /// short chain has no start-up bias, and it caps how many iterations a chain stuck in a
    /// state its proposals cannot leave (L S D S E in `box`) piles onto one photon or pixel:
    /// 64 → 8192 chains took MPS on box from rms_rel_lum 0.44 to 0.19 and MLT from 5.8 to 0.90
    /// (README, "Reproducing Fan et al. 2005").
    pub chains: u32,
    /// PM cone half-angle γ in degrees (paper: 30).
    pub pm_gamma_deg: f32,
    /// LP offsets: r ∈ [r1, r2] with density ∝ 1/r; r1 in pixels, r2 the radius of a disc
    /// covering this fraction of the image [Veach 1997, §11.4.3: 0.1 pixel and 10 %].
    pub lens_r1_px: f32,
    pub lens_r2_fraction: f32,
    /// CP angles θ ∈ [θ1, θ2] radians with density ∝ 1/θ [Veach 1997: 0.0001, 0.1].
    pub caustic_theta1: f32,
    pub caustic_theta2: f32,
}

impl Default for MetropolisParams {
    fn default() -> Self {
        Self {
            proposals: ProposalMix::default(),
            max_depth: 16,
            b_samples: None,
            chains: 8192,
            pm_gamma_deg: 30.0,
            lens_r1_px: 0.1,
            lens_r2_fraction: 0.1,
            caustic_theta1: 1e-4,
            caustic_theta2: 0.1,
        }
    }
}

/// Default path-tracing samples per chain for B_eye and the first states. **Decision** (beyond
/// the paper, which runs one chain): the pool grows with the chains. A chain's first state is
/// resampled from the pool ∝ f/p, which is unbiased with the pool's B_eye in expectation, but
/// a pool with few samples per chain starts many chains on the same heavy paths and misses the
/// rare ones: short chains then crowd their photons around those starts, and the k-nearest
/// estimate reads crowds as density. Measured with `bench map-error` on `lantern` (8 seeds,
/// 8192 chains, 500 000 mutations), the interior mean ratio went 1.068 ± 0.014 with 12 samples
/// per chain (the earlier fixed 100 000), 1.015 ± 0.014 with 100, photon mapping's k / (k − 1)
/// (README, "Reproducing Fan et al. 2005", item 10).
pub const B_SAMPLES_PER_CHAIN: u64 = 100;

impl MetropolisParams {
    /// Path-tracing samples for B_eye: `b_samples`, or [`B_SAMPLES_PER_CHAIN`] per chain.
    pub fn b_samples(&self) -> u64 {
        self.b_samples.unwrap_or(B_SAMPLES_PER_CHAIN * u64::from(self.chains))
    }

    pub fn validate(&self) -> Result<()> {
        self.proposals.validate()?;
        let bad = |what: &str, got: String| Err(Error::new(format!("{what}, got {got}")));
        if self.max_depth == 0 || self.max_depth > 64 {
            return bad(
                "max_depth: expected 1..=64 scattering events",
                self.max_depth.to_string(),
            );
        }
        if let Some(n) = self.b_samples
            && (n == 0 || n > 1_000_000_000)
        {
            return bad("b_samples: expected 1..=1000000000", n.to_string());
        }
        if self.chains == 0 || self.chains > 65_536 {
            return bad("chains: expected 1..=65536", self.chains.to_string());
        }
        if !(self.pm_gamma_deg > 0.0 && self.pm_gamma_deg <= 90.0) {
            return bad(
                "pm_gamma_deg: expected an angle in (0, 90]",
                self.pm_gamma_deg.to_string(),
            );
        }
        if !(self.lens_r1_px > 0.0 && self.lens_r1_px.is_finite()) {
            return bad("lens_r1_px: expected a positive radius", self.lens_r1_px.to_string());
        }
        if !(self.lens_r2_fraction > 0.0 && self.lens_r2_fraction <= 1.0) {
            return bad(
                "lens_r2_fraction: expected a fraction in (0, 1]",
                self.lens_r2_fraction.to_string(),
            );
        }
        if !(self.caustic_theta1 > 0.0 && self.caustic_theta1 < self.caustic_theta2 && self.caustic_theta2 <= 1.0) {
            return bad(
                "caustic_theta1, caustic_theta2: expected 0 < θ1 < θ2 ≤ 1 radian",
                format!("{}, {}", self.caustic_theta1, self.caustic_theta2),
            );
        }
        Ok(())
    }

    /// The parameters as result-row pairs.
    pub fn describe(&self) -> Vec<(&'static str, String)> {
        let p = &self.proposals;
        let mut proposals = format!(
            "up={} bd={} pm={} cp={} lp={} ls={}",
            p.up, p.bd, p.pm, p.cp, p.lp, p.ls
        );
        // Only when used, so that the rows of every mix without it read as before.
        if p.mc > 0.0 {
            proposals += &format!(" mc={}", p.mc);
        }
        vec![
            ("proposals", proposals),
            ("max_depth", self.max_depth.to_string()),
            ("b_samples", self.b_samples().to_string()),
            ("chains", self.chains.to_string()),
            ("pm_gamma_deg", self.pm_gamma_deg.to_string()),
            ("lens_r1_px", self.lens_r1_px.to_string()),
            ("lens_r2_fraction", self.lens_r2_fraction.to_string()),
            ("caustic_theta1", self.caustic_theta1.to_string()),
            ("caustic_theta2", self.caustic_theta2.to_string()),
        ]
    }
}
