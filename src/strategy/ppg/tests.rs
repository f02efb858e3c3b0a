use super::*;
use crate::bsdf::Lambertian;
use sdtree::{dir_to_square, square_to_dir};

/// The BSDF/guide mixture must sample what its pdf says: chi-square of 200 000 directions at a
/// Lambertian vertex with a trained D-tree (a lobe towards the upper left and a weak floor
/// everywhere), over a 16 × 16 grid of the sphere's cylindrical square (equal solid angle per
/// cell), against the pdf integrated by 8 × 8 midpoints per cell. The expected counts must
/// also sum to the sample count: the pdf integrates to one over the sphere.
#[test]
fn the_mixture_samples_its_pdf() {
    let mut rng = Rng::for_task(3, [0, 0, 0]);
    let mut tree = SdTree::new(Vec3::ZERO, Vec3::ONE);
    let lobe = Vec3::new(-0.4, 0.3, 0.85).normalize();
    for k in 0..3 {
        for _ in 0..30_000 {
            let d = square_to_dir(rng.uniform2());
            tree.leaves[0]
                .building
                .record(d, (d.dot(lobe).max(0.0) as f64).powi(6) + 0.02);
        }
        tree.end_iteration(k, 1e12, 0.01);
    }
    let guide = Guide {
        tree: &tree,
        alpha: 0.5,
    };
    let bsdf = Bsdf::Lambertian(Lambertian {
        reflectance: Vec3::splat(0.7),
    });
    let frame = Frame::from_normal(Vec3::new(0.2, 0.1, 1.0).normalize());
    let v = Some((0u32, frame));
    let wo = Vec3::new(0.3, 0.0, 0.95).normalize();
    let (cells, n) = (16usize, 200_000usize);
    let mut counts = vec![0f64; cells * cells];
    for _ in 0..n {
        let Some(s) = guide.sample(&v, &bsdf, wo, &mut rng) else {
            continue;
        };
        let p = dir_to_square(frame.to_world(s.wi));
        let (x, y) = (
            ((p.x * cells as f32) as usize).min(cells - 1),
            ((p.y * cells as f32) as usize).min(cells - 1),
        );
        counts[y * cells + x] += 1.0;
    }
    let (mut chi2, mut dof, mut total) = (0.0, 0, 0.0);
    for y in 0..cells {
        for x in 0..cells {
            let mut p = 0.0f64;
            for j in 0..8 {
                for i in 0..8 {
                    let uv = Vec2::new(
                        (x as f32 + (i as f32 + 0.5) / 8.0) / cells as f32,
                        (y as f32 + (j as f32 + 0.5) / 8.0) / cells as f32,
                    );
                    let wi = frame.to_local(square_to_dir(uv));
                    p += guide.pdf(&v, &bsdf, wo, wi) as f64;
                }
            }
            // Each cell is 4π / cells² of solid angle.
            let expected = p / 64.0 * 4.0 * std::f64::consts::PI / (cells * cells) as f64 * n as f64;
            total += expected;
            if expected > 5.0 {
                chi2 += (counts[y * cells + x] - expected).powi(2) / expected;
                dof += 1;
            }
        }
    }
    assert!(
        (total / n as f64 - 1.0).abs() < 0.02,
        "the pdf integrates to {}",
        total / n as f64
    );
    let limit = dof as f64 + 5.0 * (2.0 * dof as f64).sqrt();
    assert!(chi2 < limit, "chi2 {chi2} over {dof} cells (limit {limit})");
}

#[test]
fn hostile_parameters_are_refused() {
    for text in [
        "bsdf_fraction = 0.0",
        "bsdf_fraction = 1.5",
        "training_iterations = 13",
        "energy_threshold = 0.0",
        "spatial_threshold = -1.0",
        "training = 3",
    ] {
        assert!(
            crate::strategy::build("ppg", toml::from_str(text).unwrap()).is_err(),
            "`{text}`"
        );
    }
}

/// Training grows the trees where light comes from, and the counters say so.
#[test]
fn training_builds_a_tree_and_counts_its_work() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-empty.toml");
    let scene = crate::scene::load_scene(&path).unwrap();
    let mut s = <Ppg as Declared>::new(
        PpgParams::from_table(toml::from_str("training_iterations = 3\nspatial_threshold = 500.0").unwrap()).unwrap(),
    )
    .unwrap();
    let phases = s.prepare(&scene, 1).unwrap();
    assert_eq!(phases[0].name, "training");
    let counters: std::collections::HashMap<String, f64> = s.counters().into_iter().collect();
    let pixels = scene.camera.pixel_count() as f64;
    assert_eq!(counters["training_paths"], 7.0 * pixels);
    assert!(counters["training_records"] > counters["training_paths"]);
    assert!(counters["stree_leaves"] > 1.0 && counters["dtree_nodes"] > counters["stree_leaves"]);
}
