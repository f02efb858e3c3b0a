//! Jensen's photon-built pdf at a path vertex [Jensen 1995, §3–4]: the grid of the N nearest
//! photons' flux over the cosine-warped hemisphere (or of f_r · ΔΦ at glossy vertices), the
//! precomputed pdfs at every k-th photon, and the direction sampler the guided path tracer
//! calls (sample, pdf, and the weight s of eq. (11)).

use super::*;
use crate::bsdf::{Bsdf, BsdfSample, TransportMode};
use crate::color::luminance;
use crate::geometry::Frame;
use crate::photon::{FacingTree, Neighbour};
use crate::sampling::Rng;
use crate::sampling::photon_grid::{PhotonGrid, QuantizedGrids};
use crate::scene::{Scene, SurfaceHit};
use crate::strategy::path::{BsdfSampling, DirectionSampler};
use glam::Vec3;
use rayon::prelude::*;
use std::cell::RefCell;

/// Jensen's pdf at every `every`-th photon of `map` (in kd-tree order, so the set depends on
/// the seed only), each built for the side its photon arrived on.
pub fn precompute_pdfs(map: &GuideMap, params: &PhotonGuidedParams, every: usize) -> PdfRecords {
    let sampler = GridSampler {
        map,
        params,
        records: None,
    };
    let built: Vec<(Vec3, PhotonGrid)> = map
        .items()
        .par_chunks(every)
        .map(|chunk| {
            let ph = &chunk[0];
            let frame = Frame::from_normal(ph.normal);
            (frame.s, sampler.product_grid_in(ph.position, &frame, false, |_| 1.0))
        })
        .collect();
    let keys = map.items().iter().step_by(every).zip(&built).enumerate();
    let keys = keys.map(|(id, (ph, (tangent, _)))| PdfRecord {
        position: ph.position,
        normal: ph.normal,
        tangent: *tangent,
        id: id as u32,
    });
    let mut grids = QuantizedGrids::new(params.grid[0], params.grid[1]);
    built.iter().for_each(|(_, grid)| grids.push(grid));
    PdfRecords {
        tree: FacingTree::build(keys.collect(), |r: &PdfRecord| r.normal, |r: &PdfRecord| r.id),
        grids,
    }
}

/// Direction choice with Jensen's grid at Lambertian vertices.
pub struct GridSampler<'a> {
    pub map: &'a GuideMap,
    pub params: &'a PhotonGuidedParams,
    /// Precomputed pdfs (`precomputed_pdfs`), if any.
    pub records: Option<&'a PdfRecords>,
}

/// A guided vertex's pdf.
pub enum GuidedVertex {
    /// BSDF sampling (a vertex that is not guided).
    Bsdf,
    /// The grid built at the vertex in its local frame, mirrored (z → −z) when `flip`, so that
    /// +z faces `wo`.
    Built { grid: PhotonGrid, flip: bool },
    /// The grid of precomputed record `record`; `frame` takes the grid's local directions to the
    /// vertex's local frame (its +z faces `wo`).
    Precomputed { record: u32, frame: Frame },
}

#[inline]
pub(super) fn mirror(w: Vec3, flip: bool) -> Vec3 {
    if flip { Vec3::new(w.x, w.y, -w.z) } else { w }
}

thread_local! {
    static NEIGHBOURS: RefCell<Vec<Neighbour>> = const { RefCell::new(Vec::new()) };
}

impl GridSampler<'_> {
    /// Jensen's pdf at `hit` for the side `wo` is on (a Lambertian vertex: f_r is constant).
    pub fn grid_at(&self, hit: &SurfaceHit, flip: bool) -> PhotonGrid {
        self.product_grid_at(hit, flip, |_| 1.0)
    }

    /// The grid of f_r(ω_p) ΔΦ_p at `hit`; `f_r` takes the photon's direction in the hit's
    /// local frame (not mirrored) and returns the luminance of the BSDF for the vertex's ωo.
    pub fn product_grid_at(&self, hit: &SurfaceHit, flip: bool, f_r: impl Fn(Vec3) -> f32) -> PhotonGrid {
        self.product_grid_in(hit.p, &hit.frame, flip, f_r)
    }

    /// The grid of f_r ΔΦ at `p` in `frame` (mirrored when `flip`), from the N nearest photons
    /// that arrived on the side it faces.
    pub(super) fn product_grid_in(&self, p: Vec3, frame: &Frame, flip: bool, f_r: impl Fn(Vec3) -> f32) -> PhotonGrid {
        let n = if flip { -frame.n } else { frame.n };
        NEIGHBOURS.with(|buf| {
            let mut found = buf.borrow_mut();
            self.map
                .k_nearest_on_side(p, n, self.params.nearest, self.params.max_radius, &mut found);
            let dirs = found.iter().map(|nb| {
                let (direction, flux) = self.map.direction_and_flux(nb.index);
                let local = frame.to_local(direction);
                (mirror(local, flip), f_r(local) * flux)
            });
            let p = self.params;
            PhotonGrid::build(dirs, p.grid[0], p.grid[1], p.epsilon, p.empty_cells)
        })
    }

    /// The precomputed record for a Lambertian vertex at `hit` on the side `flip` says: the
    /// nearest record within `max_radius` whose normal passes the test, with the frame taking
    /// its grid's directions into the vertex's local frame.
    pub(super) fn precomputed_at(&self, hit: &SurfaceHit, flip: bool) -> Option<GuidedVertex> {
        let (records, pre) = (self.records?, self.params.precomputed_pdfs.as_ref()?);
        let n = if flip { -hit.frame.n } else { hit.frame.n };
        let found = records
            .tree
            .nearest_facing(hit.p, n, pre.normal_dot, self.params.max_radius)?;
        records.grids.prefetch(found.payload as usize);
        // The record's tangent is a function of its normal ([`precompute_pdfs`]), which the
        // search read from its blocks: the record itself (a cache miss) is not read.
        let tangent = Frame::from_normal(found.normal).s;
        let n_local = if flip { -Vec3::Z } else { Vec3::Z };
        Some(GuidedVertex::Precomputed {
            record: found.payload,
            frame: Frame::from_normal_tangent(n_local, hit.frame.to_local(tangent)),
        })
    }

    /// A direction (vertex-local) from the vertex's grid.
    pub(super) fn sample_grid(&self, v: &GuidedVertex, u: glam::Vec2) -> Option<Vec3> {
        match v {
            GuidedVertex::Bsdf => None,
            GuidedVertex::Built { grid, flip } => Some(mirror(grid.sample(u).0, *flip)),
            GuidedVertex::Precomputed { record, frame } => {
                let records = self.records.expect("a precomputed vertex has records");
                Some(frame.to_world(records.grids.sample(*record as usize, u).0))
            }
        }
    }

    /// The grid's solid-angle pdf of the vertex-local direction `wi`.
    pub(super) fn grid_pdf(&self, v: &GuidedVertex, wi: Vec3) -> f32 {
        match v {
            GuidedVertex::Bsdf => 0.0,
            GuidedVertex::Built { grid, flip } => grid.pdf(mirror(wi, *flip)),
            GuidedVertex::Precomputed { record, frame } => {
                let records = self.records.expect("a precomputed vertex has records");
                records.grids.pdf(*record as usize, frame.to_local(wi))
            }
        }
    }
}

impl DirectionSampler for GridSampler<'_> {
    type Vertex = GuidedVertex;

    fn vertex(&self, _: &Scene, hit: &SurfaceHit, bsdf: &Bsdf, wo: Vec3) -> GuidedVertex {
        let flip = wo.z < 0.0;
        match bsdf.seen_from(wo) {
            Some(Bsdf::Lambertian(_)) => self.precomputed_at(hit, flip).unwrap_or_else(|| GuidedVertex::Built {
                grid: self.grid_at(hit, flip),
                flip,
            }),
            Some(Bsdf::Phong(_) | Bsdf::Ward(_)) if self.params.glossy => GuidedVertex::Built {
                grid: self.product_grid_at(hit, flip, |wi| luminance(bsdf.eval(wo, wi, TransportMode::Radiance))),
                flip,
            },
            _ => GuidedVertex::Bsdf,
        }
    }

    fn sample(&self, v: &GuidedVertex, bsdf: &Bsdf, wo: Vec3, rng: &mut Rng) -> Option<BsdfSample> {
        if let GuidedVertex::Bsdf = v {
            return BsdfSampling::Importance.sample(&(), bsdf, wo, rng);
        }
        let alpha = self.params.bsdf_mixture;
        let (u, u_choice) = (rng.uniform2(), rng.uniform());
        let (wi, drawn) = if u_choice < alpha {
            // Given this branch, u_choice / α is uniform again: it picks a glossy model's lobe.
            let s = bsdf.sample(wo, u, u_choice / alpha, TransportMode::Radiance)?;
            (s.wi, Some(s))
        } else {
            (self.sample_grid(v, u)?, None)
        };
        BsdfSample::of_mixture(bsdf, wo, wi, drawn.as_ref(), self.pdf(v, bsdf, wo, wi))
    }

    fn pdf(&self, v: &GuidedVertex, bsdf: &Bsdf, wo: Vec3, wi: Vec3) -> f32 {
        if let GuidedVertex::Bsdf = v {
            return bsdf.pdf(wo, wi);
        }
        let alpha = self.params.bsdf_mixture;
        let p_grid = self.grid_pdf(v, wi);
        if alpha > 0.0 {
            alpha * bsdf.pdf(wo, wi) + (1.0 - alpha) * p_grid
        } else {
            p_grid
        }
    }
}
