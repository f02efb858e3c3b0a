//! Micro-benchmarks of the renderer's kernels on the shipped scenes:
//!
//! - `bvh/closest` and `bvh/shadow`: closest-hit and early-exit shadow queries on Mitsuba's
//!   Cornell box (`scenes/cornell-box.toml`) for 100 000 rays from points on its surfaces in
//!   uniformly random directions (shadow rays: length 0.25);
//! - `bsdf/sample/<model>`: one `sample` call per iteration of each reflectance model;
//! - `photon_grid/build` and `photon_grid/sample`: Jensen 1995's 4 × 16 pdf from 50 photons and
//!   one direction drawn from it;
//! - `metropolis/<proposal>`: one Metropolis step (proposal, contribution, acceptance) of each
//!   proposal alone on `cornell-spheres` (BD, PM, CP, LP, LS; UP needs user paths: `box`).
//!
//! Run: `cargo bench --bench kernels` (throughputs in elements/s). Timings in results and the
//! README always come with the machine's core count; these run on one thread.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::{Vec2, Vec3};
use photon_bench::bsdf::{Bsdf, Dielectric, DiffuseTransmission, Lambertian, Mirror, Phong, TransportMode, Ward};
use photon_bench::geometry::{Ray, spawn_ray};
use photon_bench::sampling::photon_grid::{EmptyCells, PhotonGrid};
use photon_bench::sampling::{Rng, sample_uniform_hemisphere, sample_uniform_sphere};
use photon_bench::scene::load_scene;
use std::hint::black_box;
use std::path::Path;

const RAYS: usize = 100_000;

fn bvh(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml");
    let scene = load_scene(&path).expect("the shipped scene loads");
    let mut rng = Rng::for_task(1, [0, 0, 0]);
    // Ray origins on the surfaces: first hits of camera rays.
    let rays: Vec<Ray> = (0..RAYS)
        .filter_map(|i| {
            let w = scene.camera.width as usize;
            let raster = Vec2::new((i % w) as f32, ((i / w) % scene.camera.height as usize) as f32) + rng.uniform2();
            let hit = scene.intersect(&scene.camera.generate_ray(raster))?;
            let mut d = sample_uniform_sphere(rng.uniform2());
            if d.dot(hit.ng) < 0.0 {
                d = -d;
            }
            Some(spawn_ray(hit.p, hit.ng, d))
        })
        .collect();
    let mut g = c.benchmark_group("bvh");
    g.throughput(Throughput::Elements(rays.len() as u64));
    g.bench_function("closest", |b| {
        b.iter(|| rays.iter().filter(|r| scene.accel.intersect(r).is_some()).count())
    });
    let shadow: Vec<Ray> = rays.iter().map(|r| Ray { t_max: 0.25, ..*r }).collect();
    g.bench_function("shadow", |b| {
        b.iter(|| shadow.iter().filter(|r| scene.accel.unoccluded(r)).count())
    });
    g.finish();
}

fn bsdf(c: &mut Criterion) {
    let grey = Vec3::splat(0.5);
    let models = [
        ("lambertian", Bsdf::Lambertian(Lambertian { reflectance: grey })),
        ("mirror", Bsdf::Mirror(Mirror { reflectance: grey })),
        ("dielectric", Bsdf::Dielectric(Dielectric::clear(1.5))),
        (
            "phong",
            Bsdf::Phong(Phong {
                diffuse: Vec3::splat(0.3),
                specular: Vec3::splat(0.5),
                exponent: 50.0,
            }),
        ),
        (
            "ward",
            Bsdf::Ward(Ward {
                diffuse: Vec3::splat(0.3),
                specular: Vec3::splat(0.5),
                alpha_x: 0.1,
                alpha_y: 0.3,
            }),
        ),
        (
            "diffuse_transmission",
            Bsdf::DiffuseTransmission(DiffuseTransmission {
                reflectance: grey,
                transmittance: Vec3::splat(0.4),
            }),
        ),
    ];
    let mut g = c.benchmark_group("bsdf/sample");
    g.throughput(Throughput::Elements(1));
    for (name, model) in &models {
        let mut rng = Rng::for_task(2, [0, 0, 0]);
        let wo = Vec3::new(0.3, -0.2, 0.9).normalize();
        g.bench_function(*name, |b| {
            b.iter(|| black_box(model.sample(wo, rng.uniform2(), rng.uniform(), TransportMode::Radiance)))
        });
    }
    g.finish();
}

fn photon_grid(c: &mut Criterion) {
    let mut rng = Rng::for_task(3, [0, 0, 0]);
    let photons: Vec<(Vec3, f32)> = (0..50)
        .map(|_| (sample_uniform_hemisphere(rng.uniform2()), rng.uniform()))
        .collect();
    let mut g = c.benchmark_group("photon_grid");
    g.throughput(Throughput::Elements(1));
    g.bench_function("build", |b| {
        b.iter(|| {
            black_box(PhotonGrid::build(
                photons.iter().copied(),
                4,
                16,
                0.01,
                EmptyCells::Each,
            ))
        })
    });
    let grid = PhotonGrid::build(photons.iter().copied(), 4, 16, 0.01, EmptyCells::Each);
    g.bench_function("sample", |b| b.iter(|| black_box(grid.sample(rng.uniform2()))));
    g.finish();
}

fn metropolis(c: &mut Criterion) {
    use photon_bench::metropolis::proposals::Context;
    use photon_bench::metropolis::{
        Chain, MetropolisParams, Proposal, ProposalMix, State, Tally, estimate_b, prepare_user_paths,
    };
    let mut g = c.benchmark_group("metropolis");
    g.throughput(Throughput::Elements(1));
    for (file, kinds) in [
        (
            "scenes/cornell-spheres.toml",
            &[Proposal::Bd, Proposal::Pm, Proposal::Cp, Proposal::Lp, Proposal::Ls][..],
        ),
        ("scenes/box.toml", &[Proposal::Up, Proposal::Mc][..]),
    ] {
        let scene = load_scene(&Path::new(env!("CARGO_MANIFEST_DIR")).join(file)).expect("the shipped scene loads");
        let base = MetropolisParams {
            b_samples: Some(20_000),
            chains: 1,
            ..MetropolisParams::default()
        };
        let (_, starts) = estimate_b(&scene, &base, 1).expect("light reaches the image");
        let user_paths = prepare_user_paths(&scene).expect("valid user paths");
        for &kind in kinds {
            let params = MetropolisParams {
                proposals: ProposalMix::only(kind),
                ..base.clone()
            };
            let ctx = Context::new(&scene, &params, &user_paths);
            let mut chain = Chain::new(ctx, State::new(&scene, starts[0].clone()).expect("a valid first state"));
            let mut rng = Rng::for_task(2, [0, 0, 0]);
            let mut tally = Tally::default();
            g.bench_function(kind.name(), |b| {
                b.iter(|| {
                    let step = chain.step(&mut rng, &mut tally);
                    chain.commit(black_box(step));
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bvh, bsdf, photon_grid, metropolis);
criterion_main!(benches);
