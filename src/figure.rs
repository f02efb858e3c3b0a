//! A strategy's diagnostic figures and the names of their files: what a run writes beside a
//! cell's renders (`<cell><suffix>`) and the reports link. Below both the strategies that draw
//! them and the reports that list them, so neither depends on the other.
//!
//! - Photon distribution images [Fan et al. 2005, Fig. 2; Christensen 1999, Fig. 1a]: where a
//!   strategy's global-map photons lie, as the camera sees them ([`crate::photon::picture`]);
//!   counts on a log scale (viridis, black for no photon), so standard photon mapping's photons
//!   spread over everything the lights reach while Metropolis photon sampling's gather where
//!   the final gather looks.
//! - Christensen 1999, Fig. 1 (b)–(e), in linear RGB on the renders' radiance scale, written as
//!   sRGB previews like the renders.

use crate::error::Result;
use crate::film::{Image, write_png, write_rgb8_png};
use std::path::Path;

/// Suffix of a cell's photon distribution image (Fig. 1a).
pub const PHOTONS_PNG: &str = "_photons.png";
/// Suffix of the irradiance estimated at the image points (Fig. 1b).
pub const IRRADIANCE_PNG: &str = "_fig1b_irradiance.png";
/// Suffix of the precomputed irradiance at the photons (Fig. 1c, 1d).
pub const PRECOMPUTED_PNG: &str = "_fig1cd_precomputed.png";
/// Suffix of the radiance the final gather reads (Fig. 1e).
pub const GATHER_SEES_PNG: &str = "_fig1e_gather_sees.png";

/// Every figure a cell may write, with its caption, in the paper's order.
pub const FIGURES: [(&str, &str); 4] = [
    (
        PHOTONS_PNG,
        "(a) global photon map: visible photons per pixel, log scale (viridis)",
    ),
    (
        IRRADIANCE_PNG,
        "(b) irradiance estimated from the global map at each pixel's first diffuse hit, shown as E/π",
    ),
    (
        PRECOMPUTED_PNG,
        "(c, d) precomputed irradiance at the photons that hold it, as the camera sees them, shown as E/π",
    ),
    (
        GATHER_SEES_PNG,
        "(e) what final-gather rays read at each pixel's first diffuse hit (ρ/π · E, or the map's radiance estimate)",
    ),
];

/// A diagnostic image of a strategy ([`crate::strategy::Strategy::figures`]): the file name
/// suffix (one of [`FIGURES`]) and the image.
pub struct Figure {
    pub suffix: &'static str,
    pub image: FigureImage,
}

/// What a figure's pixels hold.
pub enum FigureImage {
    /// Linear RGB on the renders' radiance scale: written like a render's preview (clamped to
    /// 1, sRGB).
    Radiance(Image),
    /// Colours for display already (a colormap), 8-bit sRGB.
    Display(image::RgbImage),
}

impl Figure {
    /// The radiance image, for figures that hold one.
    pub fn radiance(&self) -> Option<&Image> {
        match &self.image {
            FigureImage::Radiance(image) => Some(image),
            FigureImage::Display(_) => None,
        }
    }

    /// Writes the figure as a PNG, atomically.
    pub fn write_png(&self, path: &Path) -> Result<()> {
        match &self.image {
            FigureImage::Radiance(image) => write_png(image, path, 0.0),
            FigureImage::Display(rgb) => write_rgb8_png(rgb, path),
        }
    }
}
