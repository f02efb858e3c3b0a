//! Shape transforms (translate, rotate, scale, matrices) validated and applied in f64, and the
//! frames of quads.

use super::*;
use crate::error::Result;
use crate::scene::desc::{self, Scale, TransformDesc};
use glam::{DAffine3, DMat3, DVec3};

/// An affine map from shape space to world space.
#[derive(Clone, Copy, Debug)]
pub(super) struct Xform {
    pub(super) m: DAffine3,
    /// Inverse transpose of the linear part: maps normals.
    pub(super) normal_matrix: DMat3,
    /// The map mirrors: triangle windings must be reversed to keep their front side.
    pub(super) flips: bool,
}

impl Xform {
    pub(super) fn point(&self, p: DVec3) -> DVec3 {
        self.m.transform_point3(p)
    }

    /// This map applied after `local` (an invertible affine map into this one's shape space):
    /// how a shape with its own frame (a cylinder's axis) is placed.
    pub(super) fn after(&self, local: DAffine3) -> Xform {
        let m = self.m * local;
        Xform {
            m,
            normal_matrix: m.matrix3.inverse().transpose(),
            flips: m.matrix3.determinant() < 0.0,
        }
    }
}

/// Composes a transform description into one affine map, refusing non-finite, non-affine and
/// degenerate ones.
pub(super) fn transform(ctx: &Ctx, field: &str, t: Option<&TransformDesc>) -> Result<Xform> {
    let steps = t.map_or(&[][..], |t| &t.0[..]);
    let mut m = DAffine3::IDENTITY;
    for (j, step) in steps.iter().enumerate() {
        let field = if steps.len() == 1 {
            format!("{field}.transform")
        } else {
            format!("{field}.transform[{j}]")
        };
        let step_m = if let Some(rows) = step.matrix {
            let others = step.scale.is_some()
                || step.rotate_x.is_some()
                || step.rotate_y.is_some()
                || step.rotate_z.is_some()
                || step.translate.is_some();
            if others {
                return Err(ctx.err(
                    &field,
                    "`matrix` cannot share a step with scale/rotate/translate; use a list of \
                     steps, e.g. [{ matrix = … }, { translate = … }]",
                ));
            }
            if !rows.iter().flat_map(|r| r.iter()).all(|&x| is_coord(x)) {
                return Err(ctx.err(
                    &format!("{field}.matrix"),
                    format!("expected finite entries of magnitude at most {}", num(MAX_COORD)),
                ));
            }
            if rows[3].0 != [0.0, 0.0, 0.0, 1.0] {
                return Err(ctx.err(
                    &format!("{field}.matrix"),
                    "the last row must be [0, 0, 0, 1] (affine transforms only)",
                ));
            }
            let col = |j: usize| DVec3::new(rows[0][j], rows[1][j], rows[2][j]);
            DAffine3::from_mat3_translation(DMat3::from_cols(col(0), col(1), col(2)), col(3))
        } else {
            let s = match step.scale {
                None => DVec3::ONE,
                Some(Scale::Uniform(s)) => DVec3::splat(s),
                Some(Scale::PerAxis(s)) => dvec(s),
            };
            if !s.to_array().iter().all(|&c| c != 0.0 && is_coord(c)) {
                return Err(ctx.err(
                    &format!("{field}.scale"),
                    format!("expected non-zero finite factors, got {}", triple(s.to_array())),
                ));
            }
            let mut r = DMat3::IDENTITY;
            for (key, angle, rot) in [
                ("rotate_x", step.rotate_x, DMat3::from_rotation_x as fn(f64) -> DMat3),
                ("rotate_y", step.rotate_y, DMat3::from_rotation_y),
                ("rotate_z", step.rotate_z, DMat3::from_rotation_z),
            ] {
                if let Some(deg) = angle {
                    if !is_coord(deg) {
                        return Err(ctx.err(
                            &format!("{field}.{key}"),
                            format!("expected a finite angle in degrees, got {}", num(deg)),
                        ));
                    }
                    r = rot(deg.to_radians()) * r;
                }
            }
            let tr = match step.translate {
                Some(tr) => ctx.coords(&format!("{field}.translate"), tr)?,
                None => DVec3::ZERO,
            };
            DAffine3::from_mat3_translation(r * DMat3::from_diagonal(s), tr)
        };
        m = step_m * m;
    }
    let l = m.matrix3;
    let det = l.determinant();
    let stretch = l.x_axis.length().max(l.y_axis.length()).max(l.z_axis.length());
    let field = format!("{field}.transform");
    if !(det.is_finite() && det.abs() > 1e-12 * stretch.powi(3)) {
        return Err(ctx.err(
            &field,
            format!("degenerate transform (determinant {}): it flattens shapes", approx(det)),
        ));
    }
    if !m.translation.to_array().iter().all(|&c| is_coord(c)) {
        return Err(ctx.err(
            &field,
            format!(
                "the composed translation {} exceeds magnitude {}",
                triple(m.translation.to_array()),
                num(MAX_COORD)
            ),
        ));
    }
    Ok(Xform {
        m,
        normal_matrix: l.inverse().transpose(),
        flips: det < 0.0,
    })
}

/// The corner and edges of a quad from either of its two forms.
pub(super) fn quad_frame(ctx: &Ctx, field: &str, q: &desc::Quad) -> Result<(DVec3, DVec3, DVec3)> {
    let f = |k: &str| format!("{field}.{k}");
    let (corner, u, v) = match (q.corner, q.edge_u, q.edge_v, q.center, q.size, &q.facing) {
        (Some(c), Some(u), Some(v), None, None, None) => (
            ctx.coords(&f("corner"), c)?,
            ctx.coords(&f("edge_u"), u)?,
            ctx.coords(&f("edge_v"), v)?,
        ),
        (None, None, None, Some(c), Some(size), facing) => {
            let c = ctx.coords(&f("center"), c)?;
            let [a, b] = ctx.sizes(&f("size"), size.0)?;
            let facing = facing.as_deref().unwrap_or("+y");
            let (n, ea, eb) = match facing {
                "+x" | "-x" => (DVec3::X, DVec3::Y, DVec3::Z),
                "+y" | "-y" => (DVec3::Y, DVec3::X, DVec3::Z),
                "+z" | "-z" => (DVec3::Z, DVec3::X, DVec3::Y),
                other => {
                    return Err(ctx.err(
                        &f("facing"),
                        format!(
                            "expected one of \"+x\", \"-x\", \"+y\", \"-y\", \"+z\", \"-z\", \
                             got {other:?}"
                        ),
                    ));
                }
            };
            let n = if facing.starts_with('-') { -n } else { n };
            let (ea, eb) = (a * ea, b * eb);
            // Order the edges so that edge_u × edge_v points along the facing axis.
            let (u, v) = if ea.cross(eb).dot(n) > 0.0 { (ea, eb) } else { (eb, ea) };
            (c - 0.5 * (u + v), u, v)
        }
        _ => {
            return Err(ctx.err(
                field,
                "a quad needs either `corner`, `edge_u` and `edge_v`, or `center` and `size` \
                 (with an optional `facing`)",
            ));
        }
    };
    if u.cross(v).length() <= 1e-9 * u.length() * v.length() {
        return Err(ctx.err(
            field,
            format!(
                "zero-area quad: edge_u {} and edge_v {} are parallel or zero",
                triple(u.to_array()),
                triple(v.to_array())
            ),
        ));
    }
    Ok((corner, u, v))
}
