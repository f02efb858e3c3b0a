//! The `<sensor>` and its `<film>`: camera placement, lens (`perspective`, `thinlens`,
//! `orthographic`), field of view, resolution, crop window, pixel filter.

use super::*;
use crate::error::Result;
use crate::scene::desc::{CameraDesc, Fixed};
use glam::{DMat3, DMat4};
use roxmltree::Node;

/// What an `<film>` says: its size, pixel filter and crop window.
pub(super) struct Film {
    width: u32,
    height: u32,
    filter: desc::FilterDesc,
    crop: Option<desc::CropDesc>,
}

impl<'a, 'i> Reader<'a, 'i> {
    pub(super) fn sensor(&mut self, n: Node<'a, 'i>) -> Result<CameraDesc> {
        let kind = self.required(n, "type")?;
        if !matches!(kind.as_str(), "perspective" | "thinlens" | "orthographic") {
            return Err(self.err(
                n,
                format!("unsupported sensor {kind:?} (perspective, thinlens, orthographic)"),
            ));
        }
        let mut o = self.obj(n)?;
        let orthographic = kind == "orthographic";
        let fov = if orthographic {
            // The view's extent is to_world's scale (below).
            45.0
        } else {
            let Some(fov) = self.float(&mut o, "fov")? else {
                return Err(self.err(n, "expected <float name=\"fov\"> (focal_length is not supported)"));
            };
            if !(fov > 0.0 && fov < 180.0) {
                return Err(self.err(n, format!("fov: expected degrees in (0, 180), got {fov}")));
            }
            fov
        };
        let axis = match (orthographic, self.string(&mut o, "fov_axis")?) {
            (false, None) => "x".to_string(),
            (false, Some((_, a))) => a,
            (true, _) => "y".to_string(),
        };
        let thin_lens = if kind == "thinlens" {
            let Some(radius) = self.float(&mut o, "aperture_radius")? else {
                return Err(self.err(n, "expected <float name=\"aperture_radius\"> (thinlens)"));
            };
            // Mitsuba's default focus distance is its far clip, 10⁴.
            let focus = self.float(&mut o, "focus_distance")?.unwrap_or(1e4);
            Some(desc::ThinLensDesc {
                aperture_radius: radius,
                focus_distance: focus,
            })
        } else {
            None
        };
        for clip in ["near_clip", "far_clip"] {
            if let Some(p) = o.props.get(clip).copied() {
                self.float(&mut o, clip)?;
                self.warn(p, "ignored: photon-bench's camera has no clipping planes");
            }
        }
        // A pinhole has everything in focus; Mitsuba's `perspective` ignores it too (only
        // `thinlens` reads it).
        if thin_lens.is_none() {
            self.float(&mut o, "focus_distance")?;
        }
        let m = match self.transform(&mut o, "to_world")? {
            Some((_, m)) => m,
            None => DMat4::IDENTITY,
        };
        let (mut width, mut height, mut filter, mut crop) = (None, None, None, None);
        let mut medium = None;
        for c in o.children.clone() {
            match c.tag_name().name() {
                "ref" | "medium" if c.attribute("name") == Some("medium") || c.has_tag_name("medium") => {
                    if medium.is_some() {
                        return Err(self.err(c, "a second medium for the sensor"));
                    }
                    medium = Some(self.medium_child(c, "sensor-medium".to_string())?);
                }
                "film" => {
                    if width.is_some() {
                        return Err(self.err(c, "a second <film>"));
                    }
                    let film = self.film(c)?;
                    (width, height, filter, crop) = (Some(film.width), Some(film.height), Some(film.filter), film.crop);
                }
                "sampler" => self.warn(c, "ignored: the experiment file sets the samples per pixel"),
                "ref" if c.attribute("id").is_some_and(|id| self.sampler_ids.contains(id)) => {
                    self.warn(c, "ignored: the experiment file sets the samples per pixel")
                }
                other => {
                    return Err(self.err(
                        c,
                        format!("unsupported element <{other}> in a sensor (film, sampler, medium, a <ref> to a sampler or medium)"),
                    ));
                }
            }
        }
        self.finish(&o)?;
        let (w, h) = (
            width.unwrap_or(DEFAULT_WIDTH as u32),
            height.unwrap_or(DEFAULT_HEIGHT as u32),
        );

        // Mitsuba's camera frame: columns left, up, forward, position. An orthographic
        // sensor's extent is the scale of its first two columns (its camera space spans
        // [−1, 1] × [−1/aspect, 1/aspect]).
        let col = |i: usize| m.col(i).truncate();
        let (mut left, mut up, mut fwd, eye) = (col(0), col(1), col(2), col(3));
        let extent = (left.length(), up.length());
        if orthographic {
            (left, up, fwd) = (left.normalize(), up.normalize(), fwd.normalize());
        }
        let rigid = [left, up, fwd].iter().all(|c| (c.length() - 1.0).abs() < 1e-4)
            && left.dot(up).abs() < 1e-4
            && left.dot(fwd).abs() < 1e-4
            && up.dot(fwd).abs() < 1e-4;
        if !rigid {
            return Err(self.err(
                n,
                "to_world: expected a rotation and translation only (no scale or shear on a camera)",
            ));
        }
        // A mirrored frame (pbrt's convention, which Mitsuba users write as a scale of −1 in
        // x) mirrors the image.
        let flip_x = DMat3::from_cols(left, up, fwd).determinant() < 0.0;
        let (wf, hf) = (w as f64, h as f64);
        let Some(half) = crate::camera::fov_half_extents(fov, &axis, (w, h)) else {
            return Err(self.err(
                n,
                format!("fov_axis: expected x, y, diagonal, smaller or larger, got {axis:?}"),
            ));
        };
        let half_h = half.y;
        let lens = if orthographic {
            Some(desc::LensDesc::Orthographic(desc::OrthographicDesc {
                height: 2.0 * extent.1 * hf / wf,
                width: Some(2.0 * extent.0),
            }))
        } else {
            thin_lens.map(desc::LensDesc::Thin)
        };
        Ok(CameraDesc {
            eye: Fixed(eye.to_array()),
            look_at: Fixed((eye + fwd).to_array()),
            up: Fixed(up.to_array()),
            fov_y: (!orthographic).then(|| 2.0 * half_h.atan().to_degrees()),
            lens,
            resolution: Fixed([w, h]),
            // A sensor without a film has Mitsuba's default film and its Gaussian.
            filter: Some(filter.unwrap_or(desc::FilterDesc::Gaussian(desc::GaussianFilterDesc { stddev: None }))),
            crop,
            flip_x,
            medium,
        })
    }

    pub(super) fn film(&mut self, n: Node<'a, 'i>) -> Result<Film> {
        let kind = self.required(n, "type")?;
        if kind != "hdrfilm" {
            return Err(self.err(n, format!("unsupported film {kind:?} (hdrfilm)")));
        }
        let mut o = self.obj(n)?;
        let mut size = [0u32; 2];
        for (i, (key, default)) in [("width", DEFAULT_WIDTH), ("height", DEFAULT_HEIGHT)]
            .into_iter()
            .enumerate()
        {
            let node = o.props.get(key).copied().unwrap_or(n);
            let v = self.integer(&mut o, key)?.unwrap_or(default);
            if !(1..=i64::from(crate::scene::limits::MAX_RESOLUTION_SIDE)).contains(&v) {
                return Err(self.err(
                    node,
                    format!(
                        "{key}: expected 1..={}, got {v}",
                        crate::scene::limits::MAX_RESOLUTION_SIDE
                    ),
                ));
            }
            size[i] = v as u32;
        }
        // These choose how Mitsuba writes its output file, not the image's values.
        for key in ["pixel_format", "component_format", "file_format"] {
            self.string(&mut o, key)?;
        }
        for key in ["banner", "sample_border"] {
            self.boolean(&mut o, key)?;
        }
        // Mitsuba's crop window: offset (0, 0) and the whole film unless told otherwise; it
        // must lie on the film (Mitsuba's `set_crop_window` refuses it otherwise, as the
        // camera's validation does here).
        let mut window = [0i64, 0, i64::from(size[0]), i64::from(size[1])];
        let mut cropped = false;
        for (i, key) in ["crop_offset_x", "crop_offset_y", "crop_width", "crop_height"]
            .into_iter()
            .enumerate()
        {
            let node = o.props.get(key).copied().unwrap_or(n);
            if let Some(v) = self.integer(&mut o, key)? {
                if !(0..=i64::from(crate::scene::limits::MAX_RESOLUTION_SIDE)).contains(&v) {
                    return Err(self.err(node, format!("{key}: expected a pixel count on the film, got {v}")));
                }
                window[i] = v;
                cropped = true;
            }
        }
        let crop = cropped.then(|| desc::CropDesc {
            offset: Some(desc::Fixed([window[0] as u32, window[1] as u32])),
            size: desc::Fixed([window[2] as u32, window[3] as u32]),
        });
        // Mitsuba's film reconstructs with a Gaussian unless told otherwise.
        let mut filter = desc::FilterDesc::Gaussian(desc::GaussianFilterDesc { stddev: None });
        let mut seen = false;
        for c in o.children.clone() {
            match c.tag_name().name() {
                "rfilter" if seen => return Err(self.err(c, "a second <rfilter>")),
                "rfilter" => {
                    seen = true;
                    filter = self.rfilter(c)?;
                }
                other => return Err(self.err(c, format!("unsupported element <{other}> in a film (rfilter)"))),
            }
        }
        self.finish(&o)?;
        Ok(Film {
            width: size[0],
            height: size[1],
            filter,
            crop,
        })
    }

    /// `<rfilter>`: `box`, `tent` (`radius`) or `gaussian` (`stddev`); Mitsuba's filters with
    /// negative lobes are refused (filter importance sampling needs a non-negative filter).
    fn rfilter(&mut self, n: Node<'a, 'i>) -> Result<desc::FilterDesc> {
        let kind = self.required(n, "type")?;
        let mut o = self.obj(n)?;
        let f = match kind.as_str() {
            "box" => desc::FilterDesc::Box(desc::BoxFilterDesc {}),
            "tent" => desc::FilterDesc::Tent(desc::TentFilterDesc {
                radius: self.float(&mut o, "radius")?,
            }),
            "gaussian" => desc::FilterDesc::Gaussian(desc::GaussianFilterDesc {
                stddev: self.float(&mut o, "stddev")?,
            }),
            other => {
                return Err(self.err(
                    n,
                    format!(
                        "unsupported rfilter {other:?} (box, tent, gaussian: photon-bench samples pixels by \
                         the filter, which needs one without negative lobes)"
                    ),
                ));
            }
        };
        self.finish(&o)?;
        Ok(f)
    }
}
