//! The shapes of the scene format (`[[shapes]]`): their types mirror the file one to one, as
//! the rest of [`super`]; the format itself is documented there.

use super::{Fixed, TransformDesc, Triple};
use serde::Deserialize;

/// A shape; `type` selects the variant.
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ShapeDesc {
    Quad(Quad),
    Box(Cuboid),
    Sphere(Sphere),
    Mesh(Mesh),
    Disk(Disk),
    Cylinder(Cylinder),
    Triangles(Triangles),
    LinearCurve(Curves),
    BsplineCurve(Curves),
}

impl ShapeDesc {
    /// The shape's media (interior, exterior), whatever its kind.
    pub fn media(&self) -> (Option<&str>, Option<&str>) {
        let (i, e) = match self {
            ShapeDesc::Quad(s) => (&s.interior, &s.exterior),
            ShapeDesc::Box(s) => (&s.interior, &s.exterior),
            ShapeDesc::Sphere(s) => (&s.interior, &s.exterior),
            ShapeDesc::Mesh(s) => (&s.interior, &s.exterior),
            ShapeDesc::Disk(s) => (&s.interior, &s.exterior),
            ShapeDesc::Cylinder(s) => (&s.interior, &s.exterior),
            ShapeDesc::Triangles(s) => (&s.interior, &s.exterior),
            ShapeDesc::LinearCurve(s) | ShapeDesc::BsplineCurve(s) => (&s.interior, &s.exterior),
        };
        (i.as_deref(), e.as_deref())
    }

    /// Sets the shape's media, whatever its kind.
    pub fn set_media(&mut self, interior: Option<String>, exterior: Option<String>) {
        let (i, e) = match self {
            ShapeDesc::Quad(s) => (&mut s.interior, &mut s.exterior),
            ShapeDesc::Box(s) => (&mut s.interior, &mut s.exterior),
            ShapeDesc::Sphere(s) => (&mut s.interior, &mut s.exterior),
            ShapeDesc::Mesh(s) => (&mut s.interior, &mut s.exterior),
            ShapeDesc::Disk(s) => (&mut s.interior, &mut s.exterior),
            ShapeDesc::Cylinder(s) => (&mut s.interior, &mut s.exterior),
            ShapeDesc::Triangles(s) => (&mut s.interior, &mut s.exterior),
            ShapeDesc::LinearCurve(s) | ShapeDesc::BsplineCurve(s) => (&mut s.interior, &mut s.exterior),
        };
        (*i, *e) = (interior, exterior);
    }

    /// The shape's transform, whatever its kind.
    pub fn transform_mut(&mut self) -> &mut Option<TransformDesc> {
        match self {
            ShapeDesc::Quad(s) => &mut s.transform,
            ShapeDesc::Box(s) => &mut s.transform,
            ShapeDesc::Sphere(s) => &mut s.transform,
            ShapeDesc::Mesh(s) => &mut s.transform,
            ShapeDesc::Disk(s) => &mut s.transform,
            ShapeDesc::Cylinder(s) => &mut s.transform,
            ShapeDesc::Triangles(s) => &mut s.transform,
            ShapeDesc::LinearCurve(s) | ShapeDesc::BsplineCurve(s) => &mut s.transform,
        }
    }
}

/// A triangle mesh given in the file itself (pbrt's `trianglemesh`): `positions`, and
/// `indices` in threes (optional for a single triangle); optional per-vertex `normals` (they
/// decide the front side, as a mesh file's do) and texture coordinates `uv`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Triangles {
    pub material: String,
    /// The media inside and outside the surface: names of `[media]` tables (default: none).
    pub interior: Option<String>,
    pub exterior: Option<String>,
    pub positions: Vec<Triple>,
    pub indices: Option<Vec<i64>>,
    pub normals: Option<Vec<Triple>>,
    pub uv: Option<Vec<Fixed<f64, 2>>>,
    pub transform: Option<TransformDesc>,
    pub emission: Option<EmissionDesc>,
}

/// A parallelogram: `corner`, `edge_u`, `edge_v`, or an axis-aligned rectangle: `center`,
/// `size`, `facing`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Quad {
    pub material: String,
    /// The media inside and outside the surface: names of `[media]` tables (default: none).
    pub interior: Option<String>,
    pub exterior: Option<String>,
    pub corner: Option<Triple>,
    pub edge_u: Option<Triple>,
    pub edge_v: Option<Triple>,
    pub center: Option<Triple>,
    /// Extents along the two in-plane axes, in x, y, z order.
    pub size: Option<Fixed<f64, 2>>,
    /// The axis the front side faces: "+x", "-x", "+y", "-y", "+z" or "-z" (default "+y").
    pub facing: Option<String>,
    /// Cells per edge of the tessellation (default 1: two triangles).
    pub subdivide: Option<i64>,
    pub transform: Option<TransformDesc>,
    pub emission: Option<EmissionDesc>,
}

/// An axis-aligned box (`type = "box"`; named `Cuboid` so as not to shadow `std`'s `Box`):
/// `min`/`max` or `center`/`size`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cuboid {
    pub material: String,
    /// The media inside and outside the surface: names of `[media]` tables (default: none).
    pub interior: Option<String>,
    pub exterior: Option<String>,
    pub min: Option<Triple>,
    pub max: Option<Triple>,
    pub center: Option<Triple>,
    pub size: Option<Triple>,
    /// Cells per edge of each face's tessellation (default 1: two triangles per face).
    pub subdivide: Option<i64>,
    pub transform: Option<TransformDesc>,
    pub emission: Option<EmissionDesc>,
}

/// An analytic sphere.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sphere {
    pub material: String,
    /// The media inside and outside the surface: names of `[media]` tables (default: none).
    pub interior: Option<String>,
    pub exterior: Option<String>,
    pub center: Triple,
    pub radius: f64,
    pub transform: Option<TransformDesc>,
    pub emission: Option<EmissionDesc>,
}

/// A triangle mesh from a Wavefront OBJ file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mesh {
    pub material: String,
    /// The media inside and outside the surface: names of `[media]` tables (default: none).
    pub interior: Option<String>,
    pub exterior: Option<String>,
    /// Relative to the directory of the scene file.
    pub file: String,
    /// Ignore the file's vertex normals and shade with the triangles' own normals (default
    /// false). Mitsuba's `obj` option of the same name.
    #[serde(default)]
    pub face_normals: bool,
    /// For a file without vertex normals: compute smooth ones as Mitsuba 3 does (angle-weighted
    /// face normals) instead of shading flat (default false). The Mitsuba importer sets it
    /// unless the scene asks for `face_normals`.
    #[serde(default)]
    pub smooth_normals: bool,
    /// Which mesh of a Mitsuba `.serialized` file (default 0); other formats refuse it.
    pub shape_index: Option<u32>,
    /// Turn the front side around where the triangles' winding decides it (a file without
    /// vertex normals, or `face_normals`); vertex normals decide by themselves (default false).
    /// pbrt-v4's `ReverseOrientation`.
    #[serde(default)]
    pub reverse_orientation: bool,
    pub transform: Option<TransformDesc>,
    pub emission: Option<EmissionDesc>,
}

/// Mitsuba 3's `disk`: the unit disk x² + y² ≤ 1 in the plane z = 0, front side +z, placed by
/// `transform` (which may scale it into an ellipse). Loaded as triangles (the loader's `curved`
/// module says how finely, and why).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Disk {
    pub material: String,
    /// The media inside and outside the surface: names of `[media]` tables (default: none).
    pub interior: Option<String>,
    pub exterior: Option<String>,
    /// Turn the front side to −z (default false), as Mitsuba's `flip_normals`.
    #[serde(default)]
    pub flip_normals: bool,
    pub transform: Option<TransformDesc>,
    pub emission: Option<EmissionDesc>,
}

/// Mitsuba 3's `linearcurve` (`linear_curve`: round tubes through the control points, a sphere
/// at each and the cone touching each consecutive pair) and `bsplinecurve` (`bspline_curve`:
/// open tubes whose circular cross-section, in the plane normal to a uniform cubic B-spline,
/// has the B-spline of the radii; four control points per segment), read from a text `file`
/// (per line x y z radius, an empty line between curves). `transform` moves the points, not
/// the radii. Loaded as triangles ([`crate::scene::load`], `curves.rs`); not emitters.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Curves {
    pub material: String,
    /// The media inside and outside the surface: names of `[media]` tables (default: none).
    pub interior: Option<String>,
    pub exterior: Option<String>,
    /// Relative to the directory of the scene file.
    pub file: String,
    pub transform: Option<TransformDesc>,
}

/// Mitsuba 3's `cylinder`: an open tube (no caps) of `radius` around the segment `p0`–`p1`,
/// front side outward, then `transform`. Loaded as triangles, as [`Disk`].
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cylinder {
    pub material: String,
    /// The media inside and outside the surface: names of `[media]` tables (default: none).
    pub interior: Option<String>,
    pub exterior: Option<String>,
    /// Start of the axis (default [0, 0, 0]).
    pub p0: Option<Triple>,
    /// End of the axis (default [0, 0, 1]); must differ from `p0`.
    pub p1: Option<Triple>,
    /// Default 1; must be positive.
    pub radius: Option<f64>,
    /// Turn the front side inward (default false), as Mitsuba's `flip_normals`.
    #[serde(default)]
    pub flip_normals: bool,
    pub transform: Option<TransformDesc>,
    pub emission: Option<EmissionDesc>,
}

impl ShapeDesc {
    /// The type name as written in the file.
    pub fn type_name(&self) -> &'static str {
        match self {
            ShapeDesc::Quad(_) => "quad",
            ShapeDesc::Box(_) => "box",
            ShapeDesc::Sphere(_) => "sphere",
            ShapeDesc::Mesh(_) => "mesh",
            ShapeDesc::Disk(_) => "disk",
            ShapeDesc::Cylinder(_) => "cylinder",
            ShapeDesc::Triangles(_) => "triangles",
            ShapeDesc::LinearCurve(_) => "linear_curve",
            ShapeDesc::BsplineCurve(_) => "bspline_curve",
        }
    }

    /// The keys every shape has: material, transform, emission.
    pub fn common(&self) -> (&str, Option<&TransformDesc>, Option<&EmissionDesc>) {
        match self {
            ShapeDesc::Quad(s) => (&s.material, s.transform.as_ref(), s.emission.as_ref()),
            ShapeDesc::Box(s) => (&s.material, s.transform.as_ref(), s.emission.as_ref()),
            ShapeDesc::Sphere(s) => (&s.material, s.transform.as_ref(), s.emission.as_ref()),
            ShapeDesc::Mesh(s) => (&s.material, s.transform.as_ref(), s.emission.as_ref()),
            ShapeDesc::Disk(s) => (&s.material, s.transform.as_ref(), s.emission.as_ref()),
            ShapeDesc::Cylinder(s) => (&s.material, s.transform.as_ref(), s.emission.as_ref()),
            ShapeDesc::Triangles(s) => (&s.material, s.transform.as_ref(), s.emission.as_ref()),
            ShapeDesc::LinearCurve(s) | ShapeDesc::BsplineCurve(s) => (&s.material, s.transform.as_ref(), None),
        }
    }
}

/// Makes a shape an area light.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EmissionDesc {
    /// Emitted radiance, each channel >= 0.
    pub radiance: Triple,
    /// Emit from the back side too (default: front side only).
    #[serde(default)]
    pub two_sided: bool,
}
