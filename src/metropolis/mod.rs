//! A Metropolis–Hastings chain over light-to-eye paths with target density p_eye = f_eye / B_eye
//! [Fan et al. 2005, §3–4; Veach 1997, ch. 11], shared by `kind = "mlt"` (paths splat into the
//! image) and `kind = "mps"` (paths store photons).
//!
//! - **B_eye** is estimated by path tracing over the whole image ([`estimate_b`]), with its
//!   standard error.
//! - **X₀** of every chain is resampled from those path-tracing paths ∝ their luminance
//!   contribution f/p (no start-up bias [Veach 1997, §11.3.1]).
//! - Each **step** picks a proposal with its fixed probability and accepts with
//!   a = min(1, f_eye,Y(Y) T(X|Y) / (f_eye,Y(X) T(Y|X))); T is that of the chosen proposal,
//!   except UP and BD, which are combined: T = (P_UP T_UP + P_BD T_BD) / (P_UP + P_BD)
//!   [Fan et al. 2005, eq. (7)].
//!
//! Files: [`params`] (the chain's declared parameters and the proposal mix), [`start`] (B_eye,
//! first states, user paths: the preparation `mlt` and `mps` share), [`chain`] (state, one step,
//! tallies), [`proposals`] (the six proposals of Fan et al. 2005 and Veach's multi-chain
//! perturbation, with their transition densities). What does not live here: what a chain's
//! states become (image splats in `strategy::mlt`, photons in `strategy::mps`).

mod chain;
mod params;
pub mod proposals;
mod start;

pub use chain::*;
pub use params::*;
pub use start::*;
