//! User paths of the UP proposal [Fan et al. 2005, §4.1]: points, cone angles, and the check
//! that each path starts on a light.

use super::*;
use crate::error::Result;
use crate::geometry::Primitive;
use crate::scene::desc::{self, ConeDeg};
use crate::scene::{PrimAttrs, UserPath};
use glam::{DVec3, Vec3};

pub(super) fn user_paths(
    ctx: &Ctx,
    descs: &[desc::UserPathDesc],
    primitives: &[Primitive],
    attrs: &[PrimAttrs],
) -> Result<Vec<UserPath>> {
    if descs.is_empty() {
        return Ok(Vec::new());
    }
    let (lo, hi) = primitives
        .iter()
        .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), p| {
            let (a, b) = p.aabb_min_max();
            (lo.min(a), hi.max(b))
        });
    let tolerance = USER_PATH_LIGHT_TOLERANCE * (hi - lo).as_dvec3().length();
    let mut out = Vec::with_capacity(descs.len());
    for (i, d) in descs.iter().enumerate() {
        let field = format!("user_paths[{i}]");
        if d.points.len() < 2 {
            return Err(ctx.err(
                &format!("{field}.points"),
                format!(
                    "expected at least 2 points (a light point, then surface points), got {}",
                    d.points.len()
                ),
            ));
        }
        let mut points = Vec::with_capacity(d.points.len());
        for (j, &p) in d.points.iter().enumerate() {
            points.push(ctx.coords(&format!("{field}.points[{j}]"), p)?);
        }
        let segments = points.len() - 1;
        let cones = match &d.cone_deg {
            ConeDeg::All(c) => vec![*c; segments],
            ConeDeg::PerSegment(c) if c.len() == segments => c.clone(),
            ConeDeg::PerSegment(c) => {
                return Err(ctx.err(
                    &format!("{field}.cone_deg"),
                    format!("expected one angle or one per segment ({segments}), got {}", c.len()),
                ));
            }
        };
        if let Some(&bad) = cones.iter().find(|&&c| !(c > 0.0 && c <= 90.0)) {
            return Err(ctx.err(
                &format!("{field}.cone_deg"),
                format!("expected cone half-angles in (0, 90] degrees, got {}", num(bad)),
            ));
        }
        let dist = primitives
            .iter()
            .zip(attrs)
            .filter(|(_, a)| a.emission.is_some_and(|e| e.le.max_element() > 0.0))
            .map(|(p, _)| distance_to(p, points[0]))
            .fold(f64::INFINITY, f64::min);
        if dist.is_nan() || dist > tolerance {
            return Err(ctx.err(
                &format!("{field}.points[0]"),
                format!(
                    "must lie on an emissive surface: {} is {} from the nearest light (tolerance {})",
                    triple(points[0].to_array()),
                    approx(dist),
                    approx(tolerance)
                ),
            ));
        }
        out.push(UserPath {
            points: points.iter().map(|p| p.as_vec3()).collect(),
            cone_deg: cones.iter().map(|&c| c as f32).collect(),
        });
    }
    Ok(out)
}

/// Distance from `p` to the surface of a primitive.
pub(super) fn distance_to(prim: &Primitive, p: DVec3) -> f64 {
    match *prim {
        Primitive::Triangle([a, b, c]) => {
            let q = closest_point_on_triangle(p, a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
            (p - q).length()
        }
        Primitive::Sphere { center, radius } => ((p - center.as_dvec3()).length() - radius as f64).abs(),
    }
}

/// Closest point to `p` on triangle abc, by the Voronoi regions of its vertices, edges and
/// face [Ericson 2005, Real-Time Collision Detection, §5.1.5].
pub(super) fn closest_point_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}
