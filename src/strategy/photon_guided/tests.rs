//! Tests of the guided sampler: precomputed pdfs equal the built ones, χ² of the precomputed
//! and glossy samplers against their pdfs, light sampling options leave the map unchanged.

use super::*;
use crate::bsdf::{Bsdf, Phong, TransportMode};
use crate::geometry::Frame;
use crate::sampling::Rng;
use crate::sampling::chi2::{CHI2_ALPHA, DirectionTest, chi2_test_directions};
use crate::sampling::sample_uniform_hemisphere;
use crate::scene::SurfaceHit;
use crate::strategy::path::DirectionSampler;

/// A glossy vertex at the origin (normal +z) with photons arriving mostly from one side.
fn glossy_vertex() -> (GuideMap, SurfaceHit, Bsdf, Vec3) {
    let mut rng = Rng::for_task(11, [0, 0, 0]);
    let lobe = Vec3::new(-0.6, 0.2, 0.77).normalize();
    let photons = (0..200)
        .map(|k| {
            let d = if k % 4 == 0 {
                sample_uniform_hemisphere(rng.uniform2())
            } else {
                (lobe + 0.3 * (sample_uniform_hemisphere(rng.uniform2()) - Vec3::Z)).normalize()
            };
            GuidePhoton {
                position: Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, 0.0) * 0.1,
                direction: d,
                normal: Vec3::Z,
                flux: 0.5 + rng.uniform(),
            }
        })
        .collect();
    let hit = SurfaceHit {
        t: 1.0,
        p: Vec3::ZERO,
        ng: Vec3::Z,
        frame: Frame::from_normal(Vec3::Z),
        prim: 0,
        material: 0,
        bary: glam::Vec2::ZERO,
    };
    let bsdf = Bsdf::Phong(Phong {
        diffuse: Vec3::splat(0.3),
        specular: Vec3::splat(0.5),
        exponent: 20.0,
    });
    (
        GuideMap::build(photons),
        hit,
        bsdf,
        Vec3::new(0.5, -0.1, 0.86).normalize(),
    )
}

/// Photons at the origin's neighbourhood on both sides of a surface with normal `n`: those
/// on the front arrive mostly from one direction, those on the back from another.
fn two_sided_photons(n: Vec3) -> GuideMap {
    let mut rng = Rng::for_task(12, [0, 0, 0]);
    let frame = Frame::from_normal(n);
    let lobes = [Vec3::new(0.5, 0.3, 0.81), Vec3::new(-0.4, 0.6, 0.69)];
    let photons = (0..400)
        .map(|k| {
            let side = if k % 2 == 0 { 1.0 } else { -1.0 };
            let lobe = lobes[k % 2].normalize();
            let local = if k % 5 == 0 {
                sample_uniform_hemisphere(rng.uniform2())
            } else {
                (lobe + 0.4 * (sample_uniform_hemisphere(rng.uniform2()) - Vec3::Z)).normalize()
            };
            let offset = Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, 0.0) * 0.1;
            GuidePhoton {
                position: frame.to_world(offset),
                direction: frame.to_world(Vec3::new(local.x, local.y, side * local.z)),
                normal: side * n,
                flux: 0.5 + rng.uniform(),
            }
        })
        .collect();
    GuideMap::build(photons)
}

fn precomputing_params() -> PhotonGuidedParams {
    PhotonGuidedParams {
        precomputed_pdfs: Some(Precomputed::default()),
        ..PhotonGuidedParams::default()
    }
}

fn hit_at(p: Vec3, frame: Frame) -> SurfaceHit {
    SurfaceHit {
        t: 1.0,
        p,
        ng: frame.n,
        frame,
        prim: 0,
        material: 0,
        bary: glam::Vec2::ZERO,
    }
}

/// The tangent `frame.s` turned by `angle` about `frame.n`.
fn turned(frame: Frame, angle: f32) -> Vec3 {
    frame.s * angle.cos() + frame.t * angle.sin()
}

/// At a vertex on a record's photon, the precomputed pdf is, direction for direction, the
/// pdf the vertex would build in the record's frame, on either side of the surface, whatever
/// the vertex's own tangent (here turned 50° from the record's). On the back the record's
/// frame is a rotation of the mirrored frame a vertex builds in; both bin φ alike, since the
/// φ-cells are symmetric under φ → −φ.
#[test]
fn precomputed_pdf_at_its_own_photon_is_the_built_pdf() {
    let n = Vec3::new(0.2, -0.3, 0.93).normalize();
    let map = two_sided_photons(n);
    let params = precomputing_params();
    let records = precompute_pdfs(&map, &params, 1);
    let sampler = GridSampler {
        map: &map,
        params: &params,
        records: Some(&records),
    };
    let mut rng = Rng::for_task(13, [0, 0, 0]);
    let mut checked = [0, 0];
    for record in records.tree.items().iter().take(40) {
        // Lookups rebuild the tangent from the normal the search returns.
        assert_eq!(record.tangent, Frame::from_normal(record.normal).s);
        let flip = record.normal.dot(n) < 0.0;
        let aligned = Frame::from_normal_tangent(n, record.tangent);
        let built = GuidedVertex::Built {
            grid: sampler.grid_at(&hit_at(record.position, aligned), flip),
            flip,
        };
        let own = Frame::from_normal_tangent(n, turned(aligned, 50f32.to_radians()));
        let cached = sampler
            .precomputed_at(&hit_at(record.position, own), flip)
            .expect("a record passes at its own photon");
        for _ in 0..200 {
            let local = sample_uniform_hemisphere(rng.uniform2());
            let w = aligned.to_world(mirror(local, flip));
            let (a, b) = (
                sampler.grid_pdf(&cached, own.to_local(w)),
                sampler.grid_pdf(&built, aligned.to_local(w)),
            );
            assert!(a > 0.0, "every direction above the vertex is possible");
            // The stored grids round each cell's probability to 1/65 535 of the largest one
            // (`QuantizedGrids`, whose test derives the bound; here with p_max ≤ 1).
            let cells = (params.grid[0] * params.grid[1]) as f32;
            let quantised = 1.01 * (b + local.z * std::f32::consts::FRAC_1_PI) * cells / 65535.0;
            assert!(
                (a - b).abs() <= 1e-4 * b + quantised,
                "flip {flip}: precomputed {a} vs built {b} at {w}"
            );
        }
        checked[flip as usize] += 1;
    }
    assert!(checked[0] > 10 && checked[1] > 10, "both sides checked: {checked:?}");
}

/// A vertex whose normal differs from its record's (a tilted record, within the normal
/// test) samples the record's pdf rotated into its own frame: the sampler must still draw
/// directions with the pdf it reports, over the whole sphere, on both sides.
#[test]
fn precomputed_pdf_of_a_tilted_record_passes_chi2_against_its_pdf() {
    let record_normal = Vec3::new(0.0, 0.35, 0.94).normalize();
    let map = two_sided_photons(record_normal);
    let params = precomputing_params();
    let records = precompute_pdfs(&map, &params, 3);
    let sampler = GridSampler {
        map: &map,
        params: &params,
        records: Some(&records),
    };
    let bsdf = Bsdf::Lambertian(crate::bsdf::Lambertian {
        reflectance: Vec3::splat(0.7),
    });
    let z = Frame::from_normal(Vec3::Z);
    let hit = hit_at(
        Vec3::new(0.01, 0.02, 0.0),
        Frame::from_normal_tangent(Vec3::Z, turned(z, 0.9)),
    );
    for wo in [Vec3::new(0.3, 0.2, 0.93), Vec3::new(-0.2, 0.4, -0.89)] {
        let wo = wo.normalize();
        let v = sampler
            .precomputed_at(&hit, wo.z < 0.0)
            .expect("the tilted record passes");
        let report = chi2_test_directions(
            |rng: &mut Rng| sampler.sample(&v, &bsdf, wo, rng).map(|s| (s.wi, s.pdf_w)),
            |wi| sampler.pdf(&v, &bsdf, wo, wi),
            DirectionTest::default(),
        );
        assert!(report.passes(CHI2_ALPHA), "wo {wo}: {report:?}");
    }
}

/// The light sampling options change next-event estimation only: the photon map that
/// guiding builds its pdfs from (emission ∝ power, as Jensen's photons) is the same photon
/// for photon with `light_selection = "local"` and `sphere_light_sampling = "cone"`.
#[test]
fn light_sampling_options_leave_the_photon_map_unchanged() {
    let scene = {
        let mut b = crate::photon::test_scenes::SceneBuilder::new();
        let grey = b.lambertian(Vec3::splat(0.6));
        b.closed_box(grey, Vec3::splat(4.0));
        b.build()
    };
    let map = |light_selection, sphere_light_sampling| {
        let mut g = PhotonGuided::new(PhotonGuidedParams {
            photons: 2000,
            light_selection,
            sphere_light_sampling,
            ..PhotonGuidedParams::default()
        })
        .unwrap();
        g.prepare(&scene, 4).unwrap();
        g.map()
            .unwrap()
            .items()
            .iter()
            .map(|p| (p.position, p.direction, p.flux))
            .collect::<Vec<_>>()
    };
    let power = map(LightSelection::Power, SphereSampling::Area);
    assert_eq!(power.len(), 2000);
    assert_eq!(power, map(LightSelection::Local, SphereSampling::Cone));
}

/// The guided sampler at a glossy vertex (product grid, with and without the BSDF mixture)
/// draws directions with the pdf it reports: a chi-square test over the sphere.
#[test]
fn glossy_guided_sampler_passes_chi2_against_its_pdf() {
    for bsdf_mixture in [0.0, 0.3] {
        let params = PhotonGuidedParams {
            glossy: true,
            bsdf_mixture,
            ..PhotonGuidedParams::default()
        };
        let (map, hit, bsdf, wo) = glossy_vertex();
        let sampler = GridSampler {
            map: &map,
            params: &params,
            records: None,
        };
        let grid = sampler.product_grid_at(&hit, false, |wi| luminance(bsdf.eval(wo, wi, TransportMode::Radiance)));
        let v = GuidedVertex::Built { grid, flip: false };
        let report = chi2_test_directions(
            |rng: &mut Rng| sampler.sample(&v, &bsdf, wo, rng).map(|s| (s.wi, s.pdf_w)),
            |wi| sampler.pdf(&v, &bsdf, wo, wi),
            DirectionTest::default(),
        );
        assert!(report.passes(CHI2_ALPHA), "mixture {bsdf_mixture}: {report:?}");
    }
}
