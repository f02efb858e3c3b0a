//! Loop subdivision surfaces, pbrt-v4's `loopsubdiv` shape [Loop 1987; pbrt-v3 §3.8]: a
//! triangle mesh refined `levels` times by Loop's rules, its vertices then moved to their
//! limit positions, with the limit surface's normals.
//!
//! - Each level keeps every vertex (even) and adds one per edge (odd); each triangle becomes
//!   four with the same winding. An interior even vertex of valence n moves to
//!   (1 − nβ) v + β Σ ring, β = 3/16 for n = 3 and 3/(8n) otherwise; a boundary one to
//!   ¾ v + ⅛ (its two boundary neighbours). An interior odd vertex is ⅜ of each end of its edge
//!   plus ⅛ of each opposite vertex, a boundary one the edge's midpoint.
//! - The limit position of an interior vertex is (1 − nγ) v + γ Σ ring, γ = 1/(n + 3/(8β)), of a
//!   boundary one ⅗ v + ⅕ (its boundary neighbours).
//! - Normals are S × T of the limit tangents: interior S = Σ cos(2πj/n) p_j, T = Σ sin(2πj/n) p_j
//!   over the ring; boundary S = p_last − p_first and T by pbrt's valence-specific masks. The
//!   rings are ordered as pbrt orders them (an interior ring against the triangles' winding, a
//!   boundary ring with it), so the normals point where pbrt's do — which, with pbrt's rule that
//!   a mesh's normals decide its front, is the side opposite to the winding's.
//!
//! Meshes that are not 2-manifold with consistent winding (an edge in three triangles, a vertex
//! whose triangles do not form one fan) are refused: Loop's rules are undefined there.

use glam::DVec3;
use std::collections::HashMap;
use std::f64::consts::PI;

/// A refined mesh: positions, one normal per position, triangles.
pub struct Subdivided {
    pub positions: Vec<DVec3>,
    pub normals: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
}

/// The one-ring of a vertex: its neighbours in order, and whether it lies on the boundary.
struct Ring {
    neighbours: Vec<u32>,
    boundary: bool,
}

/// Loop-subdivides `triangles` over `positions` `levels` times and moves the result to the limit
/// surface; `Err` names the first vertex or edge where the mesh is not a manifold.
pub fn loop_subdivide(positions: &[DVec3], triangles: &[[u32; 3]], levels: u32) -> Result<Subdivided, String> {
    let (mut p, mut tris) = (positions.to_vec(), triangles.to_vec());
    for _ in 0..levels {
        (p, tris) = refine(&p, &tris)?;
    }
    let rings = rings(p.len(), &tris)?;
    let limit: Vec<DVec3> = rings
        .iter()
        .enumerate()
        .map(|(v, r)| limit_position(p[v], r, &p))
        .collect();
    let normals = rings
        .iter()
        .enumerate()
        .map(|(v, r)| limit_normal(limit[v], r, &limit))
        .collect();
    Ok(Subdivided {
        positions: limit,
        normals,
        triangles: tris,
    })
}

/// β of Loop's even-vertex rule for valence n.
fn beta(n: usize) -> f64 {
    if n == 3 { 3.0 / 16.0 } else { 3.0 / (8.0 * n as f64) }
}

/// (1 − n w) v + w Σ ring.
fn weigh_ring(v: DVec3, ring: &[u32], w: f64, p: &[DVec3]) -> DVec3 {
    let sum: DVec3 = ring.iter().map(|&j| p[j as usize]).sum();
    v * (1.0 - ring.len() as f64 * w) + sum * w
}

/// (1 − 2w) v + w (first + last neighbour).
fn weigh_boundary(v: DVec3, ring: &[u32], w: f64, p: &[DVec3]) -> DVec3 {
    let (a, b) = (
        p[ring[0] as usize],
        p[*ring.last().expect("a ring is never empty") as usize],
    );
    v * (1.0 - 2.0 * w) + (a + b) * w
}

fn limit_position(v: DVec3, r: &Ring, p: &[DVec3]) -> DVec3 {
    if r.boundary {
        weigh_boundary(v, &r.neighbours, 0.2, p)
    } else {
        let n = r.neighbours.len();
        weigh_ring(v, &r.neighbours, 1.0 / (n as f64 + 3.0 / (8.0 * beta(n))), p)
    }
}

fn limit_normal(v: DVec3, r: &Ring, p: &[DVec3]) -> DVec3 {
    let ring: Vec<DVec3> = r.neighbours.iter().map(|&j| p[j as usize]).collect();
    let n = ring.len();
    let (s, t) = if !r.boundary {
        ring.iter()
            .enumerate()
            .fold((DVec3::ZERO, DVec3::ZERO), |(s, t), (j, q)| {
                let a = 2.0 * PI * j as f64 / n as f64;
                (s + *q * a.cos(), t + *q * a.sin())
            })
    } else {
        let s = ring[n - 1] - ring[0];
        let t = match n {
            2 => ring[0] + ring[1] - 2.0 * v,
            3 => ring[1] - v,
            4 => -ring[0] + 2.0 * ring[1] + 2.0 * ring[2] - ring[3] - 2.0 * v,
            _ => {
                let theta = PI / (n - 1) as f64;
                let mut t = (ring[0] + ring[n - 1]) * theta.sin();
                for (k, q) in ring.iter().enumerate().take(n - 1).skip(1) {
                    t += *q * ((2.0 * theta.cos() - 2.0) * (k as f64 * theta).sin());
                }
                -t
            }
        };
        (s, t)
    };
    s.cross(t).normalize_or_zero()
}

/// Every vertex's one-ring. Around vertex v, a triangle (v, a, b) in its winding spans the fan
/// from a to b; the fan's triangles chain b → a of the next. pbrt walks an interior fan against
/// the winding and a boundary fan with it, from its first boundary neighbour.
fn rings(vertices: usize, tris: &[[u32; 3]]) -> Result<Vec<Ring>, String> {
    // Per vertex, the (a, b) spans of its triangles.
    let mut spans: Vec<Vec<(u32, u32)>> = vec![Vec::new(); vertices];
    for t in tris {
        for i in 0..3 {
            spans[t[i] as usize].push((t[(i + 1) % 3], t[(i + 2) % 3]));
        }
    }
    spans
        .iter()
        .enumerate()
        .map(|(v, fan)| {
            if fan.is_empty() {
                // A vertex no triangle uses: it stays where it is, facing nowhere.
                return Ok(Ring {
                    neighbours: vec![v as u32],
                    boundary: true,
                });
            }
            let next: HashMap<u32, u32> = fan.iter().copied().collect();
            let not_manifold = || format!("the mesh is not a manifold at vertex {v} (Loop subdivision needs one)");
            if next.len() != fan.len() {
                return Err(not_manifold());
            }
            let ends: std::collections::HashSet<u32> = fan.iter().map(|&(_, b)| b).collect();
            let starts: Vec<u32> = fan.iter().map(|&(a, _)| a).filter(|a| !ends.contains(a)).collect();
            let (start, boundary) = match starts[..] {
                [] => (fan[0].0, false),
                [s] => (s, true),
                _ => return Err(not_manifold()),
            };
            let mut ring = vec![start];
            let mut at = start;
            while let Some(&b) = next.get(&at) {
                if b == start {
                    break;
                }
                ring.push(b);
                at = b;
                if ring.len() > fan.len() + 1 {
                    return Err(not_manifold());
                }
            }
            if ring.len() != fan.len() + usize::from(boundary) {
                return Err(not_manifold());
            }
            if !boundary {
                ring.reverse();
            }
            Ok(Ring {
                neighbours: ring,
                boundary,
            })
        })
        .collect()
}

/// One level of Loop's refinement: even vertices moved, one odd vertex per edge, four
/// triangles per triangle.
fn refine(p: &[DVec3], tris: &[[u32; 3]]) -> Result<(Vec<DVec3>, Vec<[u32; 3]>), String> {
    let rings = rings(p.len(), tris)?;
    let mut out: Vec<DVec3> = rings
        .iter()
        .enumerate()
        .map(|(v, r)| match (r.boundary, r.neighbours.len()) {
            (true, _) if r.neighbours == [v as u32] => p[v],
            (true, _) => weigh_boundary(p[v], &r.neighbours, 0.125, p),
            (false, n) => weigh_ring(p[v], &r.neighbours, beta(n), p),
        })
        .collect();
    // Each edge's opposite vertices (one on a boundary, two inside).
    let mut opposite: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for t in tris {
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            opposite.entry((a.min(b), a.max(b))).or_default().push(t[(i + 2) % 3]);
        }
    }
    let mut odd: HashMap<(u32, u32), u32> = HashMap::with_capacity(opposite.len());
    let mut edges: Vec<_> = opposite.into_iter().collect();
    edges.sort_unstable_by_key(|(e, _)| *e);
    for ((a, b), others) in edges {
        let (pa, pb) = (p[a as usize], p[b as usize]);
        let q = match others[..] {
            [_] => (pa + pb) * 0.5,
            [c, d] => (pa + pb) * 0.375 + (p[c as usize] + p[d as usize]) * 0.125,
            _ => {
                return Err(format!(
                    "edge ({a}, {b}) lies in {} triangles (Loop subdivision needs at most two)",
                    others.len()
                ));
            }
        };
        odd.insert((a, b), out.len() as u32);
        out.push(q);
    }
    let mid = |a: u32, b: u32| odd[&(a.min(b), a.max(b))];
    let mut refined = Vec::with_capacity(4 * tris.len());
    for &[a, b, c] in tris {
        let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
        refined.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
    }
    Ok((out, refined))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A regular octahedron.
    fn octahedron() -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let p = vec![DVec3::X, -DVec3::X, DVec3::Y, -DVec3::Y, DVec3::Z, -DVec3::Z];
        let t = vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ];
        (p, t)
    }

    /// Counts and symmetry: V − E + F stays 2 for a closed mesh, every level quadruples the
    /// triangles; the octahedron's limit surface is symmetric, so every original vertex ends at
    /// the same distance from the centre and its normal points along its position (outward
    /// against the winding's front here: the triangles wind outward, pbrt's normals face in).
    #[test]
    fn a_closed_mesh_refines_symmetrically() {
        let (p, t) = octahedron();
        for levels in 0..4 {
            let s = loop_subdivide(&p, &t, levels).unwrap();
            let (v, f) = (s.positions.len(), s.triangles.len());
            assert_eq!(f, 8 * 4usize.pow(levels));
            assert_eq!(v + f - 3 * f / 2, 2, "Euler characteristic at level {levels}");
            let r0 = s.positions[0].length();
            for (i, q) in s.positions.iter().take(6).enumerate() {
                assert!((q.length() - r0).abs() < 1e-12, "vertex {i}: {q}");
                let n = s.normals[i];
                assert!((n.dot(q.normalize()) + 1.0).abs() < 1e-9, "vertex {i}: normal {n}");
            }
            // The winding's normal of the first triangle points out of the solid.
            let [a, b, c] = s.triangles[0].map(|i| s.positions[i as usize]);
            assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
        }
    }

    /// The limit surface is smooth where the control mesh is flat: a planar grid stays planar
    /// (interior and boundary masks are affine), with normals perpendicular to it; refining
    /// once, then taking the limit, gives the same limit points as taking the limit of the
    /// same vertices after more levels (the limit is the surface, not a level's mesh).
    #[test]
    fn a_flat_grid_stays_flat_and_limits_agree_across_levels() {
        let n = 4u32;
        let p: Vec<DVec3> = (0..=n)
            .flat_map(|j| (0..=n).map(move |i| DVec3::new(i as f64, j as f64, 0.0)))
            .collect();
        let id = |i: u32, j: u32| j * (n + 1) + i;
        let t: Vec<[u32; 3]> = (0..n)
            .flat_map(|j| {
                (0..n).flat_map(move |i| {
                    [
                        [id(i, j), id(i + 1, j), id(i + 1, j + 1)],
                        [id(i, j), id(i + 1, j + 1), id(i, j + 1)],
                    ]
                })
            })
            .collect();
        let s1 = loop_subdivide(&p, &t, 1).unwrap();
        for (q, nrm) in s1.positions.iter().zip(&s1.normals) {
            assert!(q.z.abs() < 1e-12 && (nrm.z.abs() - 1.0).abs() < 1e-9, "{q} {nrm}");
        }
        // Interior original vertices: the limit of level 1 and of level 3 coincide.
        let s3 = loop_subdivide(&p, &t, 3).unwrap();
        for v in [id(1, 1), id(2, 2), id(3, 1)] {
            let (a, b) = (s1.positions[v as usize], s3.positions[v as usize]);
            assert!((a - b).length() < 1e-12, "{v}: {a} vs {b}");
        }
    }

    /// A curved closed mesh: the limit positions of level 1 and level 3 agree at the original
    /// vertices (both are points of the same limit surface).
    #[test]
    fn limit_positions_do_not_depend_on_the_level() {
        let (mut p, t) = octahedron();
        p[4] *= 2.0;
        let (a, b) = (loop_subdivide(&p, &t, 1).unwrap(), loop_subdivide(&p, &t, 4).unwrap());
        for v in 0..6 {
            assert!((a.positions[v] - b.positions[v]).length() < 1e-9, "{v}");
        }
    }

    #[test]
    fn non_manifold_meshes_are_refused() {
        let p = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, -DVec3::Z];
        // Three triangles on the edge (0, 1).
        let t = [[0, 1, 2], [1, 0, 3], [0, 1, 4]];
        assert!(loop_subdivide(&p, &t, 1).is_err());
        // Two fans meeting at vertex 0 only (a bow tie).
        let p = vec![DVec3::ZERO, DVec3::X, DVec3::Y, -DVec3::X, -DVec3::Y];
        let t = [[0, 1, 2], [0, 3, 4]];
        assert!(loop_subdivide(&p, &t, 1).err().unwrap().contains("vertex 0"));
    }
}
