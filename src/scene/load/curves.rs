//! Mitsuba 3's `linearcurve` ([`desc::Curves`]) as triangles.
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
/// Enters the content hash of every scene with a curve (bump it when a tessellation changes).
const CURVE_HASH_TAG: &[u8] = b"photon-bench curve tessellation v1";

/// A control point: the centre of a sphere (in the world) and its radius.
#[derive(Clone, Copy, Debug, PartialEq)]
struct ControlPoint {
    p: DVec3,
    r: f64,
}

/// Mitsuba's curve file: per line four numbers, a control point's x y z and radius; an empty
/// line starts a new curve; each curve has at least `least` control points (2 for linear
/// curves, 4 for B-splines). Returns the curves' control points as written, or what is wrong
/// (naming the line).
fn parse_curves(text: &str, least: usize) -> std::result::Result<Vec<Vec<[f64; 4]>>, String> {
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
    if let Some(k) = curves.iter().position(|c| c.len() < least) {
        return Err(format!(
            "curve {} has {} control point(s); this kind of curve needs at least {least}",
            k + 1,
            curves[k].len()
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
    pub(super) fn linear_curve(&mut self, field: &str, c: &desc::Curves, xf: &Xform, attrs: PrimAttrs) -> Result<()> {
        let ctx = self.ctx;
        let file_field = format!("{field}.file");
        let (curves, shown) = self.curve_file(&file_field, c, xf, 2)?;
        let mut chains = Vec::with_capacity(curves.len());
        for curve in &curves {
            let mut segments = Vec::with_capacity(curve.len() - 1);
            for pair in curve.windows(2) {
                let (a, b) = (pair[0], pair[1]);
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
        self.tessellated(field, &WORLD, triangles.into_iter(), attrs)
    }

    /// The curves of `c`'s file (each with at least `least` control points), their points moved
    /// by `xf` (their radii not), and the file's name as shown in messages.
    fn curve_file(
        &mut self,
        file_field: &str,
        c: &desc::Curves,
        xf: &Xform,
        least: usize,
    ) -> Result<(Vec<Vec<ControlPoint>>, String)> {
        let ctx = self.ctx;
        let path = self.dir.join(&c.file);
        let shown = path.display().to_string();
        let bytes =
            read_regular_file(&path, "curve").map_err(|e| ctx.err(file_field, format!("cannot read {shown}: {e}")))?;
        self.stats.files_read.push(path.clone());
        let text = String::from_utf8(bytes).map_err(|_| ctx.err(file_field, format!("{shown}: not a text file")))?;
        let curves = parse_curves(&text, least).map_err(|e| ctx.err(file_field, format!("{shown}: {e}")))?;
        let world = |&[x, y, z, r]: &[f64; 4]| ControlPoint {
            p: xf.point(DVec3::new(x, y, z)),
            r,
        };
        Ok((curves.iter().map(|c| c.iter().map(world).collect()).collect(), shown))
    }

    /// A `bsplinecurve` file under the shape's transform (radii unchanged), tessellated as open
    /// tubes whose back faces let rays through ([`PrimAttrs::cull_back`]).
    pub(super) fn bspline_curve(&mut self, field: &str, c: &desc::Curves, xf: &Xform, attrs: PrimAttrs) -> Result<()> {
        let (curves, _) = self.curve_file(&format!("{field}.file"), c, xf, 4)?;
        let segments: Vec<Bspline> = curves
            .iter()
            .flat_map(|curve| curve.windows(4).map(|w| Bspline([w[0], w[1], w[2], w[3]])))
            .collect();
        let rings: Vec<u32> = segments.iter().map(Bspline::rings).collect();
        let count: u64 = rings.iter().map(|&r| 2 * u64::from(AROUND) * u64::from(r)).sum();
        self.reserve_tessellation(field, count, CURVE_HASH_TAG)?;
        let total = segments.len() as f64;
        let triangles: Vec<[Vertex; 3]> = segments
            .iter()
            .zip(&rings)
            .enumerate()
            .flat_map(|(k, (s, &r))| s.tube_triangles(r, k as f64, total))
            .collect();
        let attrs = PrimAttrs {
            cull_back: true,
            ..attrs
        };
        self.tessellated(field, &WORLD, triangles.into_iter(), attrs)
    }
}

/// The identity: curves are tessellated in the world.
const WORLD: Xform = Xform {
    m: DAffine3::IDENTITY,
    normal_matrix: DMat3::IDENTITY,
    flips: false,
};

/// The most rings along one B-spline segment.
const MAX_SPLINE_RINGS: u32 = 1024;

/// One segment of a uniform cubic B-spline: four control points in the world.
struct Bspline([ControlPoint; 4]);

/// The centre line and radius of a [`Bspline`] segment at t, with derivatives.
struct SplinePoint {
    c: DVec3,
    dc: DVec3,
    ddc: DVec3,
    r: f64,
    dr: f64,
}

impl Bspline {
    /// c(t) = [(1 − t)³ P₀ + (3t³ − 6t² + 4) P₁ + (−3t³ + 3t² + 3t + 1) P₂ + t³ P₃] / 6 and the
    /// same for the radius (Mitsuba's `cubic_interpolation`), with first and second derivatives.
    fn at(&self, t: f64) -> SplinePoint {
        let (t2, t3) = (t * t, t * t * t);
        let b = [
            (1.0 - t).powi(3),
            3.0 * t3 - 6.0 * t2 + 4.0,
            -3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0,
            t3,
        ];
        let db = [
            -3.0 * (1.0 - t).powi(2),
            9.0 * t2 - 12.0 * t,
            -9.0 * t2 + 6.0 * t + 3.0,
            3.0 * t2,
        ];
        let ddb = [6.0 * (1.0 - t), 18.0 * t - 12.0, -18.0 * t + 6.0, 6.0 * t];
        let point = |w: [f64; 4]| self.0.iter().zip(w).fold(DVec3::ZERO, |acc, (q, w)| acc + w * q.p) / 6.0;
        let radius = |w: [f64; 4]| self.0.iter().zip(w).map(|(q, w)| w * q.r).sum::<f64>() / 6.0;
        SplinePoint {
            c: point(b),
            dc: point(db),
            ddc: point(ddb),
            r: radius(b),
            dr: radius(db),
        }
    }

    /// Rings along the segment: cells about [`MAX_ASPECT`] times longer than wide, and the
    /// tangent turning at most π/128 from ring to ring (measured over 256 steps).
    fn rings(&self) -> u32 {
        const STEPS: u32 = 256;
        let (mut length, mut turn, mut r_min) = (0.0, 0.0, f64::INFINITY);
        let mut prev = self.at(0.0);
        for i in 1..=STEPS {
            let next = self.at(f64::from(i) / f64::from(STEPS));
            length += (next.c - prev.c).length();
            turn += next.dc.angle_between(prev.dc);
            r_min = r_min.min(next.r.abs());
            prev = next;
        }
        let width = TAU * r_min.max(1e-9) / f64::from(AROUND);
        let by_length = length / (MAX_ASPECT * width);
        let by_turn = turn / (std::f64::consts::PI / 128.0);
        by_length.max(by_turn).ceil().clamp(1.0, f64::from(MAX_SPLINE_RINGS)) as u32
    }

    /// The open tube of the segment, the `k`-th of `total`: at t, the circle of radius r(t)
    /// about c(t) in the plane normal to c'(t), from Mitsuba's `local_frame` (u = 0 along e_rad);
    /// the normal Mitsuba's, (|c'|² − ρ · c'') ρ − r r' c' for ρ the point's offset from c(t).
    fn tube_triangles(&self, rings: u32, k: f64, total: f64) -> Vec<[Vertex; 3]> {
        let frames: Vec<(SplinePoint, DVec3, DVec3)> = (0..=rings)
            .map(|i| {
                let s = self.at(f64::from(i) / f64::from(rings));
                let (e_rot, e_rad) = local_frame(s.dc.normalize());
                (s, e_rot, e_rad)
            })
            .collect();
        let at = |j: u32, ring: u32| {
            let (s, e_rot, e_rad) = &frames[ring as usize];
            let u = f64::from(j) / f64::from(AROUND);
            let phi = TAU * u;
            let rho = s.r * (phi.cos() * *e_rad + phi.sin() * *e_rot);
            let n = ((s.dc.length_squared() - rho.dot(s.ddc)) * rho - s.r * s.dr * s.dc).normalize();
            Vertex {
                p: s.c + rho,
                n,
                uv: DVec2::new(u, (f64::from(ring) / f64::from(rings) + k) / total),
            }
        };
        grid(AROUND, rings, at)
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
        let curves = parse_curves("-1 0 0 0.5\n 1 1 1 0.5\n\n\n-1 5 2 1\n-2 4 2 2\n4 1 2 5\n", 2).unwrap();
        assert!(
            parse_curves("-1 0 0 0.5\n 1 1 1 0.5\n2 2 2 1\n", 4)
                .unwrap_err()
                .contains("at least 4")
        );
        assert_eq!(curves.len(), 2);
        assert_eq!(curves[0], vec![[-1.0, 0.0, 0.0, 0.5], [1.0, 1.0, 1.0, 0.5]]);
        assert_eq!(curves[1].len(), 3);
        for (text, expect) in [
            ("1 2 3\n4 5 6 1\n", "line 1"),
            ("1 2 3 x\n", "line 1"),
            ("1 2 3 1\n", "at least 2"),
            ("1 2 3 1\n4 5 6 0\n", "positive radius"),
            ("", "no control points"),
        ] {
            let e = parse_curves(text, 2).unwrap_err();
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

    /// A bent B-spline segment whose radius changes: every vertex lies on the circle of radius
    /// r(t) about c(t) in the plane normal to c'(t) (t read back from v), and its normal is
    /// perpendicular to the surface along both parameters (finite differences of the sweep).
    #[test]
    fn bspline_vertices_lie_on_the_sweep_with_its_normals() {
        let s = Bspline(
            [
                [0.0, 0.0, 0.0, 0.05],
                [1.0, 0.5, 0.2, 0.1],
                [1.5, -0.5, 0.8, 0.15],
                [2.5, 0.0, 1.0, 0.08],
            ]
            .map(|[x, y, z, r]| ControlPoint {
                p: DVec3::new(x, y, z),
                r,
            }),
        );
        let rings = s.rings();
        assert!(rings > 16, "{rings}");
        let sweep = |t: f64, phi: f64| {
            let q = s.at(t);
            let (e_rot, e_rad) = local_frame(q.dc.normalize());
            q.c + q.r * (phi.cos() * e_rad + phi.sin() * e_rot)
        };
        for v in s.tube_triangles(rings, 3.0, 7.0).iter().flatten() {
            let t = 7.0 * v.uv.y - 3.0;
            let q = s.at(t);
            let rho = v.p - q.c;
            assert!((rho.length() - q.r).abs() < 1e-9 && rho.dot(q.dc).abs() < 1e-9 * q.dc.length());
            let phi = TAU * v.uv.x;
            assert!((sweep(t, phi) - v.p).length() < 1e-9);
            let h = 1e-5;
            for tangent in [
                sweep((t + h).min(1.0), phi) - sweep((t - h).max(0.0), phi),
                sweep(t, phi + h) - sweep(t, phi - h),
            ] {
                assert!(v.n.dot(tangent.normalize()).abs() < 1e-4, "n {} along {}", v.n, tangent);
            }
        }
    }
}
