//! Meshing: every shape to primitives (quads, boxes, spheres, OBJ meshes through tobj,
//! `subdivide`; disks and cylinders in [`super::curved`]), rounded to f32 only after validation;
//! degenerate triangles refused or counted.

use super::mesh_formats::{TriMesh, angle_weighted_normals, parse_ply, parse_serialized};
use super::*;
use crate::error::Result;
use crate::geometry::Primitive;
use crate::light::Emission;
use crate::resources::{check_memory, memory_limit};
use crate::scene::desc::{self, ShapeDesc};
use crate::scene::{PrimAttrs, UvMap};
use glam::{DMat3, DVec2, DVec3, Vec3};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Builds primitives shape by shape and remembers every file it read for the content hash.
pub(super) struct Builder<'a> {
    pub(super) ctx: &'a Ctx,
    /// Directory of the scene file: relative mesh paths start here.
    pub(super) dir: PathBuf,
    pub(super) primitives: Vec<Primitive>,
    pub(super) attrs: Vec<PrimAttrs>,
    /// The scene file's bytes, then every mesh and MTL file's bytes in reading order.
    pub(super) hashed: Vec<Vec<u8>>,
    pub(super) stats: LoadStats,
    /// Mesh attributes by name: the channels and, per primitive that has the attribute, its
    /// three corners' values in the primitive's vertex order (a face attribute's value three
    /// times), for `mesh_attribute` textures.
    pub(super) mesh_attributes: BTreeMap<String, PrimValues>,
    /// The first primitive of each shape and the shape's label, for messages.
    pub(super) shape_starts: Vec<(usize, String)>,
}

/// One mesh attribute over the scene's primitives ([`Builder::mesh_attributes`]).
#[derive(Debug, Default)]
pub(super) struct PrimValues {
    pub(super) channels: usize,
    pub(super) per_face: bool,
    pub(super) corners: Vec<(u32, [[f32; 4]; 3])>,
}

/// Why a triangle could not be added.
pub(super) enum TriangleError {
    /// Zero area at f32 precision.
    Degenerate,
    /// A transformed vertex, as a message.
    OutOfRange(String),
}

/// Where a mesh's shading normals come from: none (`face`), the file's, or Mitsuba's smooth
/// ones when the file has none (`smooth`).
#[derive(Clone, Copy)]
struct MeshNormals {
    face: bool,
    smooth: bool,
}

impl Builder<'_> {
    pub(super) fn shape(
        &mut self,
        field: &str,
        shape: &ShapeDesc,
        material_index: &BTreeMap<String, u32>,
    ) -> Result<()> {
        let ctx = self.ctx;
        let (material_name, t, emission) = shape.common();
        let Some(&material) = material_index.get(material_name) else {
            let known: Vec<String> = material_index.keys().map(|k| key_string(k)).collect();
            let known = if known.is_empty() {
                "no materials are defined".to_string()
            } else {
                format!("defined: {}", known.join(", "))
            };
            return Err(ctx.err(
                &format!("{field}.material"),
                format!("no material named {material_name:?} ({known})"),
            ));
        };
        let emission = match emission {
            None => None,
            Some(e) => {
                let ok = e.radiance.iter().all(|&c| (0.0..=MAX_RADIANCE).contains(&c));
                if !ok {
                    return Err(ctx.err(
                        &format!("{field}.emission.radiance"),
                        format!(
                            "expected each channel finite in [0, {}], got {}",
                            num(MAX_RADIANCE),
                            triple(e.radiance)
                        ),
                    ));
                }
                Some(Emission {
                    le: rgb(e.radiance),
                    two_sided: e.two_sided,
                })
            }
        };
        let attrs = PrimAttrs {
            emission,
            ..PrimAttrs::new(material)
        };
        let xf = transform(ctx, field, t)?;
        match shape {
            ShapeDesc::Quad(q) => {
                let (corner, u, v) = quad_frame(ctx, field, q)?;
                let n = self.subdivision(field, q.subdivide, 2)?;
                // (u, v) = (s, t), Mitsuba's rectangle parameterization.
                self.quad(field, &xf, [corner, u, v], [DVec2::ZERO, DVec2::X, DVec2::Y], n, attrs)
            }
            ShapeDesc::Box(b) => {
                let (lo, hi) = match (b.min, b.max, b.center, b.size) {
                    (Some(lo), Some(hi), None, None) => {
                        let lo = ctx.coords(&format!("{field}.min"), lo)?;
                        let hi = ctx.coords(&format!("{field}.max"), hi)?;
                        if !lo.cmplt(hi).all() {
                            return Err(ctx.err(
                                &format!("{field}.max"),
                                format!(
                                    "expected max > min on every axis, got min = {}, max = {}",
                                    triple(lo.to_array()),
                                    triple(hi.to_array())
                                ),
                            ));
                        }
                        (lo, hi)
                    }
                    (None, None, Some(c), Some(s)) => {
                        let c = ctx.coords(&format!("{field}.center"), c)?;
                        let s = DVec3::from_array(ctx.sizes(&format!("{field}.size"), s.0)?);
                        (c - 0.5 * s, c + 0.5 * s)
                    }
                    _ => {
                        return Err(ctx.err(field, "a box needs either `min` and `max` or `center` and `size`"));
                    }
                };
                let n = self.subdivision(field, b.subdivide, 12)?;
                let d = hi - lo;
                let (x, y, z) = (d.x * DVec3::X, d.y * DVec3::Y, d.z * DVec3::Z);
                // Six faces, each edge_u × edge_v pointing out of the box.
                let faces = [
                    (lo, z, y),
                    (DVec3::new(hi.x, lo.y, lo.z), y, z),
                    (lo, x, z),
                    (DVec3::new(lo.x, hi.y, lo.z), z, x),
                    (lo, y, x),
                    (DVec3::new(lo.x, lo.y, hi.z), x, y),
                ];
                for (corner, u, v) in faces {
                    // Mitsuba's cube parameterization, affine on each face.
                    let local = |p: DVec3| 2.0 * (p - lo) / d - DVec3::ONE;
                    let normal = u.cross(v).normalize();
                    let uv0 = cube_uv(local(corner), normal);
                    let uvs = [
                        uv0,
                        cube_uv(local(corner + u), normal) - uv0,
                        cube_uv(local(corner + v), normal) - uv0,
                    ];
                    self.quad(field, &xf, [corner, u, v], uvs, n, attrs)?;
                }
                Ok(())
            }
            ShapeDesc::Sphere(s) => {
                let center = ctx.coords(&format!("{field}.center"), s.center)?;
                let radius = ctx.positive(&format!("{field}.radius"), s.radius)?;
                // A sphere stays a sphere only under a similarity: LᵀL = s² I.
                let l = xf.m.matrix3;
                let g = l.transpose() * l;
                let s2 = (g.x_axis.x + g.y_axis.y + g.z_axis.z) / 3.0;
                let off = (g - DMat3::from_diagonal(DVec3::splat(s2))).to_cols_array();
                if off.iter().any(|x| x.abs() > 1e-6 * s2) {
                    return Err(ctx.err(
                        &format!("{field}.transform"),
                        "a sphere accepts only rotations, translations and uniform scale",
                    ));
                }
                let c = xf.point(center);
                let r = radius * s2.sqrt();
                if !(c.to_array().iter().all(|&x| is_coord(x)) && r > 0.0 && is_coord(r)) {
                    return Err(ctx.err(
                        field,
                        format!(
                            "the transformed sphere (center {}, radius {}) exceeds magnitude {}",
                            triple(c.to_array()),
                            num(r),
                            num(MAX_COORD)
                        ),
                    ));
                }
                self.primitives.push(Primitive::Sphere {
                    center: c.as_vec3(),
                    radius: r as f32,
                });
                // The transform's rotation (or reflection) turns the sphere's own frame, in which
                // its (u, v) are defined.
                let world_to_local = (l / s2.sqrt()).transpose().as_mat3();
                self.attrs.push(PrimAttrs {
                    uv: UvMap::Sphere { world_to_local },
                    ..attrs
                });
                Ok(())
            }
            ShapeDesc::Mesh(m) => self.mesh(field, m, &xf, attrs),
            ShapeDesc::Triangles(t) => self.inline_triangles(field, t, &xf, attrs),
            ShapeDesc::Disk(d) => self.disk(field, d, &xf, attrs),
            ShapeDesc::Cylinder(c) => self.cylinder(field, c, &xf, attrs),
            ShapeDesc::LinearCurve(c) => self.linear_curve(field, c, &xf, attrs),
            ShapeDesc::BsplineCurve(c) => self.bspline_curve(field, c, &xf, attrs),
        }
    }

    /// The validated `subdivide` of `field` (default 1), after checking that the
    /// `triangles_per_cell` · n² triangles it adds fit in the memory limit.
    pub(super) fn subdivision(&mut self, field: &str, subdivide: Option<i64>, triangles_per_cell: u64) -> Result<u32> {
        let Some(n) = subdivide else { return Ok(1) };
        let field = format!("{field}.subdivide");
        if !(1..=MAX_SUBDIVIDE).contains(&n) {
            return Err(self.ctx.err(
                &field,
                format!("expected an integer in 1..={MAX_SUBDIVIDE} (cells per edge), got {n}"),
            ));
        }
        let triangles = self.primitives.len() as u64 + triangles_per_cell * (n * n) as u64;
        check_memory("the scene's triangles", triangles * BYTES_PER_TRIANGLE, memory_limit()?)
            .map_err(|e| self.ctx.err(&field, e))?;
        if n > 1 && !self.hashed.iter().any(|h| h == SUBDIVIDE_HASH_TAG) {
            self.hashed.push(SUBDIVIDE_HASH_TAG.to_vec());
        }
        Ok(n as u32)
    }

    /// Adds the parallelogram corner + s·u + t·v as an n × n grid of cells, two triangles each,
    /// facing u × v, with texture coordinates uv₀ + s·du + t·dv (`[uv₀, du, dv]`). Cell corners
    /// are computed from the integer grid indices (never by accumulating steps), so neighbouring
    /// cells share their vertices exactly: no cracks.
    pub(super) fn quad(
        &mut self,
        field: &str,
        xf: &Xform,
        [corner, u, v]: [DVec3; 3],
        [uv0, du, dv]: [DVec2; 3],
        n: u32,
        attrs: PrimAttrs,
    ) -> Result<()> {
        let st = |i: u32, j: u32| (f64::from(i) / f64::from(n), f64::from(j) / f64::from(n));
        let at = |i: u32, j: u32| {
            let (s, t) = st(i, j);
            (corner + u * s + v * t, uv0 + du * s + dv * t)
        };
        for j in 0..n {
            for i in 0..n {
                let cell = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
                self.cell(field, xf, cell.map(|c| c.0), cell.map(|c| c.1), attrs)?;
            }
        }
        Ok(())
    }

    /// Adds one parallelogram a b c d (counter-clockwise about its front) as two triangles.
    pub(super) fn cell(
        &mut self,
        field: &str,
        xf: &Xform,
        [a, b, c, d]: [DVec3; 4],
        [ta, tb, tc, td]: [DVec2; 4],
        attrs: PrimAttrs,
    ) -> Result<()> {
        for (tri, uv) in [([a, b, c], [ta, tb, tc]), ([a, c, d], [ta, tc, td])] {
            match self.triangle(xf, tri, None, Some(uv), attrs) {
                Ok(_) => {}
                Err(TriangleError::OutOfRange(msg)) => return Err(self.ctx.err(field, msg)),
                Err(TriangleError::Degenerate) => {
                    return Err(self.ctx.err(
                        field,
                        "the shape has zero area at f32 precision after transforming (too \
                         small for its distance from the origin)",
                    ));
                }
            }
        }
        Ok(())
    }

    /// Transforms and adds one triangle, given CCW about its intended front side, with its
    /// vertices' shading normals and texture coordinates if any; true when it was turned around
    /// (its vertices 1 and 2 swapped).
    pub(super) fn triangle(
        &mut self,
        xf: &Xform,
        v: [DVec3; 3],
        normals: Option<[DVec3; 3]>,
        uvs: Option<[DVec2; 3]>,
        attrs: PrimAttrs,
    ) -> std::result::Result<bool, TriangleError> {
        let mut w = v.map(|p| xf.point(p));
        for p in w {
            if !p.to_array().iter().all(|&c| is_coord(c)) {
                return Err(TriangleError::OutOfRange(format!(
                    "a transformed vertex {} exceeds magnitude {}",
                    triple(p.to_array()),
                    num(MAX_COORD)
                )));
            }
        }
        let mut n = normals.and_then(|ns| {
            let ns = ns.map(|n| (xf.normal_matrix * n).normalize_or_zero().as_vec3());
            ns.iter().all(|n| n.is_finite() && *n != Vec3::ZERO).then_some(ns)
        });
        let mut uvs = uvs.map(|t| t.map(|t| t.as_vec2()));
        // The front side follows the vertex normals where a file has them (Mitsuba shades, and
        // decides one-sidedness and inside/outside, in the frame of the interpolated normal,
        // whatever the winding says), the winding otherwise (turned back by a mirroring
        // transform). A triangle wound against its world normals is turned around.
        let turn = match n {
            Some(ns) => (w[1] - w[0]).cross(w[2] - w[0]).dot((ns[0] + ns[1] + ns[2]).as_dvec3()) < 0.0,
            None => xf.flips,
        };
        if turn {
            w.swap(1, 2);
            if let Some(ns) = n.as_mut() {
                ns.swap(1, 2);
            }
            if let Some(t) = uvs.as_mut() {
                t.swap(1, 2);
            }
        }
        let p = w.map(|p| p.as_vec3());
        if is_degenerate(p) {
            return Err(TriangleError::Degenerate);
        }
        self.primitives.push(Primitive::Triangle(p));
        let uv = match uvs {
            Some(t) if t.iter().all(|t| t.is_finite()) => UvMap::Vertices(t),
            _ => attrs.uv,
        };
        self.attrs.push(PrimAttrs {
            normals: n,
            uv,
            ..attrs
        });
        Ok(turn)
    }

    /// A mesh file: OBJ (through tobj), PLY or Mitsuba `.serialized`, chosen by the extension.
    pub(super) fn mesh(&mut self, field: &str, m: &desc::Mesh, xf: &Xform, attrs: PrimAttrs) -> Result<()> {
        let ctx = self.ctx;
        let file_field = format!("{field}.file");
        let path = self.dir.join(&m.file);
        let shown = path.display().to_string();
        let bytes =
            read_regular_file(&path, "mesh").map_err(|e| ctx.err(&file_field, format!("cannot read {shown}: {e}")))?;
        self.stats.files_read.push(path.clone());
        // A `.ply.gz` (pbrt-v4 reads gzip-compressed PLY files) is its decompressed PLY.
        let (bytes, named) = if crate::util::is_gzip(&path) {
            let plain = crate::util::gunzip(&bytes, crate::util::MAX_TEXT_INPUT * 16)
                .map_err(|e| ctx.err(&file_field, format!("{shown}: {e}")))?;
            (plain, path.with_extension(""))
        } else {
            (bytes, path.clone())
        };
        let extension = named
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        if m.shape_index.is_some() && extension != "serialized" {
            return Err(ctx.err(
                &format!("{field}.shape_index"),
                "only a .serialized file holds several meshes",
            ));
        }
        let (mut meshes, face_normals) = match extension.as_str() {
            "obj" => (self.obj_meshes(&file_field, &path, &bytes)?, m.face_normals),
            "ply" => (
                vec![parse_ply(&bytes).map_err(|e| ctx.err(&file_field, format!("{shown}: {e}")))?],
                m.face_normals,
            ),
            "serialized" => {
                let (mesh, flat) = parse_serialized(&bytes, m.shape_index.unwrap_or(0))
                    .map_err(|e| ctx.err(&file_field, format!("{shown}: {e}")))?;
                (vec![mesh], m.face_normals || flat)
            }
            _ => {
                return Err(ctx.err(
                    &file_field,
                    format!("{shown}: expected a mesh file ending in .obj, .ply or .serialized"),
                ));
            }
        };
        self.hashed.push(bytes);
        if m.reverse_orientation {
            // Only where the winding decides the front (vertex normals decide by themselves).
            for mesh in meshes.iter_mut().filter(|mesh| face_normals || mesh.normals.is_none()) {
                for t in &mut mesh.triangles {
                    t.swap(1, 2);
                }
            }
        }
        let normals = MeshNormals {
            face: face_normals,
            smooth: m.smooth_normals,
        };
        self.add_meshes((field, &file_field, &shown), &meshes, normals, xf, attrs)
    }

    /// A mesh written in the scene file ([`desc::Triangles`]): every index a vertex, the
    /// per-vertex arrays as long as `positions`.
    fn inline_triangles(&mut self, field: &str, t: &desc::Triangles, xf: &Xform, attrs: PrimAttrs) -> Result<()> {
        let ctx = self.ctx;
        let f = |key: &str| format!("{field}.{key}");
        let n = t.positions.len();
        let indices: Vec<i64> = match &t.indices {
            Some(i) => i.clone(),
            None if n == 3 => vec![0, 1, 2],
            None => {
                return Err(ctx.err(
                    &f("indices"),
                    format!("expected indices for {n} positions (3 need none)"),
                ));
            }
        };
        if indices.is_empty() || !indices.len().is_multiple_of(3) {
            return Err(ctx.err(
                &f("indices"),
                format!("expected a multiple of 3 indices, got {}", indices.len()),
            ));
        }
        if let Some(bad) = indices.iter().find(|&&i| i < 0 || i as usize >= n) {
            return Err(ctx.err(&f("indices"), format!("index {bad} is not a vertex (0..{n})")));
        }
        check_memory(
            "the scene's triangles",
            (self.primitives.len() + indices.len() / 3) as u64 * BYTES_PER_TRIANGLE,
            memory_limit()?,
        )
        .map_err(|e| ctx.err(&f("indices"), e))?;
        let per_vertex = |key: &str, len: Option<usize>| -> Result<()> {
            match len {
                Some(l) if l != n => Err(ctx.err(&f(key), format!("expected {n} entries (one per position), got {l}"))),
                _ => Ok(()),
            }
        };
        per_vertex("normals", t.normals.as_ref().map(Vec::len))?;
        per_vertex("uv", t.uv.as_ref().map(Vec::len))?;
        let point = |p: &desc::Triple| DVec3::from_array(p.0);
        let mesh = TriMesh {
            name: field.to_string(),
            positions: t.positions.iter().map(point).collect(),
            normals: t.normals.as_ref().map(|ns| ns.iter().map(point).collect()),
            uvs: t
                .uv
                .as_ref()
                .map(|uv| uv.iter().map(|t| DVec2::from_array(t.0)).collect()),
            triangles: indices
                .chunks(3)
                .map(|c| [c[0] as usize, c[1] as usize, c[2] as usize])
                .collect(),
            attributes: Vec::new(),
        };
        let normals = MeshNormals {
            face: false,
            smooth: false,
        };
        self.add_meshes((field, &f("positions"), "the mesh"), &[mesh], normals, xf, attrs)
    }

    /// Adds the triangles of `meshes` placed by `xf`, with shading normals by `normals`;
    /// `(field, file_field, shown)` name the shape, its data and its source in messages. Refuses
    /// a mesh with a non-finite or huge vertex, or without one triangle of positive area.
    fn add_meshes(
        &mut self,
        (field, file_field, shown): (&str, &str, &str),
        meshes: &[TriMesh],
        normals_from: MeshNormals,
        xf: &Xform,
        attrs: PrimAttrs,
    ) -> Result<()> {
        let ctx = self.ctx;
        let (face_normals, smooth_normals) = (normals_from.face, normals_from.smooth);
        let (mut added, mut skipped) = (0usize, 0usize);
        for mesh in meshes {
            if let Some(bad) = mesh
                .positions
                .iter()
                .position(|p| !p.is_finite() || p.abs().max_element() > MAX_COORD)
            {
                return Err(ctx.err(
                    file_field,
                    format!(
                        "{shown}: vertex {} of object {:?} has a non-finite or huge coordinate",
                        bad + 1,
                        mesh.name
                    ),
                ));
            }
            let normals: Option<Vec<DVec3>> = if face_normals {
                None
            } else if let Some(n) = mesh.normals.as_ref().filter(|n| n.len() == mesh.positions.len()) {
                Some(n.clone())
            } else if smooth_normals {
                // Mitsuba computes them from the transformed positions; back to the file's
                // frame (normal matrix⁻¹ = Mᵀ) for `triangle`, which maps them forward again.
                let world: Vec<DVec3> = mesh.positions.iter().map(|&p| xf.point(p)).collect();
                let linear = xf.m.matrix3.transpose();
                Some(
                    angle_weighted_normals(&world, &mesh.triangles)
                        .into_iter()
                        .map(|n| linear * n)
                        .collect(),
                )
            } else {
                None
            };
            let uvs = mesh.uvs.as_ref().filter(|t| t.len() == mesh.positions.len());
            for (face, tri) in mesh.triangles.iter().enumerate() {
                let ns = normals.as_ref().map(|n| tri.map(|i| n[i]));
                let ts = uvs.map(|t| tri.map(|i| t[i]));
                match self.triangle(xf, tri.map(|i| mesh.positions[i]), ns, ts, attrs) {
                    Ok(turned) => {
                        added += 1;
                        self.add_attributes(mesh, face, *tri, turned);
                    }
                    Err(TriangleError::Degenerate) => skipped += 1,
                    Err(TriangleError::OutOfRange(msg)) => {
                        return Err(ctx.err(field, format!("{shown}: {msg}")));
                    }
                }
            }
        }
        if added == 0 {
            let why = if skipped > 0 {
                format!("all {skipped} triangles are degenerate (zero area)")
            } else {
                "no triangles".to_string()
            };
            return Err(ctx.err(file_field, format!("{shown}: {why}")));
        }
        self.stats.degenerate_triangles_skipped += skipped;
        Ok(())
    }

    /// Records the attributes of `mesh` at its triangle `face` (vertices `tri`), the primitive
    /// just added (`turned`: with its vertices 1 and 2 swapped).
    fn add_attributes(&mut self, mesh: &TriMesh, face: usize, tri: [usize; 3], turned: bool) {
        let prim = (self.primitives.len() - 1) as u32;
        for a in &mesh.attributes {
            let value = |k: usize| -> [f32; 4] {
                let mut v = [0.0; 4];
                let n = a.channels.min(4);
                v[..n].copy_from_slice(&a.values[k * a.channels..k * a.channels + n]);
                v
            };
            let mut corners = if a.per_face { [value(face); 3] } else { tri.map(value) };
            if turned {
                corners.swap(1, 2);
            }
            let entry = self.mesh_attributes.entry(a.name.clone()).or_default();
            if entry.corners.is_empty() {
                (entry.channels, entry.per_face) = (a.channels, a.per_face);
            } else if entry.channels != a.channels {
                // Meshes disagree on its channels: a texture reading it is refused.
                entry.channels = usize::MAX;
            }
            entry.corners.push((prim, corners));
        }
    }

    /// The objects of an OBJ file (tobj, triangulated, one index per vertex). MTL libraries are
    /// read for the hash only; the scene's `material` is used, so tobj gets none (which also
    /// keeps its MTL parser, which can panic on short colour lines, away from our inputs).
    fn obj_meshes(&mut self, file_field: &str, path: &Path, bytes: &[u8]) -> Result<Vec<TriMesh>> {
        let ctx = self.ctx;
        let shown = path.display();
        let obj_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let mtl = std::cell::RefCell::new(Vec::<(PathBuf, Vec<u8>)>::new());
        let options = tobj::LoadOptions {
            triangulate: true,
            single_index: true,
            ignore_points: true,
            ignore_lines: true,
        };
        let parsed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            tobj::load_obj_buf(&mut &bytes[..], &options, |p| {
                let p = obj_dir.join(p);
                if let Ok(b) = read_regular_file(&p, "material library") {
                    mtl.borrow_mut().push((p, b));
                }
                Err(tobj::LoadError::GenericFailure)
            })
        }));
        let models = match parsed {
            Ok(Ok((models, _materials))) => models,
            Ok(Err(e)) => return Err(ctx.err(file_field, format!("{shown}: {e}"))),
            Err(_) => {
                return Err(ctx.err(file_field, format!("{shown}: the OBJ parser failed")));
            }
        };
        for (p, b) in mtl.into_inner() {
            self.stats.files_read.push(p);
            self.hashed.push(b);
        }
        let vecs = |v: &[f32]| -> Vec<DVec3> {
            v.chunks_exact(3)
                .map(|c| DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64))
                .collect()
        };
        let mut meshes = Vec::with_capacity(models.len());
        for model in models {
            let mesh = &model.mesh;
            let positions = vecs(&mesh.positions);
            let mut triangles = Vec::with_capacity(mesh.indices.len() / 3);
            for tri in mesh.indices.chunks(3) {
                let &[i, j, k] = tri else {
                    return Err(ctx.err(file_field, format!("{shown}: a face is not a triangle")));
                };
                let idx = [i as usize, j as usize, k as usize];
                if idx.iter().any(|&i| i >= positions.len()) {
                    return Err(ctx.err(file_field, format!("{shown}: a face index is out of range")));
                }
                triangles.push(idx);
            }
            // Mitsuba flips an OBJ file's v.
            let uvs = (mesh.texcoords.len() == 2 * positions.len()).then(|| {
                mesh.texcoords
                    .chunks_exact(2)
                    .map(|c| DVec2::new(f64::from(c[0]), 1.0 - f64::from(c[1])))
                    .collect()
            });
            meshes.push(TriMesh {
                name: model.name.clone(),
                normals: (!mesh.normals.is_empty()).then(|| vecs(&mesh.normals)),
                uvs,
                positions,
                triangles,
                attributes: Vec::new(),
            });
        }
        Ok(meshes)
    }
}

/// Mitsuba 3's `cube` parameterization: each face of [−1, 1]³ (point `p` on the face with unit
/// outward `normal`) onto [0, 1]², oriented as Mitsuba's cube (checked against Mitsuba 3.9's
/// ray intersections).
fn cube_uv(p: DVec3, normal: DVec3) -> DVec2 {
    let h = |a: f64| 0.5 * (a + 1.0);
    let axis = normal.abs().max_position();
    match (axis, normal[axis] > 0.0) {
        (0, true) => DVec2::new(h(p.y), h(-p.z)),
        (0, false) => DVec2::new(h(p.y), h(p.z)),
        (1, true) => DVec2::new(h(-p.x), h(-p.z)),
        (1, false) => DVec2::new(h(p.z), h(p.x)),
        (_, true) => DVec2::new(h(p.y), h(p.x)),
        (_, false) => DVec2::new(h(-p.y), h(p.x)),
    }
}

/// Reads a file a scene names (`what`: "mesh", "image" …), refusing devices, pipes and files
/// larger than any mesh ([`crate::util::read_input`]).
pub(super) fn read_regular_file(path: &Path, what: &str) -> std::io::Result<Vec<u8>> {
    // The caller names the path; the message keeps only what is wrong with it.
    crate::util::read_input(path, what, crate::util::MAX_MESH_INPUT).map_err(|e| {
        let msg = e.to_string();
        let prefix = format!("{}: ", path.display());
        std::io::Error::other(msg.strip_prefix(&prefix).unwrap_or(&msg).to_string())
    })
}

/// A triangle is degenerate when its normal is not computable in f32: zero or non-finite
/// cross product, or one so small against the edges that its direction is rounding noise.
pub(super) fn is_degenerate([a, b, c]: [Vec3; 3]) -> bool {
    let cross = (b - a).cross(c - a).length();
    let edge2 = (b - a)
        .length_squared()
        .max((c - a).length_squared())
        .max((c - b).length_squared());
    !(cross.is_finite() && cross > 1e-6 * edge2)
}
