//! Mitsuba 3's `disk` and `cylinder` ([`desc::Disk`], [`desc::Cylinder`]) as triangles.
//!
//! **Decision: the curved shapes are tessellated**, finely enough that geometry and area are
//! within 10⁻⁴ of the analytic surface, with the analytic surface's shading normals and
//! Mitsuba's texture coordinates at every vertex, so that everything downstream (BVH, light
//! sampling, photons, every strategy) stays as it is for triangles:
//! - **around**: [`SEGMENTS`] = 512 segments, the vertices on the circle. A polygon of N sides
//!   has π r² · sin(2π/N)/(2π/N) of the disk's area, (2π/N)²/6 = 2.5·10⁻⁵ short, and the tube's
//!   sides 2πrh · sin(π/N)/(π/N), (π/N)²/6 = 6.3·10⁻⁶ short; no point of a chord is farther
//!   than r (1 − cos(π/N)) = 1.9·10⁻⁵ r from the surface.
//! - **normals**: exact at each vertex — the disk's plane normal, the tube's radial direction —
//!   and mapped by the inverse transpose of the transform, as Mitsuba maps them. Along a chord of
//!   the tube the interpolated normal is the radial direction through the point itself, so the
//!   shading is the analytic surface's (also for an elliptic tube: the map is linear).
//! - **texture coordinates** as Mitsuba 3.9.1 computes them (`src/shapes/disk.cpp`,
//!   `cylinder.cpp`), in the shape's own frame with φ ∈ [0, 2π) from its +x towards +y: the disk
//!   (r, φ/2π), the tube (φ/2π, z) with z from 0 at `p0` to 1 at `p1`. The seam φ = 0 is a row
//!   of vertices taken twice, with the angle coordinate 0 on one side and 1 on the other, so that
//!   no triangle interpolates across it; the disk's centre is one vertex per triangle, at the
//!   triangle's middle angle. Between vertices the coordinates are interpolated linearly: the
//!   disk's u (the radius) is off by at most 1.9·10⁻⁵ of itself, its v by at most 1.1·10⁻⁴ on
//!   the rings and 9.3·10⁻⁴ in the central fan (r < 1/16, where that moves a pattern by at
//!   most 4·10⁻⁴ r); the tube's u by at most 5·10⁻⁹, its v not at all (measured by sampling
//!   every kind of cell).
//! - **cells** at most about [`MAX_ASPECT`] = 16 times longer than wide, so that their bounding
//!   boxes overlap little however the shape is turned: the disk in [`DISK_RINGS`] = 13 rings at
//!   radii 16^(−k/13) around a fan of 512 triangles inside radius 1/16 (13 824 triangles), the
//!   tube in ⌈h / (16 · 2πr/512)⌉ rings along its axis, h and r measured after transforming,
//!   1 to [`MAX_TUBE_RINGS`] = 128 (a tube as long as its radius: 6 rings, 6 144 triangles).
//!
//! Each triangle is one primitive: an emitting disk or tube is an area light of that many
//! triangles, as any mesh. Triangles that a transform makes too small for f32 (the centre's fan
//! of a tiny disk far from the origin) are skipped and counted, as a mesh's are; a shape left with
//! none is refused.

use super::*;
use crate::error::Result;
use crate::resources::{check_memory, memory_limit};
use crate::scene::PrimAttrs;
use crate::scene::desc::{self, Fixed};
use glam::{DAffine3, DMat3, DVec2, DVec3};
use std::f64::consts::TAU;

/// Segments around a disk or a tube.
const SEGMENTS: u32 = 512;
/// About the largest ratio of a cell's length to its width.
const MAX_ASPECT: f64 = 16.0;
/// Rings of a disk outside its central fan, and the fan's radius (of the unit disk).
const DISK_RINGS: u32 = 13;
const FAN_RADIUS: f64 = 1.0 / 16.0;
/// The most rings along a tube (a long thin rod has cells longer than [`MAX_ASPECT`]).
const MAX_TUBE_RINGS: u32 = 128;
/// Enters the content hash of every scene with a disk or a cylinder: bump it when the
/// tessellation changes, so that references and cached cells made with the old one go stale.
const TESSELLATION_HASH_TAG: &[u8] = b"photon-bench disk and cylinder tessellation v1";

/// A vertex in the shape's own frame: position, shading normal, texture coordinates.
#[derive(Clone, Copy, Debug)]
pub(super) struct Vertex {
    pub(super) p: DVec3,
    pub(super) n: DVec3,
    pub(super) uv: DVec2,
}

impl Builder<'_> {
    /// Mitsuba's unit disk (radius 1 in the plane z = 0, front +z; −z with `flip_normals`) under
    /// the shape's transform.
    pub(super) fn disk(&mut self, field: &str, d: &desc::Disk, xf: &Xform, attrs: PrimAttrs) -> Result<()> {
        let n = if d.flip_normals { -DVec3::Z } else { DVec3::Z };
        let count = SEGMENTS * (2 * DISK_RINGS + 1);
        self.reserve_tessellation(field, u64::from(count), TESSELLATION_HASH_TAG)?;
        self.tessellated(field, xf, disk_triangles(n), attrs)
    }

    /// Mitsuba's cylinder: the unit tube (radius 1 about the z axis, z ∈ [0, 1], normals outward;
    /// inward with `flip_normals`) placed on `p0`–`p1` with `radius` as Mitsuba places it, then
    /// the shape's transform.
    pub(super) fn cylinder(&mut self, field: &str, c: &desc::Cylinder, xf: &Xform, attrs: PrimAttrs) -> Result<()> {
        let ctx = self.ctx;
        let p0 = ctx.coords(&format!("{field}.p0"), c.p0.unwrap_or(Fixed([0.0; 3])))?;
        let p1 = ctx.coords(&format!("{field}.p1"), c.p1.unwrap_or(Fixed([0.0, 0.0, 1.0])))?;
        let radius = ctx.positive(&format!("{field}.radius"), c.radius.unwrap_or(1.0))?;
        if p1 == p0 {
            // Named by the one written (p1 unless only p0 is).
            let (key, other) = if c.p1.is_none() { ("p0", "p1") } else { ("p1", "p0") };
            return Err(ctx.err(
                &format!("{field}.{key}"),
                format!(
                    "expected a point other than {other} (the axis would have zero length), got {} for both",
                    triple(p1.to_array())
                ),
            ));
        }
        let xf = xf.after(cylinder_frame(p0, p1, radius));
        let rings = tube_rings(xf.m.matrix3);
        self.reserve_tessellation(field, u64::from(2 * SEGMENTS * rings), TESSELLATION_HASH_TAG)?;
        let sign = if c.flip_normals { -1.0 } else { 1.0 };
        self.tessellated(field, &xf, tube_triangles(rings, sign), attrs)
    }

    /// Checks that `count` more triangles fit in the memory limit, and marks the scene's hash as
    /// holding shapes tessellated the way `tag` names.
    pub(super) fn reserve_tessellation(&mut self, field: &str, count: u64, tag: &[u8]) -> Result<()> {
        let triangles = self.primitives.len() as u64 + count;
        check_memory("the scene's triangles", triangles * BYTES_PER_TRIANGLE, memory_limit()?)
            .map_err(|e| self.ctx.err(field, e))?;
        if !self.hashed.iter().any(|h| h == tag) {
            self.hashed.push(tag.to_vec());
        }
        Ok(())
    }

    /// Adds triangles given in the shape's frame (`xf` maps them to the world), skipping and
    /// counting those that collapse in f32; a shape left without any is refused.
    pub(super) fn tessellated(
        &mut self,
        field: &str,
        xf: &Xform,
        triangles: impl Iterator<Item = [Vertex; 3]>,
        attrs: PrimAttrs,
    ) -> Result<()> {
        let (mut added, mut skipped) = (0usize, 0usize);
        for t in triangles {
            match self.triangle(xf, t.map(|v| v.p), Some(t.map(|v| v.n)), Some(t.map(|v| v.uv)), attrs) {
                Ok(_) => added += 1,
                Err(TriangleError::Degenerate) => skipped += 1,
                Err(TriangleError::OutOfRange(msg)) => return Err(self.ctx.err(field, msg)),
            }
        }
        if added == 0 {
            return Err(self.ctx.err(
                field,
                "the shape has zero area at f32 precision after transforming (too small for its \
                 distance from the origin)",
            ));
        }
        self.stats.degenerate_triangles_skipped += skipped;
        Ok(())
    }
}

/// The unit circle at segment boundary `j` (0 ..= [`SEGMENTS`]; `SEGMENTS` is 0 again, to the
/// bit, so that the seam closes without a crack).
fn circle(j: u32) -> DVec2 {
    let phi = TAU * f64::from(j % SEGMENTS) / f64::from(SEGMENTS);
    DVec2::new(phi.cos(), phi.sin())
}

/// The angle coordinate (φ/2π) at segment boundary `j`: 1 at the far side of the seam.
fn turn(j: u32) -> f64 {
    f64::from(j) / f64::from(SEGMENTS)
}

/// The radii of the disk's rings, outermost (1) first, down to the fan's radius.
fn disk_radii() -> impl Iterator<Item = f64> {
    (0..=DISK_RINGS).map(|k| FAN_RADIUS.powf(f64::from(k) / f64::from(DISK_RINGS)))
}

/// The unit disk's triangles, counter-clockwise about +z, with normal `n` at every vertex and
/// Mitsuba's (u, v) = (r, φ/2π): two per cell of each ring, then the central fan.
fn disk_triangles(n: DVec3) -> impl Iterator<Item = [Vertex; 3]> {
    let at = move |r: f64, j: u32| Vertex {
        p: (r * circle(j)).extend(0.0),
        n,
        uv: DVec2::new(r, turn(j)),
    };
    let radii: Vec<f64> = disk_radii().collect();
    let rings = (0..DISK_RINGS as usize).flat_map(move |k| {
        let (outer, inner) = (radii[k], radii[k + 1]);
        (0..SEGMENTS).flat_map(move |j| {
            let (a, b, c, d) = (at(inner, j), at(outer, j), at(outer, j + 1), at(inner, j + 1));
            [[a, b, c], [a, c, d]]
        })
    });
    let fan = (0..SEGMENTS).map(move |j| {
        // The centre has no angle of its own: each triangle's copy takes the triangle's middle.
        let centre = Vertex {
            p: DVec3::ZERO,
            n,
            uv: DVec2::new(0.0, (f64::from(j) + 0.5) / f64::from(SEGMENTS)),
        };
        [centre, at(FAN_RADIUS, j), at(FAN_RADIUS, j + 1)]
    });
    rings.chain(fan)
}

/// The unit tube's triangles in `rings` rings along z, counter-clockwise seen from outside, with
/// normals `sign` × the radial direction and Mitsuba's (u, v) = (φ/2π, z).
fn tube_triangles(rings: u32, sign: f64) -> impl Iterator<Item = [Vertex; 3]> {
    let at = move |j: u32, k: u32| {
        let c = circle(j);
        let z = f64::from(k) / f64::from(rings);
        Vertex {
            p: c.extend(z),
            n: sign * c.extend(0.0),
            uv: DVec2::new(turn(j), z),
        }
    };
    (0..rings).flat_map(move |k| {
        (0..SEGMENTS).flat_map(move |j| {
            let (a, b, c, d) = (at(j, k), at(j + 1, k), at(j + 1, k + 1), at(j, k + 1));
            [[a, b, c], [a, c, d]]
        })
    })
}

/// Rings along a tube whose frame maps to the world by `linear`: cells about [`MAX_ASPECT`]
/// times longer than their width 2πr/[`SEGMENTS`] (lengths in the world), 1 to
/// [`MAX_TUBE_RINGS`].
fn tube_rings(linear: DMat3) -> u32 {
    let length = linear.z_axis.length();
    let radius = (linear.x_axis.length() * linear.y_axis.length()).sqrt();
    let width = TAU * radius / f64::from(SEGMENTS);
    (length / (MAX_ASPECT * width))
        .ceil()
        .clamp(1.0, f64::from(MAX_TUBE_RINGS)) as u32
}

/// Mitsuba 3's placement of its unit cylinder (`cylinder.cpp`): translate(p0) · to_frame(Frame(d̂))
/// · scale(r, r, |d|) with d = p1 − p0, so that the azimuth φ = 0 of its texture coordinates
/// lies along the frame's first tangent.
pub(crate) fn cylinder_frame(p0: DVec3, p1: DVec3, radius: f64) -> DAffine3 {
    let d = p1 - p0;
    let length = d.length();
    let mut n = d / length;
    // Mitsuba takes the difference in f32, and the sign of a zero picks the frame below: z
    // that differ only beyond f32 give its zero (+0, or −0 for −0 − 0), not our tiny difference.
    let dz = p1.z as f32 - p0.z as f32;
    if dz == 0.0 {
        n.z = f64::from(dz);
    }
    let (s, t) = coordinate_system(n);
    DAffine3::from_mat3_translation(DMat3::from_cols(radius * s, radius * t, length * n), p0)
}

/// Mitsuba 3's `coordinate_system(n)` (Duff et al. 2017, "Building an orthonormal basis,
/// revisited"): tangents s, t with s × t = n. The sign of n.z is its sign bit, as Dr.Jit's
/// `sign` and `mulsign` read it (−0 counts as negative).
fn coordinate_system(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        DVec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}
