//! The scene file format: `scenes/*.toml`, read by [`super::load_scene`]. Mitsuba 3 XML files
//! (`scenes/*.xml`) are translated into these same types by [`super::mitsuba`].
//!
//! This module is the reference for the format. Every table rejects keys it does not know, so a
//! misspelled parameter is an error, never a silent default. Lengths are in scene units (the
//! shipped scenes use metres), angles in degrees, colours are linear RGB triples `[r, g, b]`.
//!
//! ```toml
//! name = "cornell-empty"            # optional; defaults to the file stem. Part of file names:
//!                                   # no / or \, no leading dot or space
//!
//! [camera]                          # a pinhole camera
//! eye = [0.278, 0.273, -0.8]
//! look_at = [0.278, 0.273, 0.0]     # must differ from `eye`
//! up = [0, 1, 0]                    # optional, default [0, 1, 0]; not parallel to the view
//! fov_y = 39.3077                   # full vertical field of view, degrees, in (0, 180)
//! resolution = [80, 60]             # width, height: 1..=16384 each, at most 64 Mpixel
//! filter = { type = "gaussian", stddev = 0.5 }   # optional pixel filter: box (default) |
//!                                   # tent (radius in (0, 16], default 1) | gaussian (stddev in
//!                                   # (0, 4], default 0.5; radius 4 stddev): Mitsuba's rfilters,
//!                                   # sampled by filter importance sampling (src/pixel_filter.rs)
//! lens = { type = "thin", aperture_radius = 0.1, focus_distance = 5 }   # optional: pinhole
//!                                   # (default) | thin (Mitsuba's thinlens) | orthographic
//!                                   # (`height`, optional `width` in scene units: the view's
//!                                   # extent; fov_y is then not needed)
//! flip_x = false                    # optional: mirror the image left-right (pbrt's cameras)
//! crop = { offset = [20, 10], size = [40, 30] }  # optional: render only the film's pixels
//!                                   # [x, x + w) × [y, y + h) (offset default [0, 0]); the
//!                                   # field of view stays the full film's
//!
//! # Materials are named tables; `type` picks the reflectance model.
//! [materials.white]
//! type = "diffuse"                  # Lambertian
//! reflectance = [0.73, 0.73, 0.73]  # each channel in [0, 1]
//! [materials.floor]
//! type = "diffuse"                  # a colour may be a texture instead (also rough_plastic's
//! reflectance = { type = "checkerboard", color0 = [0.2, 0.2, 0.2], color1 = [0.4, 0.4, 0.4],
//!                 to_uv = { scale = [8, 8] } }   # diffuse_reflectance); or:
//! # reflectance = { type = "bitmap", file = "textures/wood.png", filter = "bilinear",
//! #                 wrap = "repeat", raw = false, to_uv = { matrix = [[1, 0, 0], [0, 1, 0]] } }
//! # reflectance = { type = "mesh_attribute", name = "vertex_color", scale = 1 }  # a PLY mesh's
//! #                 vertex_NAME / face_NAME values (Mitsuba's mesh_attribute; colours only)
//! [materials.chrome]
//! type = "mirror"                   # ideal specular reflection
//! reflectance = [1, 1, 1]           # optional, default [1, 1, 1]; in [0, 1]
//! [materials.glass]
//! type = "dielectric"               # smooth glass: Fresnel-weighted reflection and refraction
//! ior = 1.5                         # index of refraction inside / outside, > 0
//! [materials.plastic]
//! type = "phong"                    # energy-conserving modified Phong
//! diffuse = [0.4, 0.4, 0.4]         # each in [0, 1] and diffuse + specular <= 1 per channel
//! specular = [0.3, 0.3, 0.3]
//! exponent = 50.0                   # in [0, 1e6]
//! [materials.brushed]
//! type = "ward"                     # anisotropic Ward
//! diffuse = [0.1, 0.1, 0.1]         # as for phong: diffuse + specular <= 1 per channel
//! specular = [0.5, 0.5, 0.5]
//! alpha_x = 0.05                    # roughness along the tangent and bitangent, in (0, 1]
//! alpha_y = 0.2
//! [materials.paper]
//! type = "diffuse_transmission"     # Lambertian reflection plus Lambertian transmission
//! reflectance = [0.5, 0.5, 0.5]     # reflectance + transmittance <= 1 per channel
//! transmittance = [0.3, 0.3, 0.3]
//! [materials.pane]
//! type = "thin_dielectric"          # a thin glass sheet: reflects, passes light straight through
//! ior = 1.5                         # > 0
//! reflectance = [1, 1, 1]           # optional filters, default [1, 1, 1]; in [0, 1]
//! transmittance = [1, 1, 1]
//! [materials.copper]
//! type = "conductor"                # a smooth metal (Mitsuba's `conductor`)
//! material = "Cu"                   # one of Mitsuba's 71 named conductors, or:
//!                                   # eta = [..], k = [..] (defaults 0 and 1: a perfect mirror)
//! specular_reflectance = [1, 1, 1]  # optional tint, default [1, 1, 1]
//! [materials.gold]
//! type = "rough_conductor"          # Mitsuba's `roughconductor`: the fields of `conductor` and
//! material = "Au"
//! distribution = "ggx"              # "beckmann" (default) or "ggx"
//! alpha = 0.2                       # roughness in [0, 10], default 0.1, or a texture (its
//!                                   # luminance; rough conductors and dielectrics); or alpha_u
//!                                   # and alpha_v
//! sample_visible = true             # optional: visible-normal sampling (default) or all normals
//! remap_roughness = false           # optional: pbrt-v4's remaproughness, α = √value (numbers
//!                                   # and textures); not expressible in Mitsuba XML
//! [materials.frosted]
//! type = "rough_dielectric"         # Mitsuba's `roughdielectric`, the distribution as above
//! ior = 1.5                         # inside / outside, > 0 and not 1
//! alpha = 0.1
//! specular_reflectance = [1, 1, 1]  # optional filters, default [1, 1, 1]
//! specular_transmittance = [1, 1, 1]
//! [materials.red_plastic]
//! type = "rough_plastic"            # Mitsuba's `roughplastic`: isotropic (alpha only)
//! diffuse_reflectance = [0.6, 0.08, 0.05]  # default 0.5
//! ior = 1.49                        # coating, default 1.49 (polypropylene)
//! alpha = 0.15
//! nonlinear = false                 # optional, as Mitsuba
//! [materials.shiny]
//! type = "plastic"                  # Mitsuba's smooth `plastic`: a mirror-like coating over a
//! diffuse_reflectance = [0.1, 0.3, 0.6]    # diffuse base (fields as rough_plastic's, no
//! ior = 1.5                         # roughness); rendered by path, ppg, photon_guided and
//!                                   # photon_map (the others refuse it)
//! [materials.satin]
//! type = "pplastic"                 # Mitsuba's `pplastic` (unpolarised): a rough specular lobe
//! diffuse_reflectance = [0.3, 0.2, 0.5]    # plus a diffuse one attenuated by two refractions
//! ior = 1.49                        # (no internal reflection); default 1.49; alpha or
//! distribution = "ggx"              # alpha_u and alpha_v; specular_reflectance as
//! alpha = 0.06                      # rough_plastic's
//! [materials.car_paint]
//! type = "principled"               # Mitsuba's `principled` (Disney's model): base_color
//! base_color = [0.6, 0.05, 0.05]    # (colour or texture, default 0.5), roughness (0.5),
//! metallic = 0.3                    # anisotropic, metallic, spec_trans, spec_tint, sheen,
//! clearcoat = 1.0                   # sheen_tint, flatness, clearcoat, clearcoat_gloss (numbers
//! clearcoat_gloss = 0.9             # in [0, 1] or textures, default 0); specular (0.5) or eta;
//!                                   # the three *_sampling_rate; two_sided (default false:
//!                                   # black from behind unless it transmits)
//! [materials.leaf_sheet]
//! type = "principled_thin"          # Mitsuba's `principledthin`: a sheet, the same from both
//! diff_trans = 1.2                  # sides; diff_trans in [0, 2], eta (default 1.5), the
//! base_color = [0.2, 0.5, 0.1]      # principled weights but metallic and clearcoat, and four
//!                                   # *_sampling_rate
//! [materials.matte_front]
//! type = "one_sided"                # black from behind, as Mitsuba's BSDFs without `twosided`
//! bsdf = { type = "diffuse", reflectance = [0.5, 0.5, 0.5] }   # any reflecting material
//! [materials.leaf]
//! type = "mask"                     # Mitsuba's mask: scatters by `bsdf` with probability
//! opacity = { type = "checkerboard", color0 = [1, 1, 1], color1 = [0.2, 0.2, 0.2] }  # α: a
//! bsdf = { type = "diffuse", reflectance = [0.2, 0.5, 0.1] }  # number in [0, 1] (default
//!                                   # 0.5) or a texture's luminance; passes light straight
//!                                   # through otherwise; not on an emitter
//! [materials.tiles]
//! type = "normal_map"               # Mitsuba's normalmap: colour c is the normal 2c − 1 in
//! normals = { type = "bitmap", file = "textures/tiles_normals.png", raw = true }  # the hit's frame
//! bsdf = { type = "diffuse", reflectance = [0.6, 0.5, 0.4] }  # (tangent ∂p/∂u); a texture or
//!                                   # one RGB triple; any material but a mask (which goes
//!                                   # around the normal map) or another normal map
//! [materials.dimpled]
//! type = "bump_map"                 # Mitsuba's bumpmap: the surface displaced along its
//! height = { type = "bitmap", file = "textures/tiles_normals.png", raw = true }  # normal by
//! scale = 0.02                      # scale (default 1) × the height's luminance; shaded with
//! bsdf = { type = "diffuse", reflectance = [0.6, 0.5, 0.4] }  # the displaced normal
//! [materials.worn_gold]
//! type = "blend"                    # Mitsuba's blendbsdf: (1 − w) × bsdfs[0] + w × bsdfs[1]
//! weight = 0.3                      # w in [0, 1] (default 0.5) or a texture's luminance
//! bsdfs = [{ type = "rough_plastic", diffuse_reflectance = [0, 0, 0], distribution = "ggx", alpha = 0.3 },
//!          { type = "conductor", material = "Au" }]   # two materials without textures
//! [materials.varnish]
//! type = "coated"                   # pbrt-v4's coateddiffuse / coatedconductor: a dielectric
//! base = { type = "diffuse", reflectance = [0.4, 0.2, 0.1] }  # coating (ior, default 1.5)
//! alpha = 0.1                       # over a diffuse, conductor or rough_conductor base; rough
//!                                   # with alpha (GGX), smooth without; thickness (0.01),
//!                                   # albedo (0), g (0), max_depth (10), samples (1),
//!                                   # weights ("exact" or "pbrt"); not in mlt, mps
//!
//! # Shapes; every shape takes `material` (required), `transform` and `emission` (optional).
//! [[shapes]]
//! type = "quad"                     # a parallelogram, two triangles
//! material = "white"
//! corner = [0, 0, 0]                # points corner + s·edge_u + t·edge_v, s, t ∈ [0, 1];
//! edge_u = [0, 0, 0.559]            # the front (normal) side is edge_u × edge_v
//! edge_v = [0.556, 0, 0]
//! [[shapes]]
//! type = "quad"                     # the other form: an axis-aligned rectangle
//! material = "white"
//! center = [0.278, 0.5388, 0.2795]
//! size = [0.13, 0.105]              # in-plane extents in x, y, z order: ±x [y, z], ±y [x, z],
//!                                   # ±z [x, y]; each > 0
//! facing = "+y"                     # normal axis: "+x" "-x" "+y" "-y" "+z" "-z"; default "+y"
//! subdivide = 4                     # optional, default 1: an n × n grid of cells, 2n² triangles
//! emission = { radiance = [17, 12, 4], two_sided = false }   # an area light; two_sided
//!                                   # is optional, default false
//! [[shapes]]
//! type = "box"                      # 12 triangles, faces pointing outward
//! material = "white"
//! min = [-0.5, -0.5, -0.5]          # either min and max (each min < max) ...
//! max = [0.5, 0.5, 0.5]
//! # center = [0, 0, 0]; size = [1, 1, 1]   # ... or center and size (each > 0)
//! transform = { scale = [0.16, 0.33, 0.16], rotate_y = 15.0, translate = [0.37, 0.165, 0.35] }
//! subdivide = 2                     # optional, as for quads: each face n × n cells, 12n² triangles
//! [[shapes]]
//! type = "sphere"
//! material = "glass"
//! center = [0.37, 0.1, 0.18]
//! radius = 0.1                      # > 0; transforms must keep it a sphere (uniform scale)
//! [[shapes]]
//! type = "disk"                     # Mitsuba's disk: radius 1 in the xy plane, front side +z,
//! material = "white"                #   placed by `transform` (a non-uniform scale makes an
//! flip_normals = false              #   ellipse); optional flip_normals: front side −z
//! transform = { scale = 0.05, rotate_x = -90, translate = [0.15, 0.001, 0.4] }
//! [[shapes]]
//! type = "cylinder"                 # Mitsuba's cylinder: an open tube (no caps), front outward
//! material = "white"
//! p0 = [0.45, 0, 0.1]               # the axis from p0 (default [0, 0, 0]) to p1 (default
//! p1 = [0.45, 0.1, 0.1]             #   [0, 0, 1]); p1 != p0
//! radius = 0.05                     # > 0, default 1
//! flip_normals = false              # optional: front side inward
//! [[shapes]]
//! type = "linear_curve"             # Mitsuba's linearcurve (or bspline_curve): tubes through
//! material = "white"                #   control points, a sphere at each, touching cones between
//! file = "meshes/hair.txt"          # per line x y z radius; an empty line starts a new curve
//! [[shapes]]
//! type = "triangles"                # a mesh written here (pbrt's trianglemesh)
//! material = "white"
//! positions = [[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0]]
//! indices = [0, 1, 2]               # in threes, each < the number of positions (optional
//!                                   #   for a single triangle); front side by the winding
//! # normals = [[0, 0, 1], ...]      # optional, one per position: they decide the front side
//! # uv = [[0, 0], [1, 0], [0, 1]]   # optional texture coordinates, one per position
//! [[shapes]]
//! type = "mesh"                     # Wavefront OBJ (triangulated; MTL materials are ignored),
//! material = "white"                #   Stanford PLY or Mitsuba .serialized, by the extension
//! file = "meshes/bunny.obj"         # relative to this scene file
//! face_normals = false              # optional: true ignores the file's vertex normals
//! smooth_normals = false            # optional: true shades a file without normals smooth, as
//!                                   #   Mitsuba (angle-weighted); false shades it flat
//! # shape_index = 0                 # optional, .serialized only: which mesh of the file
//! reverse_orientation = false       # optional: true turns the front where the winding
//!                                   #   decides it (no vertex normals), as pbrt's
//!                                   #   ReverseOrientation; a .gz file is decompressed first
//! transform = [{ matrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]] },
//!              { rotate_x = -90 }, { translate = [0, 0.1, 0] }]
//!
//! # Light from infinitely far away (optional): a constant or an image (latitude–longitude).
//! [environment]
//! type = "envmap"                   # or type = "constant" with radiance = [r, g, b]
//! file = "textures/sky.exr"         # OpenEXR (linear), PNG, JPEG or BMP (sRGB); relative to here
//! scale = 1.0                       # optional, default 1
//! transform = { rotate_y = 90 }     # optional; rotations only
//! mapping = "latlong"               # optional: Mitsuba's latitude–longitude (default), or
//!                                   # "equal_area": pbrt-v4's square octahedral map
//!
//! # Lights that are not shapes (optional, any number): Mitsuba's point, spot and directional.
//! [[lights]]
//! type = "point"
//! position = [0.5, 1.2, 0.5]
//! intensity = [2, 2, 2]             # radiant intensity in W/sr, each channel in [0, 1e10]
//! [[lights]]
//! type = "spot"
//! position = [0.5, 1.2, 0.5]
//! target = [0.5, 0, 0.5]            # a point on the axis, or direction = [0, -1, 0]
//! intensity = [10, 10, 10]          # W/sr on the axis
//! cutoff_angle = 30                 # optional: dark beyond this half-angle (degrees), default 20
//! beam_width = 20                   # optional: full intensity inside it, default 3/4 of the cutoff
//! falloff = "linear"                # optional: Mitsuba's ramp linear in angle (default), or
//!                                   # "smoothstep": pbrt-v4's, smooth in cos θ
//! # texture = { type = "bitmap", file = "slide.png" }  # optional: a picture projected through
//! # up = [0, 0, 1]                  #   the cone (cutoff < 90), and its up (frame x = up × axis)
//! [[lights]]
//! type = "directional"
//! direction = [-0.2, -1, 0.1]       # where the light travels
//! irradiance = [1, 1, 1]            # W/m² on a surface facing the light
//!
//! # User paths for Metropolis photon sampling [Fan et al. 2005, §4.3] (optional).
//! [[user_paths]]
//! points = [[0.278, 0.5388, 0.28], [0.2, 0.2, 0.4], [0.1, 0.0, 0.3]]  # on a light, then surfaces
//! cone_deg = 5.0                    # cone half-angle in (0, 90] degrees: one for every
//!                                   # segment, or a list with one per segment
//! ```
//!
//! **Transforms.** A `transform` is one step or a list of steps applied in list order. Within a
//! step the parts apply in the fixed order `scale` (a number or `[sx, sy, sz]`, non-zero),
//! `rotate_x`, `rotate_y`, `rotate_z` (degrees, right-handed about the world axes), `translate`;
//! a step with `matrix` (4 rows of 4, row-major, acting on column vectors `p' = M p`, last row
//! `[0, 0, 0, 1]`) must hold nothing else. A step list makes rotations about a pivot easy:
//! `[{ translate = [-c] }, { rotate_y = 30 }, { translate = [c] }]`. Transforms that mirror
//! (negative determinant) keep the front side of every quad, box and mesh triangle where it was
//! meant to be; degenerate ones (determinant ≈ 0) are refused.
//!
//! **Disks and cylinders** have Mitsuba 3's parameters and meaning (the unit disk, the tube from
//! `p0` to `p1` with Mitsuba's frame about its axis, then `transform`) and its texture
//! coordinates: (r, φ/2π) on the disk, (φ/2π, t) on the tube, t from 0 at `p0` to 1 at `p1`.
//! They are loaded as triangles with exact per-vertex normals: 512 segments around (area
//! (2π/512)²/6 = 2.5·10⁻⁵ short for the disk, 6.3·10⁻⁶ for the tube), cells at most about 16
//! times longer than wide (a disk is 13 824 triangles, a tube as long as its radius 6 144);
//! `super::load`'s `curved` module has the details and figures. Like a quad, an emitting one
//! is an area light of all its triangles, each emitting from the front side.
//!
//! **Meshes.** Faces are triangulated by tobj; OBJ vertex normals, when every vertex has one,
//! become shading normals. Triangles whose area is zero to f32 precision are skipped and
//! counted ([`super::load::LoadStats`]); a mesh with no triangle left is refused. The MTL files
//! an OBJ names are read only for the content hash: the scene's `material` applies to the
//! whole mesh, and a missing MTL is ignored.
//!
//! **Subdivision.** `subdivide = n` (an integer in 1..=[`super::limits::MAX_SUBDIVIDE`]) splits
//! a quad, or each face of a box, into an n × n grid of equal parallelograms, two triangles
//! each, in a fixed order (row by row from the corner, along `edge_u` first). The surface is
//! the same; only the triangle count grows. Radiosity-era interiors such as Christensen 1999's
//! (1.05 M polygons) owe much of their polygon count to such meshing, and `scenes/interior.toml`
//! uses it to reach a comparable scale for BVH and photon-tracing measurements. The scene's
//! content hash covers the value (it is in the scene file) and a version tag of the
//! tessellation code, so a change to the tessellation invalidates references and cached cells.
//!
//! **Lights.** Any shape with an `emission` is an area light; each of its triangles (or the
//! sphere) emits `radiance` (each channel in [0, 1e10]) from its front side, or from both
//! sides with `two_sided = true`. A scene needs at least one light with positive power.
//!
//! **User paths.** At least two points; the first must lie on an emissive surface (within
//! 1e-3 of the scene's bounding-box diagonal of one).
//!
//! **Materials** get indices in name order, whatever their order in the file; a shape naming
//! an undefined material is an error, an unused material is not.
//!
//! **Limits.** Every coordinate, size and translation must be finite with magnitude <= 1e7, so
//! that f32 geometry keeps a useful precision; the same holds after transforming.
//!
//! **Errors** are one line, `<file>: <field>: <what was expected>, got <value>`, with a line and
//! column when the TOML layer found them; list indices in field paths count from 0
//! (`shapes[0]` is the first `[[shapes]]`).
//!
//! Why two layers: these types mirror the file one to one (f64, as TOML stores numbers, so an
//! error can quote the value as written); `load` validates them and builds the runtime
//! [`super::Scene`].
//!
//! Internally tagged enums ([`MaterialDesc`], [`ShapeDesc`]) carry `deny_unknown_fields` on
//! their inner structs: on the enum itself serde lets unknown keys through (serde issues #2123
//! and #2294).

use serde::Deserialize;

use std::collections::BTreeMap;

/// A point, vector or RGB triple as written in the file.
pub type Triple = Fixed<f64, 3>;

/// An array of exactly `N` values. serde's own arrays stop reading after `N` elements, and
/// the toml deserializer does not complain about the rest, so `[1, 2, 3, 4]` would pass as a
/// point; this type refuses it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fixed<T, const N: usize>(pub [T; N]);

impl<T, const N: usize> std::ops::Deref for Fixed<T, N> {
    type Target = [T; N];
    fn deref(&self) -> &[T; N] {
        &self.0
    }
}

impl<T, const N: usize> From<[T; N]> for Fixed<T, N> {
    fn from(a: [T; N]) -> Self {
        Self(a)
    }
}

/// The whole file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneDesc {
    /// Defaults to the file stem.
    #[serde(default)]
    pub name: Option<String>,
    pub camera: CameraDesc,
    /// Materials by name. A `BTreeMap` gives material indices in name order, independent of
    /// the order in the file.
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialDesc>,
    #[serde(default)]
    pub shapes: Vec<ShapeDesc>,
    #[serde(default)]
    pub user_paths: Vec<UserPathDesc>,
    /// Light from infinitely far away (optional).
    pub environment: Option<EnvironmentDesc>,
    /// Point, spot and directional lights.
    #[serde(default)]
    pub lights: Vec<LightDesc>,
    /// Participating media by name, referenced by shapes' `interior` / `exterior` and the
    /// camera's `medium`.
    #[serde(default)]
    pub media: BTreeMap<String, MediumDesc>,
}

/// A participating medium (`[media.NAME]`); `type` selects the kind (Mitsuba's media of the
/// same names).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum MediumDesc {
    Homogeneous(HomogeneousDesc),
    Heterogeneous(HeterogeneousDesc),
}

/// A medium whose extinction varies in space (Mitsuba's `heterogeneous`): σ_t(x) = `scale` ·
/// the grid's value at x inside the world box of the grid's unit cube, vacuum outside it.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeterogeneousDesc {
    /// The extinction grid (1 or 3 channels, each value >= 0).
    pub sigma_t_grid: GridDesc,
    /// Multiplies the grid (default 1), > 0.
    pub scale: Option<f64>,
    /// As for `homogeneous`.
    pub albedo: Option<Triple>,
    pub albedo_grid: Option<GridDesc>,
    pub phase: Option<PhaseDesc>,
    pub sample_emitters: Option<bool>,
}

/// A medium of constant extinction (Mitsuba's `homogeneous`).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HomogeneousDesc {
    /// σ_t per channel, in inverse scene units, each >= 0 (default [1, 1, 1]).
    pub sigma_t: Option<Triple>,
    /// Multiplies `sigma_t` (default 1), > 0.
    pub scale: Option<f64>,
    /// Single-scattering albedo σ_s / σ_t per channel in [0, 1] (default 0.75, Mitsuba's); or
    /// `albedo_grid`.
    pub albedo: Option<Triple>,
    /// The albedo from a 3-D grid (Mitsuba's `gridvolume`).
    pub albedo_grid: Option<GridDesc>,
    /// The phase function (default isotropic).
    pub phase: Option<PhaseDesc>,
    /// Whether scattering in the medium samples emitters (default true).
    pub sample_emitters: Option<bool>,
}

/// A grid of values over the unit cube, read from a Mitsuba `.vol` file.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridDesc {
    /// Relative to the scene file's directory.
    pub file: String,
    /// "trilinear" (default) or "nearest".
    pub filter: Option<String>,
    /// "clamp" (default), "repeat" or "mirror": outside the unit cube.
    pub wrap: Option<String>,
    /// Maps the unit cube into the world (default: identity).
    pub to_world: Option<TransformDesc>,
    /// Map the file's own bounding box onto the unit cube first (default false).
    pub use_grid_bbox: Option<bool>,
}

/// A phase function; `type` selects it.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum PhaseDesc {
    Isotropic(NoParams),
    /// Henyey–Greenstein with mean cosine `g` in (−1, 1).
    Hg(HgDesc),
}

/// A kind without parameters.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoParams {}

/// Henyey–Greenstein's parameter.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HgDesc {
    pub g: f64,
}

/// A light that is not a shape; `type` selects the variant (Mitsuba's emitters of the same
/// names, with their parameter names).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum LightDesc {
    Point(PointLightDesc),
    Spot(SpotLightDesc),
    Projector(ProjectorLightDesc),
    Directional(DirectionalLightDesc),
}

/// Radiant intensity [W/sr] from a point, the same in every direction.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointLightDesc {
    pub position: Triple,
    pub intensity: Triple,
}

/// A spot: radiant intensity along its axis, falling off from `beam_width` to `cutoff_angle`
/// (half-angles in degrees) as `falloff` says.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpotLightDesc {
    pub position: Triple,
    /// A point on the axis (give this or `direction`).
    pub target: Option<Triple>,
    /// The axis (give this or `target`).
    pub direction: Option<Triple>,
    pub intensity: Triple,
    /// Default 20 degrees, as Mitsuba.
    pub cutoff_angle: Option<f64>,
    /// Default three quarters of the cutoff, as Mitsuba.
    pub beam_width: Option<f64>,
    /// "linear" (default): Mitsuba's ramp, linear in angle; "smoothstep": pbrt-v4's,
    /// smoothstep(cos cutoff, cos beam, cos θ).
    pub falloff: Option<String>,
    /// Mitsuba's `texture`: a picture projected through the cone, multiplying the intensity
    /// (a `bitmap` or `checkerboard`; values finite and non-negative). Direction l in the
    /// spot's frame reads (u, v) = ½ + ½ (l_x / l_z, l_y / l_z) / tan(cutoff).
    pub texture: Option<Box<TextureDesc>>,
    /// The picture's "up": the frame is x = up × axis (normalised), y = axis × x, as Mitsuba's
    /// `lookat` (default +y, or +x when the axis is within 26° of vertical).
    pub up: Option<Triple>,
}

/// Mitsuba 3's `projector`: a picture of irradiance seen through a pinhole at `position`,
/// looking along its axis with the picture's `up` (the frame of Mitsuba's `lookat`: x = up ×
/// axis normalised, y = axis × x; default up +y, or +x when the axis is within 26° of
/// vertical). Intensity π · scale · E(u, v) / cos³ θ, so that a plane facing it at distance 1
/// receives π · scale · E ([`crate::light::projector`]).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProjectorLightDesc {
    pub position: Triple,
    /// A point on the axis (give this or `direction`).
    pub target: Option<Triple>,
    /// The axis (give this or `target`).
    pub direction: Option<Triple>,
    pub up: Option<Triple>,
    /// Field of view in degrees, in (0, 180), along `fov_axis`.
    pub fov: f64,
    /// "x" (default), "y", "diagonal", "smaller" or "larger" of the picture, as Mitsuba's.
    pub fov_axis: Option<String>,
    /// E: a colour, or a picture (`bitmap` or `checkerboard`) whose resolution sets the aspect
    /// ratio of the view (a constant's is 1). Default [1, 1, 1].
    pub irradiance: Option<Color>,
    /// Multiplies the irradiance (default 1).
    pub scale: Option<f64>,
}

/// Parallel light travelling along `direction`, with irradiance [W/m²] on a surface facing it.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DirectionalLightDesc {
    pub direction: Triple,
    pub irradiance: Triple,
}

/// Light from infinitely far away; `type` selects the variant.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum EnvironmentDesc {
    Constant(ConstantEnvironment),
    Envmap(EnvmapDesc),
}

/// The same radiance from every direction (Mitsuba's `constant`).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConstantEnvironment {
    pub radiance: Triple,
}

/// A latitude–longitude image (Mitsuba's `envmap`): OpenEXR (linear), PNG, JPEG or BMP (sRGB).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvmapDesc {
    /// Relative to the directory of the scene file.
    pub file: String,
    /// Multiplies the radiance (default 1).
    pub scale: Option<f64>,
    /// A rotation of the map (its +y is the zenith, u = 0 looks down −z; an equal-area map's
    /// centre is its +z).
    pub transform: Option<TransformDesc>,
    /// "latlong" (default, Mitsuba's `envmap`) or "equal_area": pbrt-v4's square image over
    /// the sphere by the equal-area octahedral mapping, read by nearest texel.
    pub mapping: Option<String>,
}

/// A pinhole camera.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    pub eye: Triple,
    pub look_at: Triple,
    #[serde(default = "default_up")]
    pub up: Triple,
    /// Full vertical field of view in degrees, in (0, 180); not read by an orthographic lens.
    pub fov_y: Option<f64>,
    /// `[width, height]` in pixels.
    pub resolution: Fixed<u32, 2>,
    /// The pixel reconstruction filter (default: the box).
    pub filter: Option<FilterDesc>,
    /// Render only a window of the film (default: all of it).
    pub crop: Option<CropDesc>,
    /// How rays leave the camera (default: a pinhole).
    pub lens: Option<LensDesc>,
    /// Mirror the image left–right (default false): pbrt's cameras (a pbrt-v4 scene imports
    /// with it set).
    #[serde(default)]
    pub flip_x: bool,
    /// The medium the camera sits in (a name in `[media]`; default none).
    pub medium: Option<String>,
}

/// The camera's lens (Mitsuba's sensors of the same kinds); `type` selects it.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum LensDesc {
    /// Every ray through `eye` (Mitsuba's `perspective`).
    Pinhole(PinholeDesc),
    /// Mitsuba's `thinlens`.
    Thin(ThinLensDesc),
    /// Mitsuba's `orthographic`.
    Orthographic(OrthographicDesc),
}

/// A pinhole has no parameters.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PinholeDesc {}

/// A thin lens at `eye`: rays leave a uniform point of the disc of `aperture_radius` toward
/// the plane of focus, `focus_distance` along the view direction (both in scene units, > 0).
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThinLensDesc {
    pub aperture_radius: f64,
    pub focus_distance: f64,
}

/// Parallel rays along the view direction from a `width` × `height` rectangle (scene units)
/// centred on `eye`; `width` defaults to `height` times the film's aspect ratio.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OrthographicDesc {
    pub height: f64,
    pub width: Option<f64>,
}

/// A crop window: the film's pixels [x, x + w) × [y, y + h) (Mitsuba's `crop_offset_x`,
/// `crop_offset_y`, `crop_width`, `crop_height`); the field of view stays the full film's.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CropDesc {
    /// `[x, y]`, the window's top-left pixel (default `[0, 0]`).
    pub offset: Option<Fixed<u32, 2>>,
    /// `[w, h]` in pixels.
    pub size: Fixed<u32, 2>,
}

/// A pixel reconstruction filter (Mitsuba's rfilters of the same names); `type` selects it.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum FilterDesc {
    Box(BoxFilterDesc),
    Tent(TentFilterDesc),
    Gaussian(GaussianFilterDesc),
}

/// The pixel's own square.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxFilterDesc {}

/// max(0, 1 − |x| / radius) per axis.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TentFilterDesc {
    /// Half-width in pixels (default 1, as Mitsuba).
    pub radius: Option<f64>,
}

/// Mitsuba's truncated Gaussian, radius 4 σ, per axis.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GaussianFilterDesc {
    /// σ in pixels (default 0.5, as Mitsuba).
    pub stddev: Option<f64>,
}

fn default_up() -> Triple {
    Fixed([0.0, 1.0, 0.0])
}

/// One transform step or a list of steps, applied in list order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TransformDesc(pub Vec<TransformStep>);

impl TransformDesc {
    /// A 4 × 4 affine matrix as one `matrix` step (row-major): how the Mitsuba and pbrt
    /// importers hand over the transforms they compose.
    pub fn from_matrix(m: glam::DMat4) -> Self {
        let row = |i: usize| Fixed(m.row(i).to_array());
        TransformDesc(vec![TransformStep {
            matrix: Some(Fixed([row(0), row(1), row(2), row(3)])),
            ..TransformStep::default()
        }])
    }
}

/// One step: scale, then rotate about x, y, z, then translate; or a matrix on its own.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformStep {
    pub scale: Option<Scale>,
    pub rotate_x: Option<f64>,
    pub rotate_y: Option<f64>,
    pub rotate_z: Option<f64>,
    pub translate: Option<Triple>,
    /// Four rows of four, row-major; the last row must be `[0, 0, 0, 1]`.
    pub matrix: Option<Fixed<Fixed<f64, 4>, 4>>,
}

/// A uniform (`scale = 2`) or per-axis (`scale = [1, 2, 1]`) scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scale {
    Uniform(f64),
    PerAxis(Triple),
}

/// A user path for Metropolis photon sampling.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UserPathDesc {
    /// A point on a light, then surface points; at least two.
    pub points: Vec<Triple>,
    /// Cone half-angle β in degrees, in (0, 90]: one for all segments or one per segment.
    pub cone_deg: ConeDeg,
}

/// One cone angle for every segment, or one per segment.
#[derive(Clone, Debug, PartialEq)]
pub enum ConeDeg {
    All(f64),
    PerSegment(Vec<f64>),
}

mod materials;
mod shapes;
mod visitors;

pub use materials::*;
pub use shapes::*;
