//! Reflectance models. Each model lives in its own file and works in a local shading frame
//! whose +z axis is the surface normal; `wo` (toward the viewer / previous vertex) and `wi`
//! (toward the light / next vertex) both point away from the surface.
//!
//! Conventions shared by every model:
//! - `eval` returns f_s(wo, wi) without the cosine factor; delta lobes return 0.
//! - `pdf` is the solid-angle density of `sample` for non-delta lobes; delta lobes give 0.
//! - `sample` returns f_s and pdf of the sampled direction (for delta lobes, f_s/pdf is the
//!   weight of the discrete choice times the lobe's value divided by |cos θi|, and pdf is the
//!   probability of the discrete choice, with `delta = true`).

mod lambertian;

pub use lambertian::Lambertian;

use glam::{Vec2, Vec3};

/// Whether a path carries radiance (from the camera) or importance (from the lights).
/// Refraction scales radiance by 1/η² but not importance [Veach 1997, §5.2].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportMode {
    Radiance,
    Importance,
}

/// Classification of a surface for the photon-mapping path grammar (L, D, S, E).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SurfaceKind {
    /// Has a diffuse component: photons are stored here.
    Diffuse,
    /// Glossy but no diffuse component.
    Glossy,
    /// Only delta lobes (mirror, smooth dielectric).
    Specular,
}

/// A sampled direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    /// f_s(wo, wi), without the cosine.
    pub f: Vec3,
    /// Solid-angle pdf, or the discrete probability of a delta lobe.
    pub pdf_w: f32,
    pub delta: bool,
}

/// A reflectance model.
#[derive(Clone, Debug, PartialEq)]
pub enum Bsdf {
    Lambertian(Lambertian),
}

impl Bsdf {
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        let _ = mode;
        match self {
            Bsdf::Lambertian(b) => b.eval(wo, wi),
        }
    }

    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Bsdf::Lambertian(b) => b.pdf(wo, wi),
        }
    }

    /// Samples `wi` given `wo`; `u` drives the direction and `u_lobe` the choice among lobes.
    #[inline]
    pub fn sample(&self, wo: Vec3, u: Vec2, u_lobe: f32, mode: TransportMode) -> Option<BsdfSample> {
        let _ = (u_lobe, mode);
        match self {
            Bsdf::Lambertian(b) => b.sample(wo, u),
        }
    }

    pub fn kind(&self) -> SurfaceKind {
        match self {
            Bsdf::Lambertian(_) => SurfaceKind::Diffuse,
        }
    }

    /// True when the model scatters light to the side opposite `wo` (transmission).
    pub fn is_transmissive(&self) -> bool {
        match self {
            Bsdf::Lambertian(_) => false,
        }
    }

    /// True when every lobe is a delta distribution (no light sampling is useful here).
    pub fn is_delta(&self) -> bool {
        self.kind() == SurfaceKind::Specular
    }
}
