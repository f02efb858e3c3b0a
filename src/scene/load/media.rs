//! Participating media (`[media.NAME]`): checked, their grid files read and hashed, and the
//! names shapes and the camera refer to turned into indices.

use super::mesh::read_regular_file;
use super::*;
use crate::error::Result;
use crate::medium::grid::GridVolume;
use crate::medium::phase::Phase;
use crate::medium::{Albedo, Density, Medium};
use crate::scene::desc::{self, Fixed, GridDesc, MediumDesc, PhaseDesc};
use crate::texture::{Filter, Wrap};
use std::collections::BTreeMap;

/// The largest extinction accepted, per scene unit: beyond it a medium is a surface in all but
/// name, and e^{−σ t} underflows after a few ULPs of distance.
const MAX_SIGMA_T: f64 = 1e7;

/// Builds every medium in name order; returns them with the name → index map. `hashed` and
/// `files_read` receive the grid files.
pub(super) fn media(
    ctx: &Ctx,
    dir: &std::path::Path,
    descs: &BTreeMap<String, MediumDesc>,
    hashed: &mut Vec<Vec<u8>>,
    files_read: &mut Vec<std::path::PathBuf>,
) -> Result<(Vec<Medium>, BTreeMap<String, u32>)> {
    let mut out = Vec::with_capacity(descs.len());
    let mut index = BTreeMap::new();
    for (name, d) in descs {
        let field = format!("media.{}", key_string(name));
        let f = |key: &str| format!("{field}.{key}");
        let d = Common::of(d);
        let sigma_t = d.sigma_t;
        if !sigma_t.iter().all(|&s| (0.0..=MAX_SIGMA_T).contains(&s)) {
            return Err(ctx.err(
                &f("sigma_t"),
                format!(
                    "expected each channel in [0, {}], got {}",
                    num(MAX_SIGMA_T),
                    triple(Fixed(sigma_t))
                ),
            ));
        }
        let scale = d.scale.unwrap_or(1.0);
        if !(scale > 0.0 && scale.is_finite() && sigma_t.iter().all(|s| s * scale <= MAX_SIGMA_T)) {
            return Err(ctx.err(
                &f("scale"),
                format!(
                    "expected a positive number keeping sigma_t within {}, got {}",
                    num(MAX_SIGMA_T),
                    num(scale)
                ),
            ));
        }
        let albedo = match (&d.albedo, &d.albedo_grid) {
            (Some(_), Some(_)) => {
                return Err(ctx.err(&field, "expected `albedo` or `albedo_grid`, not both"));
            }
            (_, Some(g)) => Albedo::Grid(grid(
                ctx,
                dir,
                &f("albedo_grid"),
                g,
                (1.0, "albedos"),
                (hashed, files_read),
            )?),
            (a, None) => {
                let a = a.map_or([0.75; 3], |a| a.0);
                ctx.unit_rgb(&f("albedo"), Fixed(a))?;
                Albedo::Constant(rgb(Fixed(a)))
            }
        };
        let phase = match d.phase {
            None | Some(PhaseDesc::Isotropic(_)) => Phase::Isotropic,
            Some(PhaseDesc::Hg(hg)) => {
                if !(hg.g > -1.0 && hg.g < 1.0) {
                    return Err(ctx.err(
                        &f("phase.g"),
                        format!("expected a number in (-1, 1), got {}", num(hg.g)),
                    ));
                }
                Phase::HenyeyGreenstein { g: hg.g as f32 }
            }
        };
        let density = match d.density {
            Some(g) => {
                let limit = (MAX_SIGMA_T / scale) as f32;
                let grid = grid(
                    ctx,
                    dir,
                    &f("sigma_t_grid"),
                    g,
                    (limit, "extinctions"),
                    (hashed, files_read),
                )?;
                Some(Density::new(grid, scale as f32))
            }
            None => None,
        };
        index.insert(name.clone(), out.len() as u32);
        out.push(Medium {
            name: name.clone(),
            sigma_t: rgb(Fixed(sigma_t.map(|s| s * scale))),
            density,
            albedo,
            phase,
            sample_emitters: d.sample_emitters.unwrap_or(true),
        });
    }
    Ok((out, index))
}

/// What both kinds of media share, read off either description.
struct Common<'a> {
    /// A homogeneous medium's σ_t (a heterogeneous one's is `density`).
    sigma_t: [f64; 3],
    density: Option<&'a GridDesc>,
    scale: Option<f64>,
    albedo: Option<desc::Triple>,
    albedo_grid: &'a Option<GridDesc>,
    phase: Option<PhaseDesc>,
    sample_emitters: Option<bool>,
}

impl<'a> Common<'a> {
    fn of(d: &'a MediumDesc) -> Self {
        match d {
            MediumDesc::Homogeneous(h) => Common {
                sigma_t: h.sigma_t.map_or([1.0; 3], |t| t.0),
                density: None,
                scale: h.scale,
                albedo: h.albedo,
                albedo_grid: &h.albedo_grid,
                phase: h.phase,
                sample_emitters: h.sample_emitters,
            },
            MediumDesc::Heterogeneous(h) => Common {
                sigma_t: [0.0; 3],
                density: Some(&h.sigma_t_grid),
                scale: h.scale,
                albedo: h.albedo,
                albedo_grid: &h.albedo_grid,
                phase: h.phase,
                sample_emitters: h.sample_emitters,
            },
        }
    }
}

/// Reads a grid: a `.vol` file whose every value lies in [0, `max`] (`what` names the values
/// in a message).
fn grid(
    ctx: &Ctx,
    dir: &std::path::Path,
    field: &str,
    g: &GridDesc,
    (max, what): (f32, &str),
    (hashed, files_read): (&mut Vec<Vec<u8>>, &mut Vec<std::path::PathBuf>),
) -> Result<GridVolume> {
    let filter = match g.filter.as_deref() {
        None | Some("trilinear") => Filter::Bilinear,
        Some("nearest") => Filter::Nearest,
        Some(other) => {
            return Err(ctx.err(
                &format!("{field}.filter"),
                format!("expected \"trilinear\" or \"nearest\", got {other:?}"),
            ));
        }
    };
    let wrap = match g.wrap.as_deref() {
        None | Some("clamp") => Wrap::Clamp,
        Some("repeat") => Wrap::Repeat,
        Some("mirror") => Wrap::Mirror,
        Some(other) => {
            return Err(ctx.err(
                &format!("{field}.wrap"),
                format!("expected \"clamp\", \"repeat\" or \"mirror\", got {other:?}"),
            ));
        }
    };
    let xf = transform(ctx, &format!("{field}.to_world"), g.to_world.as_ref())?;
    let to_world = glam::Affine3A::from_mat3_translation(xf.m.matrix3.as_mat3(), xf.m.translation.as_vec3());
    let path = dir.join(&g.file);
    let shown = path.display().to_string();
    let bytes = read_regular_file(&path, "volume grid")
        .map_err(|e| ctx.err(&format!("{field}.file"), format!("cannot read {shown}: {e}")))?;
    let volume = GridVolume::from_vol_bytes(&bytes, filter, wrap, to_world, g.use_grid_bbox.unwrap_or(false))
        .map_err(|e| ctx.err(&format!("{field}.file"), format!("{shown}: {e}")))?;
    let min = volume.min();
    if !(min >= 0.0 && volume.max() <= max) {
        return Err(ctx.err(
            &format!("{field}.file"),
            format!(
                "{shown}: expected {what} in [0, {}], got values in [{}, {}]",
                num(max as f64),
                num(min as f64),
                num(volume.max() as f64)
            ),
        ));
    }
    hashed.push(bytes);
    files_read.push(path);
    Ok(volume)
}

/// The index of medium `name` referred to by `field`, or an error listing the media.
pub(super) fn medium_ref(
    ctx: &Ctx,
    field: &str,
    name: Option<&str>,
    index: &BTreeMap<String, u32>,
) -> Result<Option<u32>> {
    let Some(name) = name else { return Ok(None) };
    match index.get(name) {
        Some(&i) => Ok(Some(i)),
        None => Err(ctx.err(
            field,
            format!(
                "no medium named {name:?} (media: {})",
                if index.is_empty() {
                    "none".to_string()
                } else {
                    index.keys().map(|k| format!("{k:?}")).collect::<Vec<_>>().join(", ")
                }
            ),
        )),
    }
}
