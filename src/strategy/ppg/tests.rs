use super::*;
use crate::bsdf::Lambertian;
use sdtree::square_to_dir;

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
    sdtree::assert_samples_pdf(
        200_000,
        || guide.sample(&v, &bsdf, wo, &mut rng).map(|s| frame.to_world(s.wi)),
        |d| guide.pdf(&v, &bsdf, wo, frame.to_local(d)),
    );
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

/// With `combine = "inverse_variance"` the film's mean after each pass is the combination of
/// the training images and the final render by the weights of [`Ppg::weights`], and the final
/// render's weight comes to dominate; with `"last"` it is the plain mean.
#[test]
fn the_film_holds_the_inverse_variance_combination() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-empty.toml");
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("resolution = [80, 60]", "resolution = [16, 12]");
    let (scene, _) = crate::scene::load::load_scene_bytes(&path, text.as_bytes()).unwrap();
    let build = |combine: &str| {
        let table = toml::from_str(&format!("training_iterations = 4\ncombine = \"{combine}\"")).unwrap();
        let mut s = <Ppg as Declared>::new(PpgParams::from_table(table).unwrap()).unwrap();
        s.prepare(&scene, 4).unwrap();
        s
    };
    let s = build("inverse_variance");
    assert_eq!(s.iterations.len(), 4);
    assert!(s.iterations[0].variance().is_none() && s.iterations[3].variance().is_some());
    let mut film = Film::new(16, 12);
    let mut final_weights = Vec::new();
    for (start, end) in [(0u32, 1u32), (1, 3), (3, 6)] {
        s.render_pass(&scene, 4, start..end, &mut film);
        let state = s.last.lock().unwrap();
        let w = s.weights(&state.moments);
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-9 && w[0] == 0.0);
        final_weights.push(*w.last().unwrap());
        let image = film.image();
        for (p, got) in image.pixels.iter().enumerate() {
            let mut want = state.moments.mean(p) * w[4];
            for (m, wi) in s.iterations.iter().zip(&w) {
                want += m.mean(p) * *wi;
            }
            let err = (got.as_dvec3() - want).abs().max_element();
            assert!(
                err <= 1e-5 * (1.0 + want.max_element()),
                "pixel {p} after {end}: {got} vs {want}"
            );
        }
        assert!(film.accumulators().iter().all(|a| a.count == end));
    }
    // The final render's weight grows with its samples (in expectation: small-sample variance
    // estimates are noisy): after 64 final samples against 15 of training it dominates.
    s.render_pass(&scene, 4, 6..64, &mut film);
    let w_final = *s.weights(&s.last.lock().unwrap().moments).last().unwrap();
    assert!(
        w_final > 0.5 && w_final > final_weights[0],
        "{final_weights:?} → {w_final}"
    );

    let last = build("last");
    assert!(last.iterations.is_empty());
    let mut a = Film::new(16, 12);
    last.render_pass(&scene, 4, 0..3, &mut a);
    let mut b = Film::new(16, 12);
    render_pixels(&scene, 4, 0..3, &mut b, |ray, rng| {
        let guide = Guide {
            tree: last.tree.as_ref().unwrap(),
            alpha: 0.5,
        };
        trace(&scene, &last.walk(), &guide, *ray, rng, &mut ())
    });
    assert_eq!(a.image(), b.image());
}
