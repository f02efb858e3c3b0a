//! Our photon kd-tree against kiddo's `ImmutableKdTree` on the same photons: 200 000 global
//! photons traced in `scenes/cornell-spheres.toml` and 100 000 query points (the positions of
//! photons from another seed, i.e. points on the surfaces, where estimates are made).
//!
//! - `build`: ours on the photon records (24 bytes, reordered in place; rayon over 2 threads
//!   and pinned to 1 thread) vs kiddo on their positions (`new_from_slice`, single-threaded
//!   without kiddo's `multi-threaded` feature).
//! - `knn`: k = 50 nearest within a 5 cm radius, 100 000 queries on one thread; throughput is
//!   queries/s. Ours reuses its result buffer (`k_nearest_into`); kiddo's `execute` returns a
//!   new `Vec` per query (its API has no buffer-reusing form) sorted by distance, while ours
//!   leaves the k in heap order (the estimates only sum over them); `ours_sorted` adds the
//!   sort for a like-for-like comparison.
//! - `knn_filtered` (ours only): the same with the estimate's normal test evaluated inside the
//!   search, the form the radiance estimate uses.
//!
//! - `nearest` (ours only): Christensen's lookup — the nearest photon whose normal is within
//!   the 0.9 cone of the query's — among every 4th photon, 100 000 queries on one thread:
//!   `where` as the generic `nearest_where` with the normal test as its predicate, `facing` as
//!   the precomputed irradiance and pdf lookups make it (`FacingTree`, normals tested eight at
//!   a time). Both return the same photons (checked before timing).
//!
//! - `scale` (ours only): build on one thread and k = 50 queries (unbounded radius, 10 000
//!   fixed queries, one thread) over the first N of 800 000 photons, N = 25 000 … 800 000:
//!   build time should grow as N log N (criterion's per-element time grows as log N) and the
//!   query rate fall slowly (O(log N + k)). `bench perf --photon-scale` measures the same on
//!   all threads, on any scene.
//!
//! Run: `cargo bench --bench kdtree` (`cargo bench --bench kdtree -- scale` for the series).

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use photon_bench::photon::{FacingTree, KdTree, Neighbour, Photon, TraceParams, trace_photons};
use photon_bench::scene::load_scene;
use std::hint::black_box;
use std::num::NonZero;
use std::path::Path;

const PHOTONS: usize = 200_000;
const QUERIES: usize = 100_000;
const K: usize = 50;
const MAX_RADIUS: f32 = 0.05;

/// The first `count` global photons of a trace of the scene with `seed`.
fn photons(count: usize, seed: u64) -> Vec<Photon> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-spheres.toml");
    let scene = load_scene(&path).expect("the shipped scene loads");
    let mut emitted = count as u64;
    loop {
        let params = TraceParams {
            photons: emitted,
            ..TraceParams::default()
        };
        let mut global = trace_photons(&scene, &params, seed).global;
        if global.len() >= count {
            global.truncate(count);
            return global;
        }
        emitted *= 2;
    }
}

fn bench(c: &mut Criterion) {
    let data = photons(PHOTONS, 1);
    let queries: Vec<Vec3> = photons(QUERIES, 2).iter().map(Photon::position).collect();
    let points: Vec<[f32; 3]> = data.iter().map(|p| p.position).collect();

    let ours = KdTree::build(data.clone());
    let theirs: ImmutableKdTree<f32, 3> = ImmutableKdTree::new_from_slice(&points).expect("finite points");
    let k = NonZero::new(K).expect("k > 0");

    // Both trees must agree before their speed means anything.
    let mut buf: Vec<Neighbour> = Vec::new();
    for q in queries.iter().step_by(997) {
        ours.k_nearest_into(*q, K, MAX_RADIUS, |_| true, &mut buf);
        let r = theirs
            .query(&q.to_array())
            .nearest_n::<SquaredEuclidean<f32>>(k)
            .within(MAX_RADIUS * MAX_RADIUS)
            .execute();
        // Both as sets: neither output is sorted.
        let mut a: Vec<f32> = buf.iter().map(|n| n.dist2).collect();
        let mut b: Vec<f32> = r.iter().map(|n| n.distance).collect();
        a.sort_by(f32::total_cmp);
        b.sort_by(f32::total_cmp);
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() <= 1e-6 * y.max(1e-6), "{x} vs {y}");
        }
    }

    let mut g = c.benchmark_group("build");
    g.sample_size(20);
    g.throughput(Throughput::Elements(PHOTONS as u64));
    g.bench_function(BenchmarkId::new("ours", "rayon"), |b| {
        b.iter(|| KdTree::build(black_box(data.clone())))
    });
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a thread pool");
    g.bench_function(BenchmarkId::new("ours", "1 thread"), |b| {
        b.iter(|| one.install(|| KdTree::build(black_box(data.clone()))))
    });
    g.bench_function(BenchmarkId::new("kiddo", "1 thread"), |b| {
        b.iter(|| ImmutableKdTree::<f32, 3>::new_from_slice(black_box(&points)).expect("finite points"))
    });
    g.finish();

    let mut g = c.benchmark_group("knn");
    g.sample_size(10);
    g.throughput(Throughput::Elements(QUERIES as u64));
    g.bench_function("ours", |b| {
        b.iter(|| {
            let mut sum = 0.0f32;
            for q in &queries {
                ours.k_nearest_into(*q, K, MAX_RADIUS, |_| true, &mut buf);
                sum += buf.first().map_or(0.0, |n| n.dist2);
            }
            sum
        })
    });
    g.bench_function("ours_sorted", |b| {
        b.iter(|| {
            let mut sum = 0.0f32;
            for q in &queries {
                ours.k_nearest_into(*q, K, MAX_RADIUS, |_| true, &mut buf);
                buf.sort_unstable_by(|a, b| a.dist2.total_cmp(&b.dist2));
                sum += buf.last().map_or(0.0, |n| n.dist2);
            }
            sum
        })
    });
    g.bench_function("kiddo", |b| {
        b.iter(|| {
            let mut sum = 0.0f32;
            for q in &queries {
                let r = theirs
                    .query(&q.to_array())
                    .nearest_n::<SquaredEuclidean<f32>>(k)
                    .within(MAX_RADIUS * MAX_RADIUS)
                    .execute();
                sum += r.last().map_or(0.0, |n| n.distance);
            }
            sum
        })
    });
    g.finish();

    let mut g = c.benchmark_group("knn_filtered");
    g.sample_size(10);
    g.throughput(Throughput::Elements(QUERIES as u64));
    let normals: Vec<Vec3> = photons(QUERIES, 2).iter().map(Photon::normal).collect();
    g.bench_function("ours", |b| {
        b.iter(|| {
            let mut sum = 0.0f32;
            for (q, n) in queries.iter().zip(&normals) {
                let accept = |p: &Photon| p.normal().dot(*n) >= 0.5 && p.direction().dot(*n) > 0.0;
                ours.k_nearest_into(*q, K, MAX_RADIUS, accept, &mut buf);
                sum += buf.first().map_or(0.0, |n| n.dist2);
            }
            sum
        })
    });
    g.finish();

    let mut g = c.benchmark_group("nearest");
    g.sample_size(10);
    g.throughput(Throughput::Elements(QUERIES as u64));
    let every_4th: Vec<Photon> = ours.items().iter().step_by(4).copied().collect();
    let tree = KdTree::build_for_nearest(every_4th.clone());
    let facing = FacingTree::build(every_4th, Photon::normal, |_| 0);
    let by_predicate = |q: Vec3, n: Vec3| tree.nearest_where(q, f32::INFINITY, |p: &Photon| p.normal().dot(n) > 0.9);
    for (q, n) in queries.iter().zip(&normals) {
        assert_eq!(
            by_predicate(*q, *n),
            facing.nearest_facing(*q, *n, 0.9, f32::INFINITY).map(|f| f.neighbour)
        );
    }
    g.bench_function("where", |b| {
        b.iter(|| {
            let mut sum = 0.0f32;
            for (q, n) in queries.iter().zip(&normals) {
                sum += by_predicate(*q, *n).map_or(0.0, |n| n.dist2);
            }
            sum
        })
    });
    g.bench_function("facing", |b| {
        b.iter(|| {
            let mut sum = 0.0f32;
            for (q, n) in queries.iter().zip(&normals) {
                sum += facing
                    .nearest_facing(*q, *n, 0.9, f32::INFINITY)
                    .map_or(0.0, |f| f.neighbour.dist2);
            }
            sum
        })
    });
    g.finish();
}

fn scale(c: &mut Criterion) {
    const SIZES: [usize; 6] = [25_000, 50_000, 100_000, 200_000, 400_000, 800_000];
    let all = photons(SIZES[SIZES.len() - 1], 1);
    let queries: Vec<Vec3> = photons(10_000, 2).iter().map(Photon::position).collect();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a thread pool");
    let mut g = c.benchmark_group("scale_build");
    g.sample_size(10);
    for n in SIZES {
        g.throughput(Throughput::Elements(n as u64));
        let data = all[..n].to_vec();
        g.bench_with_input(BenchmarkId::from_parameter(n), &data, |b, data| {
            b.iter(|| one.install(|| KdTree::build(black_box(data.clone()))))
        });
    }
    g.finish();
    let mut g = c.benchmark_group("scale_knn");
    g.sample_size(10);
    g.throughput(Throughput::Elements(queries.len() as u64));
    let mut buf: Vec<Neighbour> = Vec::new();
    for n in SIZES {
        let tree = KdTree::build(all[..n].to_vec());
        g.bench_function(BenchmarkId::from_parameter(n), |b| {
            b.iter(|| {
                let mut sum = 0.0f32;
                for q in &queries {
                    tree.k_nearest_into(*q, K, f32::INFINITY, |_| true, &mut buf);
                    sum += buf.last().map_or(0.0, |n| n.dist2);
                }
                sum
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench, scale);
criterion_main!(benches);
