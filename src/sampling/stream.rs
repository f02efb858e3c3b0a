//! Stream purposes: the first task coordinate of [`super::Rng::for_task`], so that different
//! uses of one experiment seed never share random numbers. Every purpose of the crate is
//! listed here, in one place, so that a new one cannot collide with an old one unnoticed
//! (the test below checks that they are distinct).

/// Camera path of pixel p, sample s: `[CAMERA_PATH, p, s]`.
pub const CAMERA_PATH: u64 = 1;
/// Photon path i of photon tracing: `[PHOTON_PATH, i, 0]` ([`crate::photon::trace_photons`]).
pub const PHOTON_PATH: u64 = 2;
/// Path-tracing sample i of the B_eye estimate: `[B_EYE, i, 0]` ([`crate::metropolis`]).
pub const B_EYE: u64 = 3;
/// First state of Metropolis chain c: `[CHAIN_START, c, 0]`.
pub const CHAIN_START: u64 = 4;
/// Mutations of chain c in block b: `[CHAIN, c, b]`.
pub const CHAIN: u64 = 5;
/// Importon path i of `mps`'s importance normalisation: `[IMPORTON, i, 0]`.
pub const IMPORTON: u64 = 6;
/// Area probes of the importon density estimates of Metropolis chain c: `[IMPORTON_PROBE, c, 0]`.
pub const IMPORTON_PROBE: u64 = 7;
/// The irradiance cache's overture at pixel p: `[IRRADIANCE_CACHE, p, 0]` (`photon_map`).
pub const IRRADIANCE_CACHE: u64 = 0x1CAC_4E00;
/// Camera rays through delta surfaces of Christensen's Fig. 1 images at pixel p:
/// `[FIGURE, p, 0]` (`photon_map`'s figures).
pub const FIGURE: u64 = 0x1CF1_6000;
/// Probe i of `bench map-error`: `[MAP_PROBE, i, 0]` ([`crate::experiment::map_error`]).
pub const MAP_PROBE: u64 = 0x9_A0BE;
/// Light path i of sample s of `light`: `[LIGHT_PATH, s, i]`.
pub const LIGHT_PATH: u64 = 8;
/// Pixel sample (eye and light sub-path) of pixel p, sample s of `bdpt`: `[BDPT, p, s]`.
pub const BDPT: u64 = 9;
/// Eye path of pixel p in pass s of `sppm`, or hit point j of pixel p of `ppm`:
/// `[PPM_EYE, p, s or j]`.
pub const PPM_EYE: u64 = 10;
/// Direct light of estimate slot i in pass s of `ppm` / `sppm`: `[PPM_DIRECT, i, s]`.
pub const PPM_DIRECT: u64 = 11;
/// Photon path i of pass s of `ppm` / `sppm`: `[PPM_PHOTON, i, s]`.
pub const PPM_PHOTON: u64 = 12;
/// Light sub-path j of pass s of `vcm`: `[VCM_LIGHT, s, j]`.
pub const VCM_LIGHT: u64 = 13;
/// Eye sub-path of pixel p in pass s of `vcm`: `[VCM_EYE, p, s]`.
pub const VCM_EYE: u64 = 14;
/// Training sample i (counted over all iterations) of pixel p of `ppg`: `[PPG_TRAIN, p, i]`.
pub const PPG_TRAIN: u64 = 15;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stream_purposes_are_distinct() {
        let all = [
            CAMERA_PATH,
            PHOTON_PATH,
            B_EYE,
            CHAIN_START,
            CHAIN,
            IMPORTON,
            IMPORTON_PROBE,
            IRRADIANCE_CACHE,
            FIGURE,
            MAP_PROBE,
            LIGHT_PATH,
            BDPT,
            PPM_EYE,
            PPM_DIRECT,
            PPM_PHOTON,
            VCM_LIGHT,
            VCM_EYE,
            PPG_TRAIN,
        ];
        let mut sorted = all.to_vec();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), all.len());
    }
}
