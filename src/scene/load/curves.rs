//! Mitsuba 3's `linearcurve` ([`desc::LinearCurve`]) as triangles.
//!
//! **The surface** (Mitsuba 3.9.1's `linearcurve.cpp`, which hands the control points to
//! Embree's round linear curves): a curve is a chain of control points, each a sphere (centre,
//! radius); each segment is the cone that touches its two spheres, with the sphere at its end
//! (and, on a curve's first segment, the one at its start). Positions go through `to_world`,
//! radii do not (a curve stays round under any transform). Seen from outside, the union is
//! what a ray hits; Embree culls back faces, and so does nothing here need them: the tube is
//! opaque to everything outside it.
//!
//! **Decision: tessellated**, as disks and cylinders are ([`super::curved`]): [`AROUND`] = 256
//! segments around (a chord falls at most r (1 − cos(π/256)) = 7.5·10⁻⁵ r short of the
//! surface), each cone in rings about 16 times longer than wide (1 to 128), each spherical cap
//! in [`CAP_RINGS`] = 64 rings of latitude (7.5·10⁻⁵ r for a hemisphere; a cap of a cone that
//! narrows toward it spans more), so no point of a cap's triangle is more than about
//! 1.5·10⁻⁴ r inside the sphere. Normals exact at
//! every vertex: the cone's tilted radial direction cos α r̂ + sin α â (sin α = (r₀ − r₁)/|p₁ −
//! p₀|), the sphere's radial one on a cap. A joint's sphere is tessellated as the cap beyond the
//! incoming cone's circle of contact; the outgoing cone hides what of it lies inside.
//!
//! **Texture coordinates** as Mitsuba computes them from Embree's hit: v = (t + k) / N for the
//! hit's segment k of all N segments of the shape, t ∈ [0, 1] the point of the axis whose normal
//! plane meets the hit (so 0 and 1 on the start and end caps, linear along a cone's generator),
//! and u = atan2(n · e_rot, n · e_rad) / 2π ∈ [0, 1) in the segment's frame (`local_frame`:
//! e_rot the +z guide made perpendicular to the axis â, or +y when â is ±z; e_rad = e_rot × â).
//! A cap belongs to the segment it ends (Embree's cone-sphere), so u jumps at joints as
//! Mitsuba's does. The seam u = 0 is a column of vertices taken twice, at 0 and at 1.

use super::curved::Vertex;
use super::mesh::read_regular_file;
use super::transform::Xform;
use super::*;
use crate::error::Result;
use crate::scene::PrimAttrs;
use crate::scene::desc;
use glam::{DAffine3, DMat3, DVec2, DVec3};
use std::f64::consts::{FRAC_PI_2, TAU};

/// Segments around a curve.
const AROUND: u32 = 256;
/// Rings of latitude on a spherical cap.
const CAP_RINGS: u32 = 64;
/// About the largest ratio of a cone cell's length to its width, and the most rings along one.
const MAX_ASPECT: f64 = 16.0;
const MAX_CONE_RINGS: u32 = 128;
/// Enters the content hash of every scene with a linear curve (bump it when the tessellation
/// changes).
const CURVE_HASH_TAG: &[u8] = b"photon-bench linear curve tessellation v1";

/// A control point: the centre of a sphere (in the world) and its radius.
#[derive(Clone, Copy, Debug, PartialEq)]
struct ControlPoint {
    p: DVec3,
    r: f64,
}

/// Mitsuba's curve file: per line four numbers, a control point's x y z and radius; an empty
/// line starts a new curve; each curve has at least two control points. Returns the curves'
/// control points as written, or what is wrong (naming the line).
fn parse_curves(text: &str) -> std::result::Result<Vec<Vec<[f64; 4]>>, String> {
    let mut curves: Vec<Vec<[f64; 4]>> = vec![Vec::new()];
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() {
            if !curves.last().is_some_and(Vec::is_empty) {
                curves.push(Vec::new());
            }
            continue;
        }
        let numbers: Vec<f64> = line
            .split_whitespace()
            .map(str::parse::<f64>)
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| format!("line {}: expected four numbers (x y z radius), got {line:?}", i + 1))?;
        let [x, y, z, r] = numbers[..] else {
            return Err(format!(
                "line {}: expected four numbers (x y z radius), got {line:?}",
                i + 1
            ));
        };
        let inside = [x, y, z].iter().all(|c| c.is_finite() && c.abs() <= MAX_COORD) && r > 0.0 && r <= MAX_COORD;
        if !inside {
            return Err(format!(
                "line {}: expected coordinates within ±{} and a positive radius, got {line:?}",
                i + 1,
                num(MAX_COORD)
            ));
        }
        curves.last_mut().unwrap().push([x, y, z, r]);
    }
    curves.retain(|c| !c.is_empty());
    if curves.is_empty() {
        return Err("no control points".to_string());
    }
    if let Some(k) = curves.iter().position(|c| c.len() < 2) {
        return Err(format!(
            "curve {} has one control point; a linear curve needs at least two",
            k + 1
        ));
    }
    Ok(curves)
}

/// One segment between control points `a` and `b`: its axis frame and the cone's tilt.
struct Segment {
    a: ControlPoint,
    b: ControlPoint,
    /// â, e_rot, e_rad (module doc).
    axis: DVec3,
    e_rot: DVec3,
    e_rad: DVec3,
    /// sin α, cos α of the cone's tilt: its normals are cos α r̂ + sin α â.
    sin: f64,
    cos: f64,
}

impl Segment {
    fn new(a: ControlPoint, b: ControlPoint) -> Option<Self> {
        let d = b.p - a.p;
        let length = d.length();
        let sin = (a.r - b.r) / length;
        if !(length > 0.0 && sin.abs() < 1.0) {
            return None;
        }
        let axis = d / length;
        let (e_rot, e_rad) = local_frame(axis);
        Some(Self {
            a,
            b,
            axis,
            e_rot,
            e_rad,
            sin,
            cos: (1.0 - sin * sin).sqrt(),
        })
    }

    /// The unit direction around the axis at turn u ∈ [0, 1] (u = 0 along e_rad).
    fn around(&self, u: f64) -> DVec3 {
        let phi = TAU * u;
        phi.cos() * self.e_rad + phi.sin() * self.e_rot
    }

    /// Rings along the cone: cells about [`MAX_ASPECT`] times longer than wide.
    fn cone_rings(&self) -> u32 {
        let generator = ((self.b.p - self.a.p).length() * self.cos).max(0.0);
        let width = TAU * self.a.r.min(self.b.r) * self.cos / f64::from(AROUND);
        (generator / (MAX_ASPECT * width))
            .ceil()
            .clamp(1.0, f64::from(MAX_CONE_RINGS)) as u32
    }
}

/// Mitsuba's `LinearCurve::local_frame`: e_rot is the +z guide made perpendicular to â (+y when
/// â is ±z), e_rad = e_rot × â.
fn local_frame(axis: DVec3) -> (DVec3, DVec3) {
    let guide = DVec3::Z;
    let e_rot = if guide.dot(axis).abs() == 1.0 {
        DVec3::Y
    } else {
        (guide - axis * axis.dot(guide)).normalize()
    };
    (e_rot, e_rot.cross(axis))
}

impl Builder<'_> {
    /// A `linearcurve` file under the shape's transform (radii unchanged), tessellated.
    pub(super) fn linear_curve(
        &mut self,
        field: &str,
        c: &desc::LinearCurve,
        xf: &Xform,
        attrs: PrimAttrs,
    ) -> Result<()> {
        let ctx = self.ctx;
        let file_field = format!("{field}.file");
        let path = self.dir.join(&c.file);
        let shown = path.display().to_string();
        let bytes =
            read_regular_file(&path, "curve").map_err(|e| ctx.err(&file_field, format!("cannot read {shown}: {e}")))?;
        self.stats.files_read.push(path.clone());
        let text = String::from_utf8(bytes).map_err(|_| ctx.err(&file_field, format!("{shown}: not a text file")))?;
        let curves = parse_curves(&text).map_err(|e| ctx.err(&file_field, format!("{shown}: {e}")))?;
        let mut chains = Vec::with_capacity(curves.len());
        for curve in &curves {
            let mut segments = Vec::with_capacity(curve.len() - 1);
            for pair in curve.windows(2) {
                let [a, b] = [pair[0], pair[1]].map(|[x, y, z, r]| ControlPoint {
                    p: xf.point(DVec3::new(x, y, z)),
                    r,
                });
                let Some(s) = Segment::new(a, b) else {
                    return Err(ctx.err(
                        &file_field,
                        format!(
                            "{shown}: the control points at {} and {} (radii {}, {}) have no cone between them: one sphere holds the other",
                            triple(a.p.to_array()),
                            triple(b.p.to_array()),
                            num(a.r),
                            num(b.r)
                        ),
                    ));
                };
                segments.push(s);
            }
            chains.push(segments);
        }
        let count: u64 = chains
            .iter()
            .map(|segments| {
                let caps = segments.len() as u64 + 1;
                let cones: u64 = segments.iter().map(|s| u64::from(s.cone_rings())).sum();
                2 * u64::from(AROUND) * (cones + caps * u64::from(CAP_RINGS))
            })
            .sum();
        self.reserve_tessellation(field, count, CURVE_HASH_TAG)?;
        let total = chains.iter().map(Vec::len).sum::<usize>() as f64;
        let mut triangles = Vec::new();
        let mut k = 0.0;
        for segments in &chains {
            for (i, s) in segments.iter().enumerate() {
                if i == 0 {
                    triangles.extend(cap_triangles(s, false, k / total));
                }
                triangles.extend(cone_triangles(s, k, total));
                triangles.extend(cap_triangles(s, true, (k + 1.0) / total));
                k += 1.0;
            }
        }
        let world = Xform {
            m: DAffine3::IDENTITY,
            normal_matrix: DMat3::IDENTITY,
            flips: false,
        };
        self.tessellated(field, &world, triangles.into_iter(), attrs)
    }
}

/// The cone of segment `s`, the `k`-th of `total`: generators from the circle of contact with
/// the start sphere to the one with the end sphere, v = (t + k) / total with t from 0 to 1.
fn cone_triangles(s: &Segment, k: f64, total: f64) -> Vec<[Vertex; 3]> {
    let rings = s.cone_rings();
    let at = |j: u32, ring: u32| {
        let u = f64::from(j) / f64::from(AROUND);
        let t = f64::from(ring) / f64::from(rings);
        let n = s.cos * s.around(u) + s.sin * s.axis;
        let (start, end) = (s.a.p + s.a.r * n, s.b.p + s.b.r * n);
        Vertex {
            p: start.lerp(end, t),
            n,
            uv: DVec2::new(u, (t + k) / total),
        }
    };
    grid(AROUND, rings, at)
}

/// The cap of segment `s`'s end sphere beyond its cone (`end`), or of its start sphere before
/// it, at v = `v`: latitudes from the circle of contact (tilt α) to the pole (±90°).
fn cap_triangles(s: &Segment, end: bool, v: f64) -> Vec<[Vertex; 3]> {
    let (centre, r) = if end { (s.b.p, s.b.r) } else { (s.a.p, s.a.r) };
    let contact = s.sin.asin();
    let pole = if end { FRAC_PI_2 } else { -FRAC_PI_2 };
    let at = |j: u32, ring: u32| {
        let u = f64::from(j) / f64::from(AROUND);
        let lat = contact + (pole - contact) * f64::from(ring) / f64::from(CAP_RINGS);
        let n = if ring == CAP_RINGS {
            pole.signum() * s.axis
        } else {
            lat.cos() * s.around(u) + lat.sin() * s.axis
        };
        Vertex {
            p: centre + r * n,
            n,
            uv: DVec2::new(u, v),
        }
    };
    let mut triangles = grid(AROUND, CAP_RINGS, at);
    // The pole's ring collapses to a point: give each of its triangles the pole once, at the
    // triangle's middle turn, rather than a degenerate pair.
    let last = triangles.len() - 2 * AROUND as usize;
    triangles.truncate(last);
    for j in 0..AROUND {
        let (a, b) = (at(j, CAP_RINGS - 1), at(j + 1, CAP_RINGS - 1));
        let mut apex = at(j, CAP_RINGS);
        apex.uv.x = (f64::from(j) + 0.5) / f64::from(AROUND);
        triangles.push([a, b, apex]);
    }
    triangles
}

/// Two triangles per cell of a `columns` × `rows` grid of vertices `at(j, ring)`, j = 0 ..=
/// columns (the seam taken twice).
fn grid(columns: u32, rows: u32, at: impl Fn(u32, u32) -> Vertex) -> Vec<[Vertex; 3]> {
    let mut triangles = Vec::with_capacity(2 * (columns * rows) as usize);
    for ring in 0..rows {
        for j in 0..columns {
            let (a, b, c, d) = (at(j, ring), at(j + 1, ring), at(j + 1, ring + 1), at(j, ring + 1));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    triangles
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curve_files_are_read_as_mitsuba_writes_them() {
        let curves = parse_curves("-1 0 0 0.5\n 1 1 1 0.5\n\n\n-1 5 2 1\n-2 4 2 2\n4 1 2 5\n").unwrap();
        assert_eq!(curves.len(), 2);
        assert_eq!(curves[0], vec![[-1.0, 0.0, 0.0, 0.5], [1.0, 1.0, 1.0, 0.5]]);
        assert_eq!(curves[1].len(), 3);
        for (text, expect) in [
            ("1 2 3\n4 5 6 1\n", "line 1"),
            ("1 2 3 x\n", "line 1"),
            ("1 2 3 1\n", "one control point"),
            ("1 2 3 1\n4 5 6 0\n", "positive radius"),
            ("", "no control points"),
        ] {
            let e = parse_curves(text).unwrap_err();
            assert!(e.contains(expect), "{text:?}: {e}");
        }
    }

    /// Every vertex lies on the union's surface with its exact normal: on the cone, at distance
    /// r(t) along the normal from the axis point t; on a cap, on the sphere; the frame is
    /// Mitsuba's (u = 0 along e_rad, a quarter turn along e_rot).
    #[test]
    fn vertices_lie_on_the_tube_with_its_normals() {
        let a = ControlPoint {
            p: DVec3::new(0.0, 0.0, 0.0),
            r: 0.3,
        };
        let b = ControlPoint {
            p: DVec3::new(2.0, 1.0, 0.5),
            r: 0.1,
        };
        let s = Segment::new(a, b).unwrap();
        assert!((s.around(0.25) - s.e_rot).length() < 1e-12);
        assert!((s.e_rot.z > 0.0) && s.e_rot.dot(s.axis).abs() < 1e-12);
        for t in cone_triangles(&s, 2.0, 5.0).iter().flatten() {
            assert!((t.n.length() - 1.0).abs() < 1e-12);
            // p = c(t) + r(t) n with c(t), r(t) the axis point and radius at t = 5v − 2.
            let f = 5.0 * t.uv.y - 2.0;
            assert!((-1e-9..=1.0 + 1e-9).contains(&f), "{}", t.uv.y);
            let on_axis = t.p - (a.r + (b.r - a.r) * f) * t.n;
            assert!((on_axis - a.p.lerp(b.p, f)).length() < 1e-9, "{:?}", t.p);
            assert!(t.n.dot(s.axis) - s.sin < 1e-12);
        }
        for (end, centre, r) in [(true, b.p, b.r), (false, a.p, a.r)] {
            for t in cap_triangles(&s, end, 0.5).iter().flatten() {
                assert!(((t.p - centre).length() - r).abs() < 1e-12);
                assert!(((t.p - centre) / r - t.n).length() < 1e-12);
                // Caps lie beyond their circle of contact.
                let side = (t.n.dot(s.axis) - s.sin) * if end { 1.0 } else { -1.0 };
                assert!(side >= -1e-12, "{end}: {:?}", t.n);
            }
        }
    }
}
