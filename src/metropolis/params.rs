//! The chain's parameters, shared by `mlt` and `mps`: the proposal mix of Fan et al. 2005,
//! eq. (5), path length, B_eye samples, chain count and perturbation sizes.

use crate::error::Result;
use crate::params::{Range, Spec, Value};
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

/// A proposal mix is one parameter: one column `up=… bd=… …` in result rows (`mc` only when
/// used, so that the rows of every mix without it read as before), an inline table in TOML.
impl Value for ProposalMix {
    fn kind() -> String {
        "table".to_string()
    }

    fn check_value(&self, name: &str, _: Option<&Range>) -> Result<()> {
        self.validate(name)
    }

    fn toml(&self) -> Option<String> {
        let items: Vec<String> = Proposal::ALL
            .iter()
            .map(|&p| format!("{} = {}", p.name(), Value::toml(&self.get(p)).unwrap_or_default()))
            .collect();
        Some(format!("{{ {} }}", items.join(", ")))
    }

    fn text(&self) -> String {
        let p = self;
        let mut text = format!(
            "up={} bd={} pm={} cp={} lp={} ls={}",
            p.up, p.bd, p.pm, p.cp, p.lp, p.ls
        );
        if p.mc > 0.0 {
            text += &format!(" mc={}", p.mc);
        }
        text
    }

    fn nested(name: &str) -> Vec<Spec> {
        let defaults = Self::default();
        Proposal::ALL
            .iter()
            .map(|&p| Spec {
                name: format!("{name}.{}", p.name()),
                kind: "float".to_string(),
                default: Value::toml(&defaults.get(p)),
                range: Some(Range::closed(0.0, 1.0).of("a probability").to_string()),
                doc: p.doc(),
            })
            .collect()
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

    /// What the proposal does, for the docs.
    pub fn doc(self) -> &'static str {
        [
            "P_UP: user-path proposal, new paths through the scene's user paths (needs bd > 0).",
            "P_BD: bidirectional mutation, replaces a sub-path [Fan et al. 2005; Veach 1997, §11.4.2].",
            "P_PM: photon-map perturbation in a cone of half-angle pm_gamma_deg.",
            "P_CP: caustic perturbation [Veach 1997, §11.4.3].",
            "P_LP: lens perturbation [Veach 1997, §11.4.3].",
            "P_LS: lens sub-path mutation (a new eye sub-path).",
            "P_MC: multi-chain perturbation [Veach 1997, §11.4.4], not in Fan et al. 2005.",
        ][self as usize]
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

    fn validate(&self, name: &str) -> Result<()> {
        for p in Proposal::ALL {
            let v = self.get(p);
            if !(v.is_finite() && (0.0..=1.0).contains(&v)) {
                crate::bail!("{name}.{}: expected a probability in [0, 1], got {v}", p.name());
            }
        }
        let sum: f64 = Proposal::ALL.iter().map(|&p| self.get(p)).sum();
        if (sum - 1.0).abs() > 1e-6 {
            crate::bail!(
                "{name}: the probabilities up, bd, pm, cp, lp, ls, mc must sum to 1, got {sum} \
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
                "{name}: up > 0 needs bd > 0 (UP is combined with BD, which gives every path a \
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

crate::declare_params! {
    /// Chain parameters shared by `mlt` and `mps`.
    pub struct MetropolisParams {
        /// Proposal probabilities P_type [Fan et al. 2005, eq. (5)]: a table of the non-zero
        /// ones (missing keys are 0); absent, the paper's Lantern mix ([`ProposalMix`]).
        proposals: ProposalMix = ProposalMix::default();
        /// Maximum scattering events of a path (edges − 1), as `path`'s `max_depth`.
        max_depth: u32 = 16, range Range::int(1, 64);
        /// Path-tracing samples (whole-image eye paths) for B_eye and the chains' first states;
        /// absent: [`B_SAMPLES_PER_CHAIN`] per chain ([`MetropolisParams::b_samples`]).
        b_samples: Option<u64> = None, range Range::int(1, 1_000_000_000);
        /// Independent chains (fixed, so results do not depend on the thread count). **Decision:
        /// many short chains (default 8192).** Every chain starts from a path resampled ∝ f/p, so a
        /// short chain has no start-up bias, and it caps how many iterations a chain stuck in a
        /// state its proposals cannot leave (L S D S E in `box`) piles onto one photon or pixel:
        /// 64 → 8192 chains took MPS on box from rms_rel_lum 0.44 to 0.19 and MLT from 5.8 to 0.90
        /// (docs/reproductions/fan2005.md).
        chains: u32 = 8192, range Range::int(1, 65_536);
        /// PM cone half-angle γ in degrees (paper: 30).
        pm_gamma_deg: f32 = 30.0, range Range::above_to(0.0, 90.0).of("an angle");
        /// LP offsets r ∈ [r1, r2] with density ∝ 1/r: r1 in pixels [Veach 1997, §11.4.3: 0.1 pixel].
        lens_r1_px: f32 = 0.1, range Range::positive().of("a radius");
        /// LP offsets: r2 is the radius of a disc covering this fraction of the image
        /// [Veach 1997, §11.4.3: 10 %].
        lens_r2_fraction: f32 = 0.1, range Range::above_to(0.0, 1.0).of("a fraction");
        /// CP angles θ ∈ [θ1, θ2] radians with density ∝ 1/θ: θ1 [Veach 1997: 0.0001].
        caustic_theta1: f32 = 1e-4, range Range::above_to(0.0, 1.0).of("an angle in radians");
        /// CP angles: θ2 [Veach 1997: 0.1].
        caustic_theta2: f32 = 0.1, range Range::above_to(0.0, 1.0).of("an angle in radians");
    }
    check MetropolisParams::rules;
}

/// Default path-tracing samples per chain for B_eye and the first states. **Decision** (beyond
/// the paper, which runs one chain): the pool grows with the chains. A chain's first state is
/// resampled from the pool ∝ f/p, which is unbiased with the pool's B_eye in expectation, but
/// a pool with few samples per chain starts many chains on the same heavy paths and misses the
/// rare ones: short chains then crowd their photons around those starts, and the k-nearest
/// estimate reads crowds as density. Measured with `bench map-error` on `lantern` (8 seeds,
/// 8192 chains, 500 000 mutations), the interior mean ratio went 1.068 ± 0.014 with 12 samples
/// per chain (the earlier fixed 100 000), 1.015 ± 0.014 with 100, photon mapping's k / (k − 1)
/// (docs/reproductions/fan2005.md, item 10).
pub const B_SAMPLES_PER_CHAIN: u64 = 100;

impl MetropolisParams {
    /// Path-tracing samples for B_eye: `b_samples`, or [`B_SAMPLES_PER_CHAIN`] per chain.
    pub fn b_samples(&self) -> u64 {
        self.b_samples.unwrap_or(B_SAMPLES_PER_CHAIN * u64::from(self.chains))
    }

    /// The rules the ranges cannot express: θ1 < θ2.
    fn rules(&self) -> Result<()> {
        if self.caustic_theta1 >= self.caustic_theta2 {
            crate::bail!(
                "caustic_theta1, caustic_theta2: expected 0 < θ1 < θ2 ≤ 1 radian, got {}, {}",
                self.caustic_theta1,
                self.caustic_theta2
            );
        }
        Ok(())
    }
}
