//! What pbrt-v4's directives mean, as our scene description: the graphics state (transform,
//! material, area light, orientation) and each camera, material, texture, shape and light.
//!
//! Decisions (pbrt-v4's semantics, `src/pbrt/scene.cpp` and the file-format page):
//! - Transforms post-multiply the current transform; `Transform`/`ConcatTransform` take the
//!   matrix column by column. The camera is the inverse of the transform at `Camera`; its image
//!   is our camera's mirrored unless that transform mirrors (module doc of [`super`]).
//! - A triangle's front side: its vertex normals where it has them, else its winding,
//!   turned around by `ReverseOrientation` and by a transform that mirrors (pbrt's
//!   `reverseOrientation ^ transformSwapsHandedness`); a disk's and a cylinder's by
//!   `ReverseOrientation` alone (their normals are transformed as normals).
//! - Colours: `rgb` as it is (pbrt-v4 normalises an RGB illuminant to the colour space's
//!   white, which an RGB render shows as the same RGB); `spectrum` lists as Mitsuba's RGB
//!   variants convert them ([`crate::spectrum`]); `blackbody` for lights at a luminance of 1
//!   (pbrt-v4 normalises light spectra to 1 nit), times `scale`.
//! - Roughness: pbrt-v4's microfacets are Trowbridge–Reitz (GGX) with visible-normal
//!   sampling; `remaproughness` (default true) makes α = √roughness; α below 10⁻³ is smooth
//!   (pbrt's `EffectivelySmooth`).
//! - `conductor`'s named spectra `metal-X-eta`/`metal-X-k` become Mitsuba's named conductor X
//!   (its measured data, not pbrt's own tables: warned); its default is copper.
//! - `mix` with `amount` a = our blend of weight a (pbrt picks the second material with
//!   probability a per hit: the same mean).
//! - Media: `MakeNamedMedium` of type `homogeneous` becomes our homogeneous medium with
//!   σ_t = `scale` (σ_a + σ_s) and albedo σ_s / σ_t, its phase function Henyey–Greenstein with
//!   `g` (pbrt's defaults σ_a = σ_s = 1, `scale` 1, `g` 0); `MediumInterface "inside"
//!   "outside"` is part of the graphics state (one name: both sides; "": vacuum); a shape takes
//!   it when its two sides differ — pbrt's `IsMediumTransition`; otherwise a ray keeps its
//!   medium there, which is what a shape without media means to us — and the camera takes the
//!   interface's outside at `Camera`. `Material "interface"` is our `null`. Emitting media
//!   (`Le`), `preset` scattering properties and grid media (`uniformgrid`, `rgbgrid`, `cloud`,
//!   `nanovdb`) are refused.

use super::syntax::{Directive, Param, Value};
use crate::error::{Error, Result};
use crate::scene::desc::{self, Color, Fixed, MaterialDesc, SceneDesc, ShapeDesc, TextureDesc, TransformDesc, Triple};
use glam::{DMat3, DMat4, DVec3, DVec4};
use std::collections::BTreeMap;
use std::path::Path;

/// The graphics state `AttributeBegin` saves.
#[derive(Clone)]
struct State {
    ctm: DMat4,
    material: Option<String>,
    area_light: Option<desc::EmissionDesc>,
    reverse_orientation: bool,
    /// `MediumInterface`: the media inside and outside the shapes that follow (`None`: vacuum).
    medium_inside: Option<String>,
    medium_outside: Option<String>,
}

pub struct Translator<'a> {
    file: &'a str,
    dir: &'a Path,
    state: State,
    stack: Vec<State>,
    named_coordinate_systems: BTreeMap<String, DMat4>,
    world: bool,
    camera: Option<desc::CameraDesc>,
    camera_at: String,
    resolution: [u32; 2],
    /// The film's pixel bounds (`cropwindow`, `pixelbounds`), if not the whole film.
    crop: Option<desc::CropDesc>,
    filter: Option<desc::FilterDesc>,
    materials: BTreeMap<String, MaterialDesc>,
    /// Spectrum and float textures by name (pbrt keeps the two apart).
    textures: BTreeMap<String, TextureDesc>,
    float_textures: BTreeMap<String, TextureDesc>,
    /// Materials made for shapes with `alpha`, by what they are (material and opacity).
    masked: BTreeMap<String, String>,
    anonymous: usize,
    shapes: Vec<ShapeDesc>,
    labels: Vec<String>,
    /// Objects of `ObjectBegin` … `ObjectEnd`: their shapes (transformed as defined) and labels.
    objects: BTreeMap<String, Vec<(ShapeDesc, String)>>,
    /// The object being defined, if any: shapes go there instead of into the scene.
    defining: Option<String>,
    lights: Vec<desc::LightDesc>,
    environment: Option<desc::EnvironmentDesc>,
    /// `MakeNamedMedium`s, and the media `MediumInterface` named (with where), checked once
    /// the whole file is read (pbrt resolves the names at the end too).
    media: BTreeMap<String, desc::MediumDesc>,
    media_named: Vec<(String, String)>,
    warnings: Vec<String>,
    /// Files read for parameters (spectra), with their bytes, for the scene's hash.
    pub files_read: Vec<(std::path::PathBuf, Vec<u8>)>,
}

impl<'a> Translator<'a> {
    pub fn new(file: &'a str, dir: &'a Path) -> Self {
        Self {
            file,
            dir,
            state: State {
                ctm: DMat4::IDENTITY,
                material: None,
                area_light: None,
                reverse_orientation: false,
                medium_inside: None,
                medium_outside: None,
            },
            stack: Vec::new(),
            named_coordinate_systems: BTreeMap::new(),
            world: false,
            camera: None,
            camera_at: String::new(),
            resolution: [1280, 720],
            crop: None,
            filter: None,
            materials: BTreeMap::new(),
            textures: BTreeMap::new(),
            float_textures: BTreeMap::new(),
            masked: BTreeMap::new(),
            anonymous: 0,
            shapes: Vec::new(),
            labels: Vec::new(),
            objects: BTreeMap::new(),
            defining: None,
            lights: Vec::new(),
            environment: None,
            media: BTreeMap::new(),
            media_named: Vec::new(),
            warnings: Vec::new(),
            files_read: Vec::new(),
        }
    }

    pub fn directive(&mut self, d: &Directive) -> Result<()> {
        let nums = |n: usize| -> Result<Vec<f64>> {
            let v: Vec<f64> = d
                .args
                .iter()
                .filter_map(|a| if let Value::Num(x) = a { Some(*x) } else { None })
                .collect();
            if v.len() == n && d.args.len() == n {
                Ok(v)
            } else {
                Err(d.err(format!("expected {n} numbers")))
            }
        };
        let name = || -> Result<String> {
            match &d.args[..] {
                [Value::Str(s)] => Ok(s.clone()),
                _ => Err(d.err("expected one quoted name")),
            }
        };
        match d.name.as_str() {
            "Identity" => self.state.ctm = DMat4::IDENTITY,
            "Translate" => {
                let v = nums(3)?;
                self.concat(DMat4::from_translation(DVec3::new(v[0], v[1], v[2])));
            }
            "Scale" => {
                let v = nums(3)?;
                self.concat(DMat4::from_scale(DVec3::new(v[0], v[1], v[2])));
            }
            "Rotate" => {
                let v = nums(4)?;
                let axis = DVec3::new(v[1], v[2], v[3]);
                if axis.length_squared() == 0.0 {
                    return Err(d.err("the rotation axis is zero"));
                }
                self.concat(DMat4::from_axis_angle(axis.normalize(), v[0].to_radians()));
            }
            "LookAt" => {
                let v = nums(9)?;
                let (eye, look, up) = (
                    DVec3::new(v[0], v[1], v[2]),
                    DVec3::new(v[3], v[4], v[5]),
                    DVec3::new(v[6], v[7], v[8]),
                );
                let dir = (look - eye).normalize_or_zero();
                let right = up.normalize_or_zero().cross(dir);
                if dir == DVec3::ZERO || right.length() < 1e-9 {
                    return Err(d.err("eye and look point coincide, or up is parallel to the view"));
                }
                let right = right.normalize();
                let new_up = dir.cross(right);
                let camera_to_world =
                    DMat4::from_cols(right.extend(0.0), new_up.extend(0.0), dir.extend(0.0), eye.extend(1.0));
                self.concat(camera_to_world.inverse());
            }
            "Transform" | "ConcatTransform" => {
                let m = column_major(&nums(16)?);
                if d.name == "Transform" {
                    self.state.ctm = m;
                } else {
                    self.concat(m);
                }
            }
            "CoordinateSystem" => {
                self.named_coordinate_systems.insert(name()?, self.state.ctm);
            }
            "CoordSysTransform" => {
                let n = name()?;
                self.state.ctm = *self
                    .named_coordinate_systems
                    .get(&n)
                    .ok_or_else(|| d.err(format!("no coordinate system named {n:?}")))?;
            }
            "ReverseOrientation" => self.state.reverse_orientation = !self.state.reverse_orientation,
            "AttributeBegin" => self.stack.push(self.state.clone()),
            "AttributeEnd" => {
                self.state = self.stack.pop().ok_or_else(|| d.err("no AttributeBegin to end"))?;
            }
            "WorldBegin" => {
                self.world = true;
                self.named_coordinate_systems.insert("world".into(), DMat4::IDENTITY);
                self.state.ctm = DMat4::IDENTITY;
            }
            "Camera" => self.camera(d)?,
            "Film" => self.film(d)?,
            "PixelFilter" => self.pixel_filter(d)?,
            "Sampler" | "Integrator" | "Accelerator" | "Option" => {
                self.warn(d, "ignored: the experiment file chooses the strategy and the samples");
            }
            "ColorSpace" => match &d.args[..] {
                [Value::Str(s)] if s == "srgb" => {}
                _ => return Err(d.err("only the srgb colour space is rendered")),
            },
            "Material" => {
                let kind = name()?;
                let m = self.material(d, &kind, &d.params)?;
                self.anonymous += 1;
                let id = format!("material-{}", self.anonymous);
                self.materials.insert(id.clone(), m);
                self.state.material = Some(id);
            }
            "MakeNamedMaterial" => {
                let n = name()?;
                let kind = string_param(d, &d.params, "type")?.ok_or_else(|| d.err("expected \"string type\""))?;
                let rest: Vec<Param> = d.params.iter().filter(|p| p.name != "type").cloned().collect();
                let m = self.material(d, &kind, &rest)?;
                self.materials.insert(format!("named:{n}"), m);
            }
            "NamedMaterial" => {
                let n = name()?;
                let id = format!("named:{n}");
                if !self.materials.contains_key(&id) {
                    return Err(d.err(format!("no material named {n:?} (MakeNamedMaterial first)")));
                }
                self.state.material = Some(id);
            }
            "Texture" => self.texture(d)?,
            "Shape" => self.shape(d)?,
            "AreaLightSource" => {
                if name()? != "diffuse" {
                    return Err(d.err("expected the \"diffuse\" area light"));
                }
                let scale = float_param(d, &d.params, "scale")?.unwrap_or(1.0);
                let l = self.light_colour(d, "L")?.unwrap_or([1.0; 3]);
                let two_sided = bool_param(d, &d.params, "twosided")?.unwrap_or(false);
                check_known(d, &d.params, &["L", "scale", "twosided"])?;
                self.state.area_light = Some(desc::EmissionDesc {
                    radiance: Fixed(l.map(|c| c * scale)),
                    two_sided,
                });
            }
            "LightSource" => self.light(d)?,
            "ObjectBegin" => {
                let n = name()?;
                if let Some(open) = &self.defining {
                    return Err(d.err(format!("object {open:?} is still open (ObjectEnd first)")));
                }
                if self.objects.contains_key(&n) {
                    return Err(d.err(format!("object {n:?} is defined twice")));
                }
                // pbrt's ObjectBegin saves the attributes, as AttributeBegin does.
                self.stack.push(self.state.clone());
                self.objects.insert(n.clone(), Vec::new());
                self.defining = Some(n);
            }
            "ObjectEnd" => {
                if self.defining.take().is_none() {
                    return Err(d.err("no ObjectBegin to end"));
                }
                self.state = self.stack.pop().ok_or_else(|| d.err("no ObjectBegin to end"))?;
            }
            "ObjectInstance" => self.instance(d, &name()?)?,
            "MakeNamedMedium" => {
                let n = name()?;
                let medium = self.medium(d)?;
                self.media.insert(n, medium);
            }
            "MediumInterface" => {
                let names: Vec<String> = d
                    .args
                    .iter()
                    .map(|a| match a {
                        Value::Str(s) => Ok(s.clone()),
                        _ => Err(d.err("expected one or two quoted medium names (inside, outside)")),
                    })
                    .collect::<Result<_>>()?;
                let (inside, outside) = match &names[..] {
                    [one] => (one.clone(), one.clone()),
                    [inside, outside] => (inside.clone(), outside.clone()),
                    _ => return Err(d.err("expected one or two quoted medium names (inside, outside)")),
                };
                let named = |n: String| (!n.is_empty()).then_some(n);
                for n in [&inside, &outside].into_iter().filter(|n| !n.is_empty()) {
                    self.media_named.push((n.clone(), d.at.clone()));
                }
                self.state.medium_inside = named(inside);
                self.state.medium_outside = named(outside);
            }
            other => {
                return Err(d.err(format!(
                    "{other} is not supported (animated transforms and named attributes are not read yet)"
                )));
            }
        }
        Ok(())
    }

    /// `ObjectInstance`: a copy of every shape of the object, the current transform applied
    /// after the one each had where it was defined (pbrt-v4's world-from-instance). Instances
    /// are flattened: a copy per instance, exact but without pbrt's memory savings.
    fn instance(&mut self, d: &Directive, n: &str) -> Result<()> {
        if self.defining.is_some() {
            return Err(d.err("ObjectInstance inside ObjectBegin (nested instancing) is not read"));
        }
        let shapes = self
            .objects
            .get(n)
            .ok_or_else(|| d.err(format!("no object named {n:?} (ObjectBegin first)")))?;
        if self.swaps_handedness() {
            return Err(d.err("an ObjectInstance under a mirroring transform is not read yet"));
        }
        for (shape, label) in shapes {
            let mut shape = shape.clone();
            let t = shape.transform_mut().get_or_insert_with(|| TransformDesc(Vec::new()));
            t.0.extend(TransformDesc::from_matrix(self.state.ctm).0);
            self.shapes.push(shape);
            self.labels.push(format!("{}, ObjectInstance {n:?} of {label}", d.at));
        }
        Ok(())
    }

    fn concat(&mut self, m: DMat4) {
        self.state.ctm *= m;
    }

    fn warn(&mut self, d: &Directive, msg: &str) {
        self.warnings.push(format!("{}, {}: {msg}", d.at, d.name));
    }

    fn camera(&mut self, d: &Directive) -> Result<()> {
        let kind = match &d.args[..] {
            [Value::Str(s)] => s.clone(),
            _ => return Err(d.err("expected the camera type")),
        };
        let world_from_camera = self.state.ctm.inverse();
        if !world_from_camera.is_finite() {
            return Err(d.err("the camera transform is not invertible"));
        }
        self.named_coordinate_systems.insert("camera".into(), world_from_camera);
        let col = |i: usize| world_from_camera.col(i).truncate();
        let (x, y, z) = (col(0), col(1), col(2));
        let rigid = [x, y, z].iter().all(|c| (c.length() - 1.0).abs() < 1e-4)
            && x.dot(y).abs() < 1e-4
            && x.dot(z).abs() < 1e-4
            && y.dot(z).abs() < 1e-4;
        if !rigid {
            return Err(d.err("the camera transform must be a rotation, translation and mirror only (no scale)"));
        }
        let eye = col(3);
        // Our camera's raster x follows view × up = z × y; pbrt's follows x.
        let flip_x = DMat3::from_cols(x, y, z).determinant() > 0.0;
        let params = &d.params;
        let lens = match kind.as_str() {
            "perspective" => {
                check_known(d, params, &["fov", "lensradius", "focaldistance"])?;
                let r = float_param(d, params, "lensradius")?.unwrap_or(0.0);
                let focus_distance = float_param(d, params, "focaldistance")?.unwrap_or(1e6);
                (r > 0.0).then_some(desc::LensDesc::Thin(desc::ThinLensDesc {
                    aperture_radius: r,
                    focus_distance,
                }))
            }
            "orthographic" => {
                check_known(d, params, &[])?;
                None
            }
            other => return Err(d.err(format!("unsupported camera {other:?} (perspective, orthographic)"))),
        };
        let fov = float_param(d, params, "fov")?.unwrap_or(90.0);
        if !(fov > 0.0 && fov < 180.0) {
            return Err(d.err(format!("fov: expected degrees in (0, 180), got {fov}")));
        }
        self.camera_at = d.at.clone();
        self.camera = Some(desc::CameraDesc {
            eye: Fixed(eye.to_array()),
            look_at: Fixed((eye + z).to_array()),
            up: Fixed(y.to_array()),
            fov_y: Some(fov),
            resolution: Fixed([1, 1]),
            filter: None,
            crop: None,
            lens: if kind == "orthographic" {
                Some(desc::LensDesc::Orthographic(desc::OrthographicDesc {
                    height: 2.0,
                    width: None,
                }))
            } else {
                lens
            },
            flip_x,
            medium: self.state.medium_outside.clone(),
        });
        Ok(())
    }

    fn film(&mut self, d: &Directive) -> Result<()> {
        match &d.args[..] {
            [Value::Str(s)] if s == "rgb" => {}
            _ => return Err(d.err("expected the \"rgb\" film")),
        }
        check_known(
            d,
            &d.params,
            &["xresolution", "yresolution", "filename", "cropwindow", "pixelbounds"],
        )?;
        for (i, key) in ["xresolution", "yresolution"].into_iter().enumerate() {
            if let Some(v) = float_param(d, &d.params, key)? {
                if !((1.0..=16384.0).contains(&v) && v.fract() == 0.0) {
                    return Err(d.err(format!("{key}: expected an integer in 1..=16384, got {v}")));
                }
                self.resolution[i] = v as u32;
            }
        }
        self.crop = self.film_crop(d)?;
        Ok(())
    }

    /// pbrt-v4's pixel bounds (`FilmBaseParameters`): `pixelbounds` [x0 x1 y0 y1] in pixels,
    /// clipped to the film, or — winning over it, as in pbrt — `cropwindow` [x0 x1 y0 y1] as
    /// fractions of the film (each pair ordered and clamped to [0, 1]), whose bounds are
    /// ⌈res · min⌉ … ⌈res · max⌉; pixel rows count from the top, as ours. `None` for the whole
    /// film.
    fn film_crop(&self, d: &Directive) -> Result<Option<desc::CropDesc>> {
        let [w, h] = self.resolution.map(f64::from);
        let values = |key: &str| -> Result<Option<Vec<f64>>> {
            match content::find(&d.params, key) {
                None => Ok(None),
                Some(p) => match content::numbers(d, p)? {
                    v if v.len() == 4 && v.iter().all(|x| x.is_finite()) => Ok(Some(v)),
                    _ => Err(d.err(format!("{key}: expected 4 numbers [x0 x1 y0 y1]"))),
                },
            }
        };
        let bounds = if let Some(c) = values("cropwindow")? {
            let frac = |a: f64, b: f64| (a.min(b).clamp(0.0, 1.0), a.max(b).clamp(0.0, 1.0));
            let ((x0, x1), (y0, y1)) = (frac(c[0], c[1]), frac(c[2], c[3]));
            [(w * x0).ceil(), (w * x1).ceil(), (h * y0).ceil(), (h * y1).ceil()]
        } else if let Some(b) = values("pixelbounds")? {
            [b[0].max(0.0), b[1].min(w), b[2].max(0.0), b[3].min(h)]
        } else {
            return Ok(None);
        };
        let [x0, x1, y0, y1] = bounds;
        if x1 <= x0 || y1 <= y0 {
            return Err(d.err(format!(
                "the crop window covers no pixel of the {w} × {h} film (pixels x {x0}..{x1}, y {y0}..{y1})"
            )));
        }
        if [x0, x1, y0, y1] == [0.0, w, 0.0, h] {
            return Ok(None);
        }
        Ok(Some(desc::CropDesc {
            offset: Some(Fixed([x0 as u32, y0 as u32])),
            size: Fixed([(x1 - x0) as u32, (y1 - y0) as u32]),
        }))
    }

    fn pixel_filter(&mut self, d: &Directive) -> Result<()> {
        let kind = match &d.args[..] {
            [Value::Str(s)] => s.clone(),
            _ => return Err(d.err("expected the filter type")),
        };
        self.filter = Some(match kind.as_str() {
            "box" => {
                check_known(d, &d.params, &[])?;
                desc::FilterDesc::Box(desc::BoxFilterDesc {})
            }
            "gaussian" => {
                check_known(d, &d.params, &[])?;
                self.warn(
                    d,
                    "pbrt's Gaussian (σ ½ to radius 1.5, minus its value there) rendered as Mitsuba's (σ ½ to radius 2)",
                );
                desc::FilterDesc::Gaussian(desc::GaussianFilterDesc { stddev: None })
            }
            other => return Err(d.err(format!("unsupported filter {other:?} (box, gaussian)"))),
        });
        Ok(())
    }

    /// The finished description: the camera (with the film's size and the filter), the
    /// materials, shapes and lights.
    pub fn finish(&mut self) -> Result<(SceneDesc, Vec<String>, Vec<String>)> {
        let Some(mut camera) = self.camera.take() else {
            return Err(Error::new(format!("{}: no Camera directive", self.file)));
        };
        let [w, h] = self.resolution;
        // pbrt's fov spans the shorter image axis.
        if let Some(fov) = camera.fov_y
            && w < h
        {
            let t = (0.5 * fov.to_radians()).tan() * h as f64 / w as f64;
            camera.fov_y = Some(2.0 * t.atan().to_degrees());
        }
        if let Some(desc::LensDesc::Orthographic(o)) = &mut camera.lens {
            // The screen window is [−1, 1] on the shorter axis.
            o.height = 2.0 * (h as f64 / w as f64).max(1.0);
        }
        camera.resolution = Fixed([w, h]);
        camera.crop = self.crop;
        camera.filter = Some(self.filter.take().unwrap_or_else(|| {
            self.warnings.push(format!(
                "{}: pbrt's default Gaussian filter rendered as Mitsuba's (σ ½ to radius 2)",
                self.camera_at
            ));
            desc::FilterDesc::Gaussian(desc::GaussianFilterDesc { stddev: None })
        }));
        if let Some(open) = &self.defining {
            return Err(Error::new(format!(
                "{}: ObjectBegin {open:?} is never ended",
                self.file
            )));
        }
        if !self.stack.is_empty() {
            return Err(Error::new(format!("{}: an AttributeBegin is never ended", self.file)));
        }
        if let Some((n, at)) = self.media_named.iter().find(|(n, _)| !self.media.contains_key(n)) {
            return Err(Error::new(format!(
                "{at}, MediumInterface: no medium named {n:?} (MakeNamedMedium it)"
            )));
        }
        let desc = SceneDesc {
            name: None,
            camera,
            materials: std::mem::take(&mut self.materials),
            shapes: std::mem::take(&mut self.shapes),
            user_paths: Vec::new(),
            environment: self.environment.take(),
            lights: std::mem::take(&mut self.lights),
            media: std::mem::take(&mut self.media),
        };
        Ok((
            desc,
            std::mem::take(&mut self.labels),
            std::mem::take(&mut self.warnings),
        ))
    }

    /// The current material's name, the default diffuse (reflectance 0.5) if none was set.
    fn current_material(&mut self) -> String {
        if let Some(m) = &self.state.material {
            return m.clone();
        }
        let id = "default-diffuse".to_string();
        self.materials
            .entry(id.clone())
            .or_insert(MaterialDesc::Diffuse(desc::Diffuse {
                reflectance: Color::Rgb(Fixed([0.5; 3])),
            }));
        id
    }
}

mod content;
mod materials;
mod textures;

use content::{bool_param, check_known, column_major, float_param, string_param};

impl Translator<'_> {
    /// A transform step for the current transform.
    fn ctm_desc(&self) -> TransformDesc {
        TransformDesc::from_matrix(self.state.ctm)
    }

    /// Whether the current transform mirrors (pbrt's `SwapsHandedness`).
    fn swaps_handedness(&self) -> bool {
        DMat3::from_mat4(self.state.ctm).determinant() < 0.0
    }

    fn point(&self, p: DVec3) -> DVec3 {
        (self.state.ctm * DVec4::new(p.x, p.y, p.z, 1.0)).truncate()
    }

    /// The current `MediumInterface` as a shape's interior and exterior, when its sides differ
    /// (module doc).
    fn shape_media(&self) -> Option<(Option<String>, Option<String>)> {
        let (inside, outside) = (&self.state.medium_inside, &self.state.medium_outside);
        (inside != outside).then(|| (inside.clone(), outside.clone()))
    }

    /// `MakeNamedMedium`'s medium (module doc).
    fn medium(&mut self, d: &Directive) -> Result<desc::MediumDesc> {
        let kind = string_param(d, &d.params, "type")?.ok_or_else(|| d.err("expected \"string type\""))?;
        if kind != "homogeneous" {
            return Err(d.err(format!(
                "medium type {kind:?} is not read (homogeneous; grid media are not read yet)"
            )));
        }
        check_known(
            d,
            &d.params,
            &["type", "sigma_a", "sigma_s", "scale", "g", "Le", "Lescale", "preset"],
        )?;
        if string_param(d, &d.params, "preset")?.is_some_and(|p| !p.is_empty()) {
            return Err(d.err("preset: named scattering properties are not read; give sigma_a and sigma_s"));
        }
        let rgb = |name: &str| -> Result<Option<[f64; 3]>> {
            match self.colour(d, &d.params, name, false)? {
                Some(Color::Rgb(c)) => Ok(Some(c.0)),
                Some(Color::Texture(_)) => Err(d.err(format!("{name}: a medium's coefficient cannot be a texture"))),
                None => Ok(None),
            }
        };
        if rgb("Le")?.is_some_and(|le| le.iter().any(|&c| c != 0.0)) {
            return Err(d.err("Le: emitting media are not rendered"));
        }
        let (sigma_a, sigma_s) = (rgb("sigma_a")?.unwrap_or([1.0; 3]), rgb("sigma_s")?.unwrap_or([1.0; 3]));
        if sigma_a.iter().chain(&sigma_s).any(|&c| !(c >= 0.0 && c.is_finite())) {
            return Err(d.err("sigma_a, sigma_s: expected finite coefficients >= 0"));
        }
        let scale = float_param(d, &d.params, "scale")?.unwrap_or(1.0);
        if !(scale > 0.0 && scale.is_finite()) {
            return Err(d.err(format!("scale: expected a number > 0, got {scale}")));
        }
        let g = float_param(d, &d.params, "g")?.unwrap_or(0.0);
        if !(g > -1.0 && g < 1.0) {
            return Err(d.err(format!("g: expected a mean cosine in (-1, 1), got {g}")));
        }
        let sigma_t: [f64; 3] = std::array::from_fn(|c| sigma_a[c] + sigma_s[c]);
        let albedo: [f64; 3] = std::array::from_fn(|c| if sigma_t[c] > 0.0 { sigma_s[c] / sigma_t[c] } else { 0.0 });
        Ok(desc::MediumDesc::Homogeneous(desc::HomogeneousDesc {
            sigma_t: Some(Fixed(sigma_t)),
            scale: Some(scale),
            albedo: Some(Fixed(albedo)),
            albedo_grid: None,
            phase: Some(desc::PhaseDesc::Hg(desc::HgDesc { g })),
            sample_emitters: None,
        }))
    }
}
