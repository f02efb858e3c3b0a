//! pbrt-v4 scene files (`*.pbrt`) translated into the scene description a TOML file becomes,
//! as [`super::mitsuba`] does for Mitsuba 3: validation, hashing, references and experiments
//! are then the same. The format is pbrt-v4's (https://pbrt.org/fileformat-v4).
//!
//! **Decision: our own reader.** The one Rust parser crate for the format, `pbrt4` (0.2.0,
//! unchanged since May 2023), drops `PixelFilter` parameters, leaves material parameters
//! unparsed and panics (`unimplemented!`) on some light types, and its errors carry no line:
//! a malformed file must get a one-line message naming the line. The format is a flat list of
//! directives with typed parameter lists, so [`syntax`] reads it in a few hundred lines, and
//! [`translate`] maps what it means.
//!
//! What is read (everything else is refused in one line naming the line and the directive):
//! - Transforms: `Identity`, `Translate`, `Scale`, `Rotate`, `LookAt`, `Transform`,
//!   `ConcatTransform`, `CoordinateSystem`, `CoordSysTransform`, `ReverseOrientation`,
//!   `AttributeBegin`/`AttributeEnd` (the graphics state: transform, material, area light,
//!   orientation), `WorldBegin`; `Include` and `Import` (read in place).
//! - `Camera` `perspective` (`fov` on the shorter image axis, `lensradius`, `focaldistance`)
//!   and `orthographic`; pbrt's camera space is left-handed (x = up × view goes to the right of
//!   the image), so the image is ours mirrored ([`crate::camera::Camera::mirrored`]).
//! - `Film` `rgb` (`xresolution`, `yresolution`, `cropwindow`, `pixelbounds`; `filename` ignored); `PixelFilter` `box`
//!   (radius ½) and `gaussian` (approximated by Mitsuba's, warned); `Sampler`, `Integrator`,
//!   `Accelerator`, `ColorSpace "srgb"`, `Option` ignored with a warning where they would
//!   change nothing we render.
//! - `Material`, `MakeNamedMaterial`, `NamedMaterial`: `diffuse`, `conductor`, `dielectric`,
//!   `thindielectric`, `diffusetransmission`, `mix`, `coateddiffuse`, `coatedconductor`,
//!   `interface` ([`translate`] says how each maps); a material's `normalmap`.
//! - `Texture` `float`/`spectrum` `checkerboard` (2D), `constant`, `imagemap` and `scale`.
//! - `Shape` `trianglemesh`, `bilinearmesh` (flat patches), `loopsubdiv` ([`loop_subdiv`]),
//!   `plymesh`, `sphere`, `disk`, `cylinder` (whole ones); `ObjectBegin`/`ObjectInstance`
//!   (flattened); a shape's `alpha` (float or float texture: our mask).
//! - `AreaLightSource` `diffuse`; `LightSource` `point`, `spot`, `distant`, `infinite`
//!   (constant `L` or an equal-area image).
//! - `MakeNamedMedium` `homogeneous`, `MediumInterface`.

mod loop_subdiv;
mod syntax;
mod translate;

use crate::error::Result;
use crate::scene::desc::SceneDesc;
use std::path::Path;

/// A pbrt-v4 scene translated ([`import`]).
pub struct Imported {
    pub desc: SceneDesc,
    /// For each of `desc.shapes`, how errors name it: `line L, Shape "…"`.
    pub shape_labels: Vec<String>,
    /// Approximations and ignored settings, one line each, prefixed with the file.
    pub warnings: Vec<String>,
    /// Every file included (at any depth) with its bytes, in reading order, for the hash.
    pub included: Vec<(std::path::PathBuf, Vec<u8>)>,
}

/// Reads a pbrt-v4 scene. `file` names it in messages; `dir` anchors relative paths.
pub fn import(file: &str, dir: &Path, text: &str) -> Result<Imported> {
    let mut included = Vec::new();
    let directives = syntax::read(file, dir, text, &mut included, 0)?;
    let mut t = translate::Translator::new(file, dir);
    for d in &directives {
        t.directive(d)?;
    }
    let (desc, shape_labels, warnings) = t.finish()?;
    included.append(&mut t.files_read);
    Ok(Imported {
        desc,
        shape_labels,
        warnings,
        included,
    })
}

/// Reads and translates the pbrt-v4 scene file at `path` (gzip-compressed if it ends in
/// `.gz`).
pub fn import_file(path: &Path) -> Result<Imported> {
    let bytes = crate::util::read_input(path, "scene file", crate::util::MAX_TEXT_INPUT)?;
    let shown = path.display().to_string();
    let bytes = if crate::util::is_gzip(path) {
        crate::util::gunzip(&bytes, crate::util::MAX_TEXT_INPUT)
            .map_err(|e| crate::error::Error::new(format!("{shown}: {e}")))?
    } else {
        bytes
    };
    let text = std::str::from_utf8(&bytes).map_err(|e| {
        crate::error::Error::new(format!(
            "{shown}: not valid UTF-8 (first bad byte at offset {})",
            e.valid_up_to()
        ))
    })?;
    import(&shown, path.parent().unwrap_or(Path::new("")), text)
}

/// Whether `path` names a pbrt scene (by its extension: `.pbrt`, or `.pbrt.gz` compressed).
pub fn is_pbrt(path: &Path) -> bool {
    let plain = if crate::util::is_gzip(path) {
        path.file_stem().map(Path::new)
    } else {
        Some(path)
    };
    plain.is_some_and(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("pbrt")))
}
