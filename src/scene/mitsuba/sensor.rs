//! The `<sensor>` and its `<film>`: camera placement, field of view, resolution.

use super::*;
use crate::error::Result;
use crate::scene::desc::{CameraDesc, Fixed};
use glam::{DMat3, DMat4};
use roxmltree::Node;

impl<'a, 'i> Reader<'a, 'i> {
    pub(super) fn sensor(&mut self, n: Node<'a, 'i>) -> Result<CameraDesc> {
        let kind = self.required(n, "type")?;
        if kind != "perspective" {
            return Err(self.err(
                n,
                format!("unsupported sensor {kind:?}: photon-bench has a pinhole camera (perspective)"),
            ));
        }
        let mut o = self.obj(n)?;
        let Some(fov) = self.float(&mut o, "fov")? else {
            return Err(self.err(n, "expected <float name=\"fov\"> (focal_length is not supported)"));
        };
        if !(fov > 0.0 && fov < 180.0) {
            return Err(self.err(n, format!("fov: expected degrees in (0, 180), got {fov}")));
        }
        let axis = match self.string(&mut o, "fov_axis")? {
            None => "x".to_string(),
            Some((_, a)) => a,
        };
        for clip in ["near_clip", "far_clip"] {
            if let Some(p) = o.props.get(clip).copied() {
                self.float(&mut o, clip)?;
                self.warn(p, "ignored: photon-bench's camera has no clipping planes");
            }
        }
        // A pinhole has everything in focus; Mitsuba's `perspective` ignores it too (only
        // `thinlens` reads it).
        self.float(&mut o, "focus_distance")?;
        let m = match self.transform(&mut o, "to_world")? {
            Some((_, m)) => m,
            None => DMat4::IDENTITY,
        };
        let (mut width, mut height, mut filter) = (None, None, None);
        for c in o.children.clone() {
            match c.tag_name().name() {
                "film" => {
                    if width.is_some() {
                        return Err(self.err(c, "a second <film>"));
                    }
                    let (w, h, f) = self.film(c)?;
                    (width, height, filter) = (Some(w), Some(h), Some(f));
                }
                "sampler" => self.warn(c, "ignored: the experiment file sets the samples per pixel"),
                "ref" if c.attribute("id").is_some_and(|id| self.sampler_ids.contains(id)) => {
                    self.warn(c, "ignored: the experiment file sets the samples per pixel")
                }
                other => {
                    return Err(self.err(
                        c,
                        format!("unsupported element <{other}> in a sensor (film, sampler, a <ref> to a sampler)"),
                    ));
                }
            }
        }
        self.finish(&o)?;
        let (w, h) = (
            width.unwrap_or(DEFAULT_WIDTH as u32),
            height.unwrap_or(DEFAULT_HEIGHT as u32),
        );

        // Mitsuba's camera frame: columns left, up, forward, position.
        let col = |i: usize| m.col(i).truncate();
        let (left, up, fwd, eye) = (col(0), col(1), col(2), col(3));
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
        if DMat3::from_cols(left, up, fwd).determinant() < 0.0 {
            return Err(self.err(n, "to_world: a mirrored camera (negative determinant) is not supported"));
        }
        let (wf, hf) = (w as f64, h as f64);
        let t = (0.5 * fov.to_radians()).tan();
        let half_h = match axis.as_str() {
            "x" => t * hf / wf,
            "y" => t,
            "diagonal" => t * hf / (wf * wf + hf * hf).sqrt(),
            "smaller" if w < h => t * hf / wf,
            "smaller" => t,
            "larger" if w > h => t * hf / wf,
            "larger" => t,
            other => {
                return Err(self.err(
                    n,
                    format!("fov_axis: expected x, y, diagonal, smaller or larger, got {other:?}"),
                ));
            }
        };
        Ok(CameraDesc {
            eye: Fixed(eye.to_array()),
            look_at: Fixed((eye + fwd).to_array()),
            up: Fixed(up.to_array()),
            fov_y: 2.0 * half_h.atan().to_degrees(),
            resolution: Fixed([w, h]),
            // A sensor without a film has Mitsuba's default film and its Gaussian.
            filter: Some(filter.unwrap_or(desc::FilterDesc::Gaussian(desc::GaussianFilterDesc { stddev: None }))),
        })
    }

    pub(super) fn film(&mut self, n: Node<'a, 'i>) -> Result<(u32, u32, desc::FilterDesc)> {
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
        Ok((size[0], size[1], filter))
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
