//! The materials of the scene format (`[materials.NAME]`) and the colours, textures and
//! numbers their parameters take; the format itself is documented in [`super`].

use super::{Fixed, Triple};
use serde::Deserialize;

fn white() -> Triple {
    Fixed([1.0, 1.0, 1.0])
}

/// A material; `type` selects the variant.
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum MaterialDesc {
    Diffuse(Diffuse),
    Mirror(Mirror),
    Dielectric(Dielectric),
    Phong(Phong),
    Ward(Ward),
    DiffuseTransmission(DiffuseTransmission),
    ThinDielectric(ThinDielectric),
    Conductor(Conductor),
    RoughConductor(RoughConductor),
    RoughDielectric(RoughDielectric),
    RoughPlastic(RoughPlastic),
    Plastic(Plastic),
    Pplastic(Pplastic),
    OneSided(OneSided),
    Mask(Mask),
    NormalMap(NormalMap),
    BumpMap(BumpMap),
    Blend(Blend),
    Coated(Coated),
    Principled(Principled),
    PrincipledThin(PrincipledThin),
    Null(Null),
}

/// Mitsuba's `null`: a surface every ray passes unchanged, which only marks the boundary of a
/// participating medium (its `interior` / `exterior`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Null {}

/// A diffuse base under a smooth dielectric coating (Mitsuba's `plastic`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plastic {
    /// Default 0.5.
    pub diffuse_reflectance: Option<Color>,
    pub specular_reflectance: Option<Triple>,
    /// Relative index of the coating; default 1.49 (polypropylene), Mitsuba's default.
    pub ior: Option<f64>,
    pub nonlinear: Option<bool>,
}

/// A reflecting material that is black seen from behind, as Mitsuba 3's BSDFs are without their
/// `twosided` wrapper (ours reflect on both sides otherwise).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OneSided {
    /// Any reflecting material (not a dielectric, a sheet or diffuse transmission).
    pub bsdf: Box<MaterialDesc>,
}

/// Mitsuba's `mask`: the material scatters light with probability `opacity` (α) and lets it
/// pass straight through otherwise ([`crate::scene::Scene::passes_through`]).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mask {
    /// α in [0, 1] (1 opaque): a number, or a texture whose luminance is α (default 0.5, as
    /// Mitsuba).
    pub opacity: Option<ScalarDesc>,
    /// Any material but another mask.
    pub bsdf: Box<MaterialDesc>,
}

/// Mitsuba's `normalmap`: the nested material seen through a shading frame tilted per point.
/// The colour c at a hit (a texture read `raw`, as normal maps are stored) is the tangent-space
/// normal 2c − 1 in the hit's own shading frame (tangent along ∂p/∂u); the new frame's normal is
/// that vector normalised and its tangent ∂p/∂u made orthogonal to it
/// ([`crate::scene::Scene::surface_hit`]).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NormalMap {
    /// A texture, or one RGB triple for the whole surface; components in [0, 1].
    pub normals: Color,
    /// Any material but a mask, a bump map or another normal map (a mask goes around it).
    pub bsdf: Box<MaterialDesc>,
}

/// Mitsuba's `bumpmap`: the surface displaced along its normal by `scale` × a height h(u, v),
/// the nested material shaded with the displaced surface's normal.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BumpMap {
    /// The height: a texture whose luminance is h (a number is a flat map).
    pub height: ScalarDesc,
    /// Multiplies the height (default 1, as Mitsuba).
    pub scale: Option<f64>,
    /// Any material but a mask, a normal map or another bump map.
    pub bsdf: Box<MaterialDesc>,
}

/// Mitsuba's `blendbsdf`: (1 − w) × the first material + w × the second.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Blend {
    /// w in [0, 1]: a number, or a texture whose luminance is w (default 0.5, as Mitsuba).
    pub weight: Option<ScalarDesc>,
    /// Exactly two materials without textures (reflecting or transmitting, not masks).
    pub bsdfs: Vec<MaterialDesc>,
}

/// A number parameter that may be a texture instead (its luminance).
#[derive(Clone, Debug, PartialEq)]
pub enum ScalarDesc {
    Value(f64),
    Texture(Box<TextureDesc>),
}

/// Lambertian reflection.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Diffuse {
    pub reflectance: Color,
}

/// A colour parameter: an RGB triple, or a texture table.
#[derive(Clone, Debug, PartialEq)]
pub enum Color {
    Rgb(Triple),
    Texture(Box<TextureDesc>),
}

impl From<Triple> for Color {
    fn from(v: Triple) -> Self {
        Color::Rgb(v)
    }
}

/// A texture (Mitsuba 3's `checkerboard`, `bitmap` and `mesh_attribute`); `type` selects the
/// variant.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum TextureDesc {
    Checkerboard(CheckerboardDesc),
    Bitmap(BitmapDesc),
    MeshAttribute(MeshAttributeDesc),
}

/// A value the mesh carries (Mitsuba 3's `mesh_attribute`): `vertex_NAME` interpolated over
/// each triangle or `face_NAME` constant over it, from a PLY file's properties (`r`, `g`, `b`
/// or `NAME_0`, `NAME_1`, … of its `vertex` or `face` element) or a `.serialized` file's
/// vertex colours. Drives colour parameters only; every shape of the material must carry it.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshAttributeDesc {
    /// `vertex_…` or `face_…`.
    pub name: String,
    /// Multiplies the value (default 1).
    pub scale: Option<f64>,
}

/// Two colours in a checker pattern with cells ½ × ½ in (u, v) (after `to_uv`).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckerboardDesc {
    /// Default 0.4 (Mitsuba's).
    pub color0: Option<Triple>,
    /// Default 0.2.
    pub color1: Option<Triple>,
    pub to_uv: Option<UvTransformDesc>,
}

/// An image file: PNG, JPEG (sRGB) or OpenEXR (linear).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BitmapDesc {
    /// Relative to the directory of the scene file.
    pub file: String,
    /// "bilinear" (default) or "nearest".
    pub filter: Option<String>,
    /// "repeat" (default), "mirror" or "clamp".
    pub wrap: Option<String>,
    /// Use 8-bit values as they are instead of decoding sRGB (default false).
    pub raw: Option<bool>,
    /// Multiplies every texel (default 1; pbrt-v4's `scale` of an `imagemap` and its `scale`
    /// texture). Mitsuba 3's bitmap has no such factor: a scaled bitmap is not exported.
    pub scale: Option<f64>,
    pub to_uv: Option<UvTransformDesc>,
}

/// An affine map of texture coordinates: `scale` then `offset`, or a `matrix` alone (2 rows of
/// 3: (u', v') = M (u, v) + t with t the last column).
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UvTransformDesc {
    pub scale: Option<Fixed<f64, 2>>,
    pub offset: Option<Fixed<f64, 2>>,
    pub matrix: Option<Fixed<Fixed<f64, 3>, 2>>,
}

/// Ideal specular reflection.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mirror {
    #[serde(default = "white")]
    pub reflectance: Triple,
}

/// A smooth dielectric interface (glass).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Dielectric {
    /// Relative index of refraction (inside over outside).
    pub ior: f64,
}

/// A thin dielectric sheet (Mitsuba's `thindielectric`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThinDielectric {
    /// Index of refraction of the sheet relative to its surroundings.
    pub ior: f64,
    #[serde(default = "white")]
    pub reflectance: Triple,
    #[serde(default = "white")]
    pub transmittance: Triple,
}

/// The microfacet distribution of a rough model, with Mitsuba 3's parameter names and
/// defaults: Beckmann, α = 0.1, visible-normal sampling.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Roughness {
    /// "beckmann" (default) or "ggx".
    pub distribution: Option<String>,
    /// Isotropic roughness (default 0.1); or both of `alpha_u`, `alpha_v`. Each a number or
    /// (rough conductors and dielectrics, as in Mitsuba) a texture.
    pub alpha: Option<ScalarDesc>,
    pub alpha_u: Option<ScalarDesc>,
    pub alpha_v: Option<ScalarDesc>,
    pub sample_visible: Option<bool>,
    /// "separable" (default, Mitsuba's G1 G1) or "height_correlated" (pbrt-v4's).
    pub masking: Option<String>,
    /// pbrt-v4's `remaproughness` for roughness textures: a texture's value r at a hit is the
    /// roughness α = √r (default false: the value is α).
    pub remap_roughness: Option<bool>,
}

/// The fields of [`Roughness`], one by one in each rough material (`deny_unknown_fields` does
/// not combine with `flatten`).
macro_rules! rough_material {
    ($(#[$doc:meta])* $name:ident { $($(#[$fdoc:meta])* pub $field:ident: $ty:ty,)* }) => {
        $(#[$doc])*
        #[derive(Clone, Debug, Deserialize)]
        #[serde(deny_unknown_fields)]
        pub struct $name {
            $($(#[$fdoc])* pub $field: $ty,)*
            pub distribution: Option<String>,
            pub alpha: Option<ScalarDesc>,
            pub alpha_u: Option<ScalarDesc>,
            pub alpha_v: Option<ScalarDesc>,
            pub sample_visible: Option<bool>,
            pub masking: Option<String>,
            pub remap_roughness: Option<bool>,
        }

        impl $name {
            pub fn roughness(&self) -> Roughness {
                Roughness {
                    distribution: self.distribution.clone(),
                    alpha: self.alpha.clone(),
                    alpha_u: self.alpha_u.clone(),
                    alpha_v: self.alpha_v.clone(),
                    sample_visible: self.sample_visible,
                    masking: self.masking.clone(),
                    remap_roughness: self.remap_roughness,
                }
            }
        }
    };
}

/// A smooth conductor (Mitsuba's `conductor`): a named metal, or η and k (default η = 0,
/// k = 1: a perfect mirror).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Conductor {
    /// One of Mitsuba's named conductors ("Au", "Cu", …; `bench` lists them on a wrong name).
    pub material: Option<String>,
    pub eta: Option<Triple>,
    pub k: Option<Triple>,
    pub specular_reflectance: Option<Triple>,
}

rough_material! {
    /// A rough conductor (Mitsuba's `roughconductor`).
    RoughConductor {
        pub material: Option<String>,
        pub eta: Option<Triple>,
        pub k: Option<Triple>,
        pub specular_reflectance: Option<Triple>,
    }
}

rough_material! {
    /// A rough dielectric (Mitsuba's `roughdielectric`).
    RoughDielectric {
        /// Relative index of refraction (inside over outside), > 0 and ≠ 1.
        pub ior: f64,
        pub specular_reflectance: Option<Triple>,
        pub specular_transmittance: Option<Triple>,
    }
}

rough_material! {
    /// A diffuse base under a rough dielectric coating (Mitsuba's `roughplastic`).
    RoughPlastic {
        /// Default 0.5.
        pub diffuse_reflectance: Option<Color>,
        pub specular_reflectance: Option<Triple>,
        /// Relative index of the coating; default 1.49 (polypropylene), Mitsuba's default.
        pub ior: Option<f64>,
        pub nonlinear: Option<bool>,
    }
}

rough_material! {
    /// Mitsuba's `pplastic` (unpolarised): a rough specular lobe plus a diffuse lobe attenuated
    /// by two refractions ([`crate::bsdf::Pplastic`]).
    Pplastic {
        /// Default 0.5.
        pub diffuse_reflectance: Option<Color>,
        pub specular_reflectance: Option<Triple>,
        /// Relative index of the interface; default 1.49 (polypropylene), Mitsuba's default.
        pub ior: Option<f64>,
    }
}

rough_material! {
    /// pbrt-v4's layered `coateddiffuse` / `coatedconductor` ([`crate::bsdf::Coated`]): a
    /// dielectric coating over a `diffuse`, `conductor` or `rough_conductor` base, evaluated by
    /// random walks. The coating is smooth unless `alpha` (or `alpha_u` and `alpha_v`, numbers)
    /// is given; its `distribution` defaults to "ggx" (pbrt's Trowbridge–Reitz).
    Coated {
        /// The base: a `diffuse`, `conductor` or `rough_conductor` material (colour textures
        /// allowed), a conductor's η and k relative to the coating.
        pub base: Box<MaterialDesc>,
        /// Relative index of the coating over the outside; default 1.5 (pbrt's).
        pub ior: Option<f64>,
        /// Optical depth of the slab between coating and base; default 0.01 (pbrt's).
        pub thickness: Option<f64>,
        /// Single-scattering albedo of the slab; default 0 (a clear slab).
        pub albedo: Option<Triple>,
        /// Henyey–Greenstein asymmetry of the slab; default 0.
        pub g: Option<f64>,
        /// Largest number of events of a walk; default 10.
        pub max_depth: Option<u32>,
        /// Walks per evaluation; default 1.
        pub samples: Option<u32>,
        /// "exact" (default) or "pbrt": pbrt-v4's connection weights, which are biased under a
        /// rough coating ([`crate::bsdf::Coated`]).
        pub weights: Option<String>,
    }
}

impl RoughConductor {
    /// The conductor part of the description.
    pub fn conductor(&self) -> Conductor {
        Conductor {
            material: self.material.clone(),
            eta: self.eta,
            k: self.k,
            specular_reflectance: self.specular_reflectance,
        }
    }
}

/// Disney's principled model as Mitsuba 3's `principled` ([`crate::bsdf::Principled`]). Every
/// weight is a number in [0, 1] or a texture (its luminance); defaults as Mitsuba's.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Principled {
    /// Default 0.5.
    pub base_color: Option<Color>,
    /// Default 0.5.
    pub roughness: Option<ScalarDesc>,
    pub anisotropic: Option<ScalarDesc>,
    pub metallic: Option<ScalarDesc>,
    pub spec_trans: Option<ScalarDesc>,
    pub spec_tint: Option<ScalarDesc>,
    pub sheen: Option<ScalarDesc>,
    pub sheen_tint: Option<ScalarDesc>,
    pub flatness: Option<ScalarDesc>,
    pub clearcoat: Option<ScalarDesc>,
    pub clearcoat_gloss: Option<ScalarDesc>,
    /// Schlick reflectance at normal incidence, 0.08 × specular (default 0.5); or `eta`.
    pub specular: Option<f64>,
    /// The dielectric part's relative index of refraction, instead of `specular`.
    pub eta: Option<f64>,
    pub diffuse_reflectance_sampling_rate: Option<f64>,
    pub main_specular_sampling_rate: Option<f64>,
    pub clearcoat_sampling_rate: Option<f64>,
    /// Mitsuba's `twosided` around it: the back side mirrors the front (default false, black
    /// from behind unless it transmits); refused with `spec_trans`.
    pub two_sided: Option<bool>,
}

/// Disney's thin-sheet principled model as Mitsuba 3's `principledthin`
/// ([`crate::bsdf::PrincipledThin`]): symmetric between its sides.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PrincipledThin {
    /// Default 0.5.
    pub base_color: Option<Color>,
    /// Default 0.5.
    pub roughness: Option<ScalarDesc>,
    pub anisotropic: Option<ScalarDesc>,
    pub spec_trans: Option<ScalarDesc>,
    /// Diffuse transmission in [0, 2] (Burley's range).
    pub diff_trans: Option<ScalarDesc>,
    pub spec_tint: Option<ScalarDesc>,
    pub sheen: Option<ScalarDesc>,
    pub sheen_tint: Option<ScalarDesc>,
    pub flatness: Option<ScalarDesc>,
    /// The sheet's relative index of refraction; default 1.5.
    pub eta: Option<f64>,
    pub specular_reflectance_sampling_rate: Option<f64>,
    pub specular_transmittance_sampling_rate: Option<f64>,
    pub diffuse_reflectance_sampling_rate: Option<f64>,
    pub diffuse_transmittance_sampling_rate: Option<f64>,
}

/// Energy-conserving modified Phong.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Phong {
    pub diffuse: Triple,
    pub specular: Triple,
    pub exponent: f64,
}

/// Anisotropic Ward.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ward {
    pub diffuse: Triple,
    pub specular: Triple,
    pub alpha_x: f64,
    pub alpha_y: f64,
}

/// Lambertian reflection and Lambertian transmission.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiffuseTransmission {
    pub reflectance: Triple,
    pub transmittance: Triple,
}
