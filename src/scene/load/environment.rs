//! The scene's light from infinitely far away: a constant radiance or an environment image,
//! checked (finite non-negative radiance, a rotation for its frame) and its file hashed.

use super::mesh::read_regular_file;
use super::*;
use crate::error::Result;
use crate::light::environment::{EnvMap, Environment, Radiance};
use crate::light::equal_area::EqualAreaMap;
use crate::scene::desc::EnvironmentDesc;
use crate::texture::decode_image;
use glam::{DMat3, Mat3};

/// Builds the environment; `hashed` and `files_read` receive the image file.
pub(super) fn environment(
    ctx: &Ctx,
    dir: &std::path::Path,
    e: &EnvironmentDesc,
    hashed: &mut Vec<Vec<u8>>,
    files_read: &mut Vec<std::path::PathBuf>,
) -> Result<Environment> {
    match e {
        EnvironmentDesc::Constant(c) => {
            if !c.radiance.iter().all(|&x| (0.0..=MAX_RADIANCE).contains(&x)) {
                return Err(ctx.err(
                    "environment.radiance",
                    format!(
                        "expected each channel finite in [0, {}], got {}",
                        num(MAX_RADIANCE),
                        triple(c.radiance)
                    ),
                ));
            }
            Ok(Environment::constant(rgb(c.radiance)))
        }
        EnvironmentDesc::Envmap(m) => {
            let scale = m.scale.unwrap_or(1.0);
            if !(scale.is_finite() && (0.0..=MAX_RADIANCE).contains(&scale)) {
                return Err(ctx.err(
                    "environment.scale",
                    format!("expected a number in [0, {}], got {}", num(MAX_RADIANCE), num(scale)),
                ));
            }
            let xf = transform(ctx, "environment", m.transform.as_ref())?;
            let linear = xf.m.matrix3;
            if (linear.transpose() * linear - DMat3::IDENTITY)
                .to_cols_array()
                .iter()
                .any(|x| x.abs() > 1e-4)
            {
                return Err(ctx.err(
                    "environment.transform",
                    "expected a rotation (the map's directions turn; translation is ignored, scaling is not allowed)",
                ));
            }
            let path = dir.join(&m.file);
            let shown = path.display().to_string();
            let bytes = read_regular_file(&path, "environment map")
                .map_err(|e| ctx.err("environment.file", format!("cannot read {shown}: {e}")))?;
            let (w, h, texels) =
                decode_image(&bytes, false).map_err(|e| ctx.err("environment.file", format!("{shown}: {e}")))?;
            if let Some(bad) = texels.iter().position(|t| !t.is_finite() || t.min_element() < 0.0) {
                return Err(ctx.err(
                    "environment.file",
                    format!(
                        "{shown}: texel {} is negative or not finite (radiance must be >= 0)",
                        bad
                    ),
                ));
            }
            let radiance = match m.mapping.as_deref() {
                None | Some("latlong") => {
                    if h < 2 {
                        return Err(ctx.err(
                            "environment.file",
                            format!("{shown}: expected at least 2 rows of texels, got {h}"),
                        ));
                    }
                    Radiance::Map(
                        EnvMap::new(w, h, texels.into())
                            .ok_or_else(|| ctx.err("environment.file", format!("{shown}: every texel is black")))?,
                    )
                }
                Some("equal_area") => {
                    if w != h {
                        return Err(ctx.err(
                            "environment.file",
                            format!("{shown}: an equal-area map is square, got {w} × {h} texels"),
                        ));
                    }
                    Radiance::EqualArea(
                        EqualAreaMap::new(w, h, texels.into())
                            .ok_or_else(|| ctx.err("environment.file", format!("{shown}: every texel is black")))?,
                    )
                }
                Some(other) => {
                    return Err(ctx.err(
                        "environment.mapping",
                        format!("expected \"latlong\" or \"equal_area\", got {other:?}"),
                    ));
                }
            };
            hashed.push(bytes);
            files_read.push(path);
            let local_to_world: Mat3 = linear.as_mat3();
            Ok(Environment::of(radiance, local_to_world, scale as f32))
        }
    }
}
