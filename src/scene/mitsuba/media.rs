//! `<medium>` elements (Mitsuba 3's `homogeneous` and `heterogeneous`, with their `phase`, a
//! `gridvolume` or `constvolume` albedo and a heterogeneous medium's `gridvolume` σ_t) and the
//! `interior` / `exterior` / sensor `medium` references to them.

use super::*;
use crate::error::Result;
use crate::scene::desc::{self, Fixed, GridDesc, HeterogeneousDesc, HomogeneousDesc, MediumDesc, PhaseDesc};
use roxmltree::Node;

impl<'a, 'i> Reader<'a, 'i> {
    /// `<medium type="homogeneous">`: σ_t (a colour; a spectrally flat one when given as a
    /// float; a `heterogeneous` medium's is a nested `<volume name="sigma_t">`), `scale`, `albedo` (a colour or a nested `<volume>`), `sample_emitters`, a nested
    /// `<phase>`. `has_spectral_extinction` only chooses how Mitsuba samples distances (the
    /// expectation is the same) and is read without effect.
    pub(super) fn medium(&mut self, n: Node<'a, 'i>) -> Result<MediumDesc> {
        let kind = self.required(n, "type")?;
        if kind != "homogeneous" && kind != "heterogeneous" {
            return Err(self.err(
                n,
                "unsupported medium (photon-bench reads homogeneous and heterogeneous)",
            ));
        }
        let mut o = self.obj(n)?;
        let named_volume = |o: &Obj, name: &str| {
            o.children
                .iter()
                .any(|c| c.has_tag_name("volume") && c.attribute("name") == Some(name))
        };
        // Nested <volume>s first: the colour reader refuses nested objects.
        let sigma_t = if named_volume(&o, "sigma_t") {
            None
        } else {
            self.unbounded_colour(&mut o, "sigma_t")?
        };
        if kind == "heterogeneous" && sigma_t.is_some() {
            return Err(self.err(
                n,
                "a heterogeneous medium's sigma_t must be a <volume type=\"gridvolume\"> (a constant one is a homogeneous medium)",
            ));
        }
        let scale = self.float(&mut o, "scale")?;
        let sample_emitters = self.boolean(&mut o, "sample_emitters")?;
        self.boolean(&mut o, "has_spectral_extinction")?;
        let mut albedo = if named_volume(&o, "albedo") {
            None
        } else {
            self.colour(&mut o, "albedo")?
        };
        let (mut albedo_grid, mut sigma_t_grid, mut phase) = (None, None, None);
        for c in o.children.clone() {
            match (c.tag_name().name(), c.attribute("name")) {
                ("phase", _) if phase.is_some() => return Err(self.err(c, "a second phase function for this medium")),
                ("phase", _) => phase = Some(self.phase(c)?),
                ("volume", Some("albedo")) if albedo.is_none() && albedo_grid.is_none() => match self.volume(c)? {
                    Volume::Constant(a) => albedo = Some(a),
                    Volume::Grid(g) => albedo_grid = Some(g),
                },
                ("volume", Some("sigma_t")) if kind == "heterogeneous" && sigma_t_grid.is_none() => {
                    match self.volume(c)? {
                        Volume::Grid(g) => sigma_t_grid = Some(g),
                        Volume::Constant(_) => {
                            return Err(self.err(
                                c,
                                "a heterogeneous medium's sigma_t must be a gridvolume (a constant one is a homogeneous medium)",
                            ));
                        }
                    }
                }
                ("volume", Some("sigma_t")) => {
                    return Err(self.err(
                        c,
                        "a homogeneous medium's sigma_t is a constant (a spatially varying one makes a heterogeneous medium)",
                    ));
                }
                _ => {
                    return Err(self.err(
                        c,
                        "unsupported element in a medium (phase, volume name=\"albedo\" or \"sigma_t\")",
                    ));
                }
            }
        }
        self.finish(&o)?;
        if kind == "heterogeneous" {
            let Some(sigma_t_grid) = sigma_t_grid else {
                return Err(self.err(n, "expected <volume name=\"sigma_t\" type=\"gridvolume\">"));
            };
            return Ok(MediumDesc::Heterogeneous(HeterogeneousDesc {
                sigma_t_grid,
                scale,
                albedo,
                albedo_grid,
                phase,
                sample_emitters,
            }));
        }
        Ok(MediumDesc::Homogeneous(HomogeneousDesc {
            sigma_t,
            scale,
            albedo,
            albedo_grid,
            phase,
            sample_emitters,
        }))
    }

    /// `<phase type="isotropic">` or `<phase type="hg">` with `g` (default 0.8, Mitsuba's).
    fn phase(&mut self, n: Node<'a, 'i>) -> Result<PhaseDesc> {
        let mut o = self.obj(n)?;
        let phase = match self.required(n, "type")?.as_str() {
            "isotropic" => PhaseDesc::Isotropic(desc::NoParams {}),
            "hg" => PhaseDesc::Hg(desc::HgDesc {
                g: self.float(&mut o, "g")?.unwrap_or(0.8),
            }),
            _ => return Err(self.err(n, "unsupported phase function (photon-bench reads isotropic and hg)")),
        };
        if let Some(&c) = o.children.first() {
            return Err(self.err(c, "unexpected element in a phase function"));
        }
        self.finish(&o)?;
        Ok(phase)
    }

    /// `<volume type="constvolume">` (its `value`) or `<volume type="gridvolume">` (`filename`,
    /// `filter_type`, `wrap_mode`, `to_world`, `use_grid_bbox`; `raw` only matters to spectral
    /// variants and is read without effect).
    fn volume(&mut self, n: Node<'a, 'i>) -> Result<Volume> {
        let mut o = self.obj(n)?;
        let v = match self.required(n, "type")?.as_str() {
            "constvolume" => Volume::Constant(self.colour(&mut o, "value")?.unwrap_or(Fixed([1.0; 3]))),
            "gridvolume" => {
                let Some((p, file)) = self.string(&mut o, "filename")? else {
                    return Err(self.err(n, "expected <string name=\"filename\">"));
                };
                let path = self.resolve(&file);
                if !path.is_file() {
                    return Err(self.err(p, format!("filename: cannot read {}: no such file", path.display())));
                }
                let filter = self.string(&mut o, "filter_type")?.map(|(_, s)| s);
                let wrap = self.string(&mut o, "wrap_mode")?.map(|(_, s)| s);
                self.boolean(&mut o, "raw")?;
                let use_grid_bbox = self.boolean(&mut o, "use_grid_bbox")?;
                let to_world = self
                    .transform(&mut o, "to_world")?
                    .map(|(_, m)| desc::TransformDesc::from_matrix(m));
                Volume::Grid(GridDesc {
                    file: self.loader_path(p, &file, &path)?,
                    filter,
                    wrap,
                    to_world,
                    use_grid_bbox,
                })
            }
            _ => return Err(self.err(n, "unsupported volume (photon-bench reads constvolume and gridvolume)")),
        };
        if let Some(&c) = o.children.first() {
            return Err(self.err(c, "unexpected element in a volume"));
        }
        self.finish(&o)?;
        Ok(v)
    }

    /// The medium a `<ref name="interior|exterior|medium" id>` or a nested `<medium name>`
    /// stands for: its name among the scene's media (a nested one is added under `fallback`).
    pub(super) fn medium_child(&mut self, c: Node<'a, 'i>, fallback: String) -> Result<String> {
        if c.has_tag_name("ref") {
            let id = self.required(c, "id")?;
            if !self.media.contains_key(&id) {
                return Err(self.err(c, format!("no top-level <medium id=\"{id}\"> to refer to")));
            }
            return Ok(id);
        }
        let name = self.attr(c, "id")?.unwrap_or(fallback);
        let m = self.medium(c)?;
        if self.media.insert(name.clone(), m).is_some() {
            return Err(self.err(c, format!("id {name:?} is used twice")));
        }
        Ok(name)
    }
}

/// What a `<volume>` element gives.
enum Volume {
    Constant(desc::Triple),
    Grid(GridDesc),
}
