//! Participating media (`[media]`, Mitsuba's `homogeneous` medium with `null` boundaries):
//! `path`'s volumetric walk conserves energy, attenuates by the closed-form transmittance, its
//! next-event estimation through media agrees with phase sampling alone, light tracing and
//! bidirectional path tracing through media agree with it, the scene is written to Mitsuba and
//! read back, other strategies refuse it, and bad input is refused in one line.

mod agreement;

use agreement::{
    assert_agrees, assert_bit_identical_across_threads, assert_refused, block_means, image_mean, load_text as load,
    render_image as render,
};

/// A 12 × 12 camera at z = 4 looking at the origin.
const CAMERA: &str = "[camera]\neye = [0, 0, 4]\nlook_at = [0, 0, 0]\nfov_y = 30\nresolution = [12, 12]\n";

/// A ball of medium (radius 1, null boundary) in a uniform white environment of radiance 1:
/// with albedo 1 nothing is absorbed, so every pixel must see radiance 1 — through the ball and
/// around it, whatever the phase function, with or without emitter sampling in the medium
/// (a white furnace for the volumetric walk: distance sampling, phase sampling, NEE with
/// transmittance through the boundary and MIS all have to agree for this to hold).
fn furnace(phase: &str, sample_emitters: bool, sigma_t: [f32; 3]) -> String {
    format!(
        "{CAMERA}[environment]\ntype = \"constant\"\nradiance = [1, 1, 1]\n\
         [materials.boundary]\ntype = \"null\"\n\
         [media.fog]\ntype = \"homogeneous\"\nsigma_t = [{}, {}, {}]\nalbedo = [1, 1, 1]\nphase = {phase}\nsample_emitters = {sample_emitters}\n\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"boundary\"\ncenter = [0, 0, 0]\nradius = 1\ninterior = \"fog\"\n",
        sigma_t[0], sigma_t[1], sigma_t[2]
    )
}

#[test]
fn a_white_medium_in_a_white_furnace_is_invisible() {
    // Deep paths: at σ_t = 6 a path scatters ~20 times before it leaves the ball.
    assert_invisible_in_furnace(
        "path",
        256,
        &[
            ("{ type = \"isotropic\" }", true, [2.0, 2.0, 2.0]),
            ("{ type = \"hg\", g = 0.7 }", true, [0.5, 2.0, 6.0]),
            ("{ type = \"hg\", g = -0.5 }", false, [3.0, 3.0, 3.0]),
        ],
    );
}

/// The white furnace for `bdpt` (module doc of `photon_bench::path_space::bidirectional`,
/// "Media"): light sub-paths from the environment's disc and eye sub-paths both scatter in the
/// ball, one hero channel for both, and every technique's connection through the ball carries
/// its transmittance; a coloured σ_t tests the spectral estimate of two sub-paths together.
#[test]
fn a_white_medium_in_a_white_furnace_is_invisible_to_bdpt_and_vcm() {
    for kind in ["bdpt", "vcm"] {
        assert_invisible_in_furnace(
            kind,
            128,
            &[
                ("{ type = \"isotropic\" }", true, [2.0, 2.0, 2.0]),
                ("{ type = \"hg\", g = 0.7 }", true, [0.5, 1.0, 3.0]),
            ],
        );
    }
}

/// Asserts that every channel of `kind`'s image (`spp` samples, no depth limit, no roulette) of
/// the white furnace of each (phase, sample_emitters, σ_t) averages 1.
fn assert_invisible_in_furnace(kind: &str, spp: u32, cases: &[(&str, bool, [f32; 3])]) {
    let dir = tempfile::tempdir().unwrap();
    for (i, &(phase, sample_emitters, sigma_t)) in cases.iter().enumerate() {
        let scene = load(
            dir.path(),
            &format!("furnace{i}.toml"),
            &furnace(phase, sample_emitters, sigma_t),
        )
        .unwrap();
        let img = render(&scene, kind, "max_depth = 1000\nrr_depth = 1000", spp, 3);
        for c in 0..3 {
            let (mean, se) = mean_and_error(&img, c);
            assert!(
                (mean - 1.0).abs() <= 4.0 * se + 1e-6 && se < 0.01,
                "{kind}, {phase}, σ_t {sigma_t:?}: channel {c} mean {mean} ± {se}, expected 1"
            );
        }
    }
}

/// Over the pixels of `img` (independent estimates), the mean of channel `c` and its standard
/// error.
fn mean_and_error(img: &photon_bench::film::Image, c: usize) -> (f64, f64) {
    let n = img.pixels.len() as f64;
    let v: Vec<f64> = img.pixels.iter().map(|p| f64::from(p[c])).collect();
    let mean = v.iter().sum::<f64>() / n;
    let se = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt();
    (mean, se)
}

/// An absorbing slab (albedo 0, σ_t different per channel, 0.5 thick between null walls) in
/// front of an emitting wall of radiance 1: every ray through it sees e^{−σ_t · 0.5} per
/// channel — the collision estimator's passing weights with the channel mixture.
#[test]
fn an_absorbing_slab_transmits_the_closed_form() {
    let dir = tempfile::tempdir().unwrap();
    let sigma = [0.4f32, 1.5, 4.0];
    let text = format!(
        "{CAMERA}[materials.boundary]\ntype = \"null\"\n[materials.black]\ntype = \"diffuse\"\nreflectance = [0, 0, 0]\n\
         [media.ink]\ntype = \"homogeneous\"\nsigma_t = [{}, {}, {}]\nalbedo = [0, 0, 0]\n\
         [[shapes]]\ntype = \"box\"\nmaterial = \"boundary\"\nmin = [-5, -5, 0.25]\nmax = [5, 5, 0.75]\ninterior = \"ink\"\n\
         [[shapes]]\ntype = \"quad\"\nmaterial = \"black\"\ncenter = [0, 0, -1]\nsize = [20, 20]\nfacing = \"+z\"\n\
         emission = {{ radiance = [1, 1, 1] }}\n",
        sigma[0], sigma[1], sigma[2]
    );
    // A narrow view: every ray crosses the slab within 10⁻⁴ of straight on.
    let text = text.replacen("fov_y = 30", "fov_y = 1", 1);
    let scene = load(dir.path(), "slab.toml", &text).unwrap();
    let img = render(&scene, "path", "", 256, 1);
    assert_transmits(&img, sigma, 0.5);
}

/// A room with a fog box lit by a small area light and a point light, a glass ball with a
/// scattering interior: next-event estimation through media (with MIS) and phase/BSDF sampling
/// alone estimate the same image.
fn foggy_room(sample_emitters: bool, point_light: bool) -> String {
    let point = if point_light {
        "[[lights]]\ntype = \"point\"\nposition = [-1, 1.5, 1]\nintensity = [1, 1, 1]\n"
    } else {
        ""
    };
    format!(
        "[camera]\neye = [0, 1, 3.5]\nlook_at = [0, 1, 0]\nfov_y = 50\nresolution = [16, 12]\nmedium = \"fog\"\n\
         [materials.white]\ntype = \"diffuse\"\nreflectance = [0.7, 0.7, 0.7]\n\
         [materials.glass]\ntype = \"dielectric\"\nior = 1.3\n\
         [media.fog]\ntype = \"homogeneous\"\nsigma_t = [0.3, 0.4, 0.5]\nalbedo = [0.9, 0.8, 0.7]\nphase = {{ type = \"hg\", g = 0.5 }}\nsample_emitters = {sample_emitters}\n\
         [media.milk]\ntype = \"homogeneous\"\nsigma_t = [4, 4, 4]\nscale = 0.5\nalbedo = [0.95, 0.9, 0.8]\n\
         [[shapes]]\ntype = \"box\"\nmaterial = \"white\"\nmin = [-2, 0, -2]\nmax = [2, 2.5, 4]\n\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"glass\"\ncenter = [0.4, 0.6, 0]\nradius = 0.5\ninterior = \"milk\"\nexterior = \"fog\"\n\
         [[shapes]]\ntype = \"quad\"\nmaterial = \"white\"\ncenter = [0, 2.45, 0]\nsize = [0.6, 0.6]\nfacing = \"-y\"\n\
         emission = {{ radiance = [6, 6, 6] }}\n{point}"
    )
}

#[test]
fn next_event_estimation_through_media_agrees_with_phase_sampling() {
    let dir = tempfile::tempdir().unwrap();
    // The box's walls face inward only if seen from inside: a closed box seen from within.
    let scene = load(dir.path(), "room.toml", &foggy_room(true, true)).unwrap();
    let mis = assert_techniques_agree(&scene, "point and area light", &["nee"]);
    // Phase and BSDF sampling alone (no point light: only light sampling reaches it).
    let lit = load(dir.path(), "room-area.toml", &foggy_room(true, false)).unwrap();
    let base = assert_techniques_agree(&lit, "area light", &["nee", "bsdf"]);
    assert!(mis.0 > base.0, "the point light adds light");
    let quiet = load(dir.path(), "room-quiet.toml", &foggy_room(false, false)).unwrap();
    assert_agrees(
        "path, sample_emitters = false",
        image_mean(&quiet, "path", "", 32),
        base,
    );
    let Err(err) = load(dir.path(), "room-dark.toml", &foggy_room(false, true)) else {
        panic!("a medium without light sampling was accepted beside a point light");
    };
    assert_refused(&err.to_string(), &["media.fog.sample_emitters"]);
    assert_bit_identical_across_threads(&scene, "path", 5);
}

#[test]
fn strategies_without_media_refuse_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(dir.path(), "room.toml", &foggy_room(true, true)).unwrap();
    for kind in ["photon_guided", "photon_map", "mlt", "mps", "ppg", "sppm"] {
        let s = photon_bench::strategy::build(kind, toml::Table::new()).unwrap();
        let err = photon_bench::strategy::check_scene(&*s, &scene)
            .unwrap_err()
            .to_string();
        assert_refused(&err, &[kind, "participating media", "\"fog\"", "path"]);
    }
    // `vcm` renders media, but not in its `ppm` mode (module doc of `photon_bench::strategy::vcm`).
    let ppm = photon_bench::strategy::build("vcm", toml::from_str("mode = \"ppm\"").unwrap()).unwrap();
    let err = photon_bench::strategy::check_scene(&*ppm, &scene)
        .unwrap_err()
        .to_string();
    assert_refused(&err, &["`vcm` with these parameters", "participating media", "bdpt"]);
}

#[test]
fn media_are_exported_to_mitsuba_and_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let toml_path = dir.path().join("room.toml");
    std::fs::write(&toml_path, foggy_room(true, true)).unwrap();
    let xml = dir.path().join("room.xml");
    photon_bench::scene::export::export_file(&toml_path, &xml).unwrap();
    let (a, _) = photon_bench::scene::load::load_scene_with_stats(&toml_path).unwrap();
    let (b, _) = photon_bench::scene::load::load_scene_with_stats(&xml).unwrap();
    let mut names_a: Vec<_> = a.media.iter().map(|m| (m.name.clone(), m.sigma_t, m.phase)).collect();
    let mut names_b: Vec<_> = b.media.iter().map(|m| (m.name.clone(), m.sigma_t, m.phase)).collect();
    names_a.sort_by(|x, y| x.0.cmp(&y.0));
    names_b.sort_by(|x, y| x.0.cmp(&y.0));
    assert_eq!(names_a, names_b);
    assert_eq!(
        a.camera_medium.map(|i| &a.media[i as usize].name),
        b.camera_medium.map(|i| &b.media[i as usize].name)
    );
    let media_of = |s: &photon_bench::scene::Scene| -> Vec<(Option<String>, Option<String>)> {
        let name = |i: Option<u32>| i.map(|i| s.media[i as usize].name.clone());
        s.attrs.iter().map(|a| (name(a.interior), name(a.exterior))).collect()
    };
    assert_eq!(media_of(&a), media_of(&b));
    // The same image, up to the noise of two renders.
    assert_agrees(
        "exported",
        image_mean(&b, "path", "", 16),
        image_mean(&a, "path", "", 16),
    );
}

#[test]
fn bad_media_are_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let base = furnace("{ type = \"isotropic\" }", true, [1.0, 1.0, 1.0]);
    for (i, (from, to, expect)) in [
        (
            "interior = \"fog\"",
            "interior = \"smoke\"",
            vec!["shapes[0].interior", "\"smoke\"", "\"fog\""],
        ),
        (
            "phase = { type = \"isotropic\" }",
            "phase = { type = \"hg\", g = 1 }",
            vec!["media.fog.phase.g", "(-1, 1)"],
        ),
        ("albedo = [1, 1, 1]", "albedo = [1.5, 1, 1]", vec!["media.fog.albedo"]),
        ("sigma_t = [1, 1, 1]", "sigma_t = [-1, 1, 1]", vec!["media.fog.sigma_t"]),
        (
            "albedo = [1, 1, 1]",
            "albedo = [1, 1, 1]\nalbedo_grid = { file = \"a.vol\" }",
            vec!["media.fog", "not both"],
        ),
        (
            "albedo = [1, 1, 1]",
            "albedo_grid = { file = \"missing.vol\" }",
            vec!["media.fog.albedo_grid.file", "missing.vol"],
        ),
        (
            "type = \"null\"",
            "type = \"mask\"\nopacity = 0.5\nbsdf = { type = \"null\" }",
            vec!["materials.boundary.bsdf", "null"],
        ),
    ]
    .into_iter()
    .enumerate()
    {
        let text = base.replacen(from, to, 1);
        assert_ne!(text, base, "case {i}: {from:?} not found");
        let Err(err) = load(dir.path(), &format!("bad{i}.toml"), &text) else {
            panic!("case {i}: {to:?} was accepted");
        };
        let err = err.to_string();
        assert_refused(&err, &expect);
    }
    let camera = base.replacen(
        "resolution = [12, 12]\n",
        "resolution = [12, 12]\nmedium = \"air\"\n",
        1,
    );
    let Err(err) = load(dir.path(), "bad-camera.toml", &camera) else {
        panic!("an unknown camera medium was accepted");
    };
    let err = err.to_string();
    assert_refused(&err, &["camera.medium", "\"air\""]);
}

/// Writes a `.vol` grid of `res` voxels (1 or 3 channels) from `value(x, y, z)` at voxel centres
/// of the unit cube.
fn write_vol(path: &std::path::Path, res: [u32; 3], channels: u32, value: impl Fn(f32, f32, f32) -> Vec<f32>) {
    use photon_bench::medium::grid::GridVolume;
    use photon_bench::texture::{Filter, Wrap};
    let mut data = Vec::new();
    for z in 0..res[2] {
        for y in 0..res[1] {
            for x in 0..res[0] {
                let c = |i: u32, n: u32| (i as f32 + 0.5) / n as f32;
                data.extend(value(c(x, res[0]), c(y, res[1]), c(z, res[2])));
            }
        }
    }
    let grid = GridVolume::new(
        res,
        channels,
        data,
        Filter::Bilinear,
        Wrap::Clamp,
        glam::Affine3A::IDENTITY,
    )
    .unwrap();
    std::fs::write(path, grid.to_vol_bytes()).unwrap();
}

/// A heterogeneous medium whose grid holds one coloured σ_t everywhere transmits what the
/// homogeneous slab does: delta tracking with spectral tracking's probabilities, and the grid's
/// box placed by its `to_world`.
#[test]
fn a_heterogeneous_slab_with_a_constant_grid_transmits_the_closed_form() {
    let dir = tempfile::tempdir().unwrap();
    let sigma = [0.4f32, 1.5, 4.0];
    write_vol(&dir.path().join("ink.vol"), [4, 4, 2], 3, |_, _, _| sigma.to_vec());
    let text = format!(
        "{CAMERA}[materials.boundary]\ntype = \"null\"\n[materials.black]\ntype = \"diffuse\"\nreflectance = [0, 0, 0]\n\
         [media.ink]\ntype = \"heterogeneous\"\nalbedo = [0, 0, 0]\n\
         sigma_t_grid = {{ file = \"ink.vol\", to_world = [{{ scale = [10, 10, 0.5] }}, {{ translate = [-5, -5, 0.25] }}] }}\n\
         [[shapes]]\ntype = \"box\"\nmaterial = \"boundary\"\nmin = [-5, -5, 0.25]\nmax = [5, 5, 0.75]\ninterior = \"ink\"\n\
         [[shapes]]\ntype = \"quad\"\nmaterial = \"black\"\ncenter = [0, 0, -1]\nsize = [20, 20]\nfacing = \"+z\"\n\
         emission = {{ radiance = [1, 1, 1] }}\n"
    )
    .replacen("fov_y = 30", "fov_y = 1", 1);
    let scene = load(dir.path(), "slab.toml", &text).unwrap();
    let img = render(&scene, "path", "", 1024, 1);
    assert_transmits(&img, sigma, 0.5);
}

/// A ball of white heterogeneous smoke (density rising along x and y, a dense core) in the
/// white furnace renders 1; in a lit room, next-event estimation (ratio tracking along shadow
/// rays) and phase sampling alone agree.
#[test]
fn heterogeneous_smoke_conserves_energy_and_its_estimators_agree() {
    let dir = tempfile::tempdir().unwrap();
    write_vol(&dir.path().join("smoke.vol"), [8, 8, 8], 1, |x, y, z| {
        let core = (-20.0 * ((x - 0.5).powi(2) + (y - 0.5).powi(2) + (z - 0.5).powi(2))).exp();
        vec![4.0 * x * y + 6.0 * core]
    });
    let smoke = "[media.smoke]\ntype = \"heterogeneous\"\nalbedo = [1, 1, 1]\nphase = { type = \"hg\", g = 0.4 }\n\
                 sigma_t_grid = { file = \"smoke.vol\", to_world = [{ scale = 2 }, { translate = [-1, -1, -1] }] }\n";
    let furnace_text = furnace("{ type = \"isotropic\" }", true, [1.0, 1.0, 1.0])
        .replace("interior = \"fog\"", "interior = \"smoke\"")
        + smoke;
    let scene = load(dir.path(), "furnace.toml", &furnace_text).unwrap();
    let img = render(&scene, "path", "max_depth = 1000\nrr_depth = 1000", 128, 2);
    for c in 0..3 {
        let (mean, se) = mean_and_error(&img, c);
        assert!(
            (mean - 1.0).abs() <= 4.0 * se + 1e-6 && se < 0.01,
            "channel {c}: {mean} ± {se}"
        );
    }
    let room = foggy_room(true, false).replace("interior = \"milk\"", "interior = \"smoke\"")
        + &smoke
            .replace("albedo = [1, 1, 1]", "albedo = [0.8, 0.7, 0.6]")
            .replace("translate = [-1, -1, -1]", "translate = [-0.6, -0.4, -1]");
    let scene = load(dir.path(), "room.toml", &room).unwrap();
    assert_techniques_agree(&scene, "heterogeneous", &["nee", "bsdf"]);
}

/// A heterogeneous medium's grid, scale and box survive the export to Mitsuba and the way back.
#[test]
fn heterogeneous_media_are_exported_and_read_back() {
    let dir = tempfile::tempdir().unwrap();
    write_vol(&dir.path().join("smoke.vol"), [4, 3, 2], 1, |x, y, z| {
        vec![x + 2.0 * y + 3.0 * z]
    });
    let text = furnace("{ type = \"hg\", g = 0.3 }", true, [1.0, 1.0, 1.0])
        .replace("interior = \"fog\"", "interior = \"smoke\"")
        + "[media.smoke]\ntype = \"heterogeneous\"\nscale = 2.5\nalbedo = [0.5, 0.6, 0.7]\n\
           sigma_t_grid = { file = \"smoke.vol\", filter = \"nearest\", to_world = [{ scale = 2 }, { translate = [-1, -1, -1] }] }\n";
    let toml_path = dir.path().join("smoke.toml");
    std::fs::write(&toml_path, text).unwrap();
    let xml = dir.path().join("smoke.xml");
    photon_bench::scene::export::export_file(&toml_path, &xml).unwrap();
    let (a, _) = photon_bench::scene::load::load_scene_with_stats(&toml_path).unwrap();
    let (b, _) = photon_bench::scene::load::load_scene_with_stats(&xml).unwrap();
    let smoke = |s: &photon_bench::scene::Scene| s.media.iter().find(|m| m.name == "smoke").unwrap().clone();
    let (da, db) = (smoke(&a).density.unwrap(), smoke(&b).density.unwrap());
    assert_eq!((da.scale, da.majorant), (db.scale, db.majorant));
    assert!(
        (da.bounds.0 - db.bounds.0).abs().max_element() < 1e-6
            && (da.bounds.1 - db.bounds.1).abs().max_element() < 1e-6
    );
    for p in [glam::Vec3::new(0.3, -0.2, 0.1), glam::Vec3::new(-0.9, 0.8, -0.4)] {
        assert_eq!(da.sigma_t(p), db.sigma_t(p), "at {p}");
    }
}

/// Asserts that `path` with each of `directs` (`direct = "nee"`, `"bsdf"`) agrees with its
/// default MIS on `scene`; returns the MIS image mean and its standard error.
fn assert_techniques_agree(scene: &photon_bench::scene::Scene, what: &str, directs: &[&str]) -> (f64, f64) {
    let base = image_mean(scene, "path", "", 32);
    for direct in directs {
        let params = format!("direct = \"{direct}\"");
        assert_agrees(
            &format!("{what}, direct = {direct}"),
            image_mean(scene, "path", &params, 32),
            base,
        );
    }
    base
}

/// Asserts that every channel of `img` averages e^{−σ_c d} within 4 standard errors (and that
/// the error is below 1 % of it).
fn assert_transmits(img: &photon_bench::film::Image, sigma: [f32; 3], d: f32) {
    for (c, s) in sigma.iter().enumerate() {
        let (mean, se) = mean_and_error(img, c);
        let expected = f64::from(-s * d).exp();
        assert!(
            (mean - expected).abs() < 4.0 * se && se < 0.01 * expected,
            "channel {c}: {mean} ± {se} vs e^(-σ d) = {expected}"
        );
    }
}

/// Light tracing through media (`light`'s volumetric walk) estimates `path`'s image: in the
/// foggy room — its fog now in a null box that leaves the camera outside (light tracing from a
/// scattering medium around the camera has infinite variance: the camera factor's 1/r² at
/// vertices near the lens) and the area light above it, the point light inside — with a
/// null-bounded ball of milk (light tracing cannot see a glass ball, whose paths end E S), and
/// with the ball of heterogeneous smoke; per block of 3 × 3 pixels and over the whole image.
/// Its images are the same bits on 1 and 3 threads.
#[test]
fn light_tracing_through_media_agrees_with_path() {
    let dir = tempfile::tempdir().unwrap();
    // 18 × 12: whole blocks.
    let milk = foggy_room(true, true)
        .replace("material = \"glass\"", "material = \"boundary\"")
        .replace("resolution = [16, 12]", "resolution = [18, 12]")
        .replace("medium = \"fog\"\n", "")
        + "[materials.boundary]\ntype = \"null\"\n\
           [[shapes]]\ntype = \"box\"\nmaterial = \"boundary\"\nmin = [-1.95, 0.05, -1.95]\nmax = [1.95, 2.4, 2.5]\ninterior = \"fog\"\n";
    let scene = load(dir.path(), "milk.toml", &milk).unwrap();
    assert_eq!(scene.camera_medium, None);
    assert_blocks_agree(&scene, "light", "milk ball");
    assert_bit_identical_across_threads(&scene, "light", 2);
    write_vol(&dir.path().join("smoke.vol"), [8, 8, 8], 1, |x, y, z| {
        let core = (-20.0 * ((x - 0.5).powi(2) + (y - 0.5).powi(2) + (z - 0.5).powi(2))).exp();
        vec![4.0 * x * y + 6.0 * core]
    });
    let smoke = milk.replace("interior = \"milk\"", "interior = \"smoke\"")
        + "[media.smoke]\ntype = \"heterogeneous\"\nalbedo = [0.8, 0.7, 0.6]\nphase = { type = \"hg\", g = -0.3 }\n\
           sigma_t_grid = { file = \"smoke.vol\", to_world = [{ scale = 2 }, { translate = [-0.6, -0.4, -1] }] }\n";
    let scene = load(dir.path(), "smoke.toml", &smoke).unwrap();
    assert_blocks_agree(&scene, "light", "heterogeneous smoke");
}

/// Bidirectional path tracing through media estimates `path`'s image: in the foggy room with
/// the camera inside the fog (the light-tracing techniques' 1/r² at vertices near the lens is
/// tamed by the weights) and a glass ball of milk (a medium behind a refracting boundary: paths
/// through it end E S … on the eye side, which only the eye walk makes), lit by the area light
/// alone — `path` cannot see the point light's light refracted into the milk (L S … : no
/// connection reaches a point light through glass, no ray hits it), which `bdpt`'s light
/// sub-paths carry there: 7 % more in the ball's blocks than `path` and Mitsuba 3's `volpath`
/// (docs/design.md, "2026-11-28: bidirectional path tracing through media"); then with the point
/// light and a null ball of heterogeneous smoke in a null box of fog. Per block and over the
/// whole image; the same bits on 1 and 3 threads.
#[test]
fn bidirectional_path_tracing_through_media_agrees_with_path() {
    let dir = tempfile::tempdir().unwrap();
    let room = foggy_room(true, false).replace("resolution = [16, 12]", "resolution = [18, 12]");
    let scene = load(dir.path(), "room.toml", &room).unwrap();
    assert!(scene.camera_medium.is_some());
    assert_blocks_agree(&scene, "bdpt", "camera in fog, glass ball of milk");
    assert_bit_identical_across_threads(&scene, "bdpt", 2);
    assert_blocks_agree_within(&scene, ("vcm", "", 0.01), "camera in fog, glass ball of milk");
    assert_bit_identical_across_threads(&scene, "vcm", 2);
    write_vol(&dir.path().join("smoke.vol"), [8, 8, 8], 1, |x, y, z| {
        let core = (-20.0 * ((x - 0.5).powi(2) + (y - 0.5).powi(2) + (z - 0.5).powi(2))).exp();
        vec![4.0 * x * y + 6.0 * core]
    });
    // A strongly coloured fog: the light sub-paths' flights and the eye sub-paths' must share
    // their hero channel (each drawing its own biases the spectral estimate by a few per cent).
    let smoke = foggy_room(true, true)
        .replace("resolution = [16, 12]", "resolution = [18, 12]")
        .replace("sigma_t = [0.3, 0.4, 0.5]", "sigma_t = [0.1, 0.6, 1.8]")
        .replace("material = \"glass\"", "material = \"boundary\"")
        .replace("interior = \"milk\"", "interior = \"smoke\"")
        .replace("medium = \"fog\"\n", "")
        + "[materials.boundary]\ntype = \"null\"\n\
           [[shapes]]\ntype = \"box\"\nmaterial = \"boundary\"\nmin = [-1.95, 0.05, -1.95]\nmax = [1.95, 2.4, 2.5]\ninterior = \"fog\"\n\
           [media.smoke]\ntype = \"heterogeneous\"\nalbedo = [0.8, 0.7, 0.6]\nphase = { type = \"hg\", g = -0.3 }\n\
           sigma_t_grid = { file = \"smoke.vol\", to_world = [{ scale = 2 }, { translate = [-0.6, -0.4, -1] }] }\n";
    let scene = load(dir.path(), "smoke.toml", &smoke).unwrap();
    assert_blocks_agree(&scene, "bdpt", "heterogeneous smoke in a fog box");
    assert_blocks_agree_within(
        &scene,
        ("vcm", "radius_factor = 0.02", 0.02),
        "heterogeneous smoke in a fog box",
    );
}

/// `vcm`'s merges through media: a camera inside an emitting, diffusely reflecting sphere filled
/// with strongly coloured fog (albedo 0.9, 0.6, 0.3), 48 × 48 pixels so that the pass's 2304
/// light sub-paths give merging a large weight at `radius_factor` 0.05. Each channel of the
/// image mean (6 seeds) agrees with `path`'s within 4 standard errors and 1 % (the kernel's
/// bias): the merges' estimate is the product of both sub-paths' spectral estimates. (Without
/// the light sub-path's flights the merges read +11 % and +25 % in green and blue, z 19 and 32.)
#[test]
fn vertex_merging_through_media_agrees_with_path() {
    let dir = tempfile::tempdir().unwrap();
    let text = "[camera]\neye = [0.1, -0.1, 0.05]\nlook_at = [0, 0, -1]\nfov_y = 60\nresolution = [48, 48]\nmedium = \"fog\"\n\
                [materials.wall]\ntype = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n\
                [media.fog]\ntype = \"homogeneous\"\nsigma_t = [0.5, 1, 3]\nalbedo = [0.9, 0.6, 0.3]\nphase = { type = \"hg\", g = 0.5 }\n\
                [[shapes]]\ntype = \"sphere\"\nmaterial = \"wall\"\ncenter = [0, 0, 0]\nradius = 1\ninterior = \"fog\"\n\
                emission = { radiance = [0.5, 0.5, 0.5], two_sided = true }\n";
    let scene = load(dir.path(), "sphere.toml", text).unwrap();
    let means = |kind: &str, params: &str, spp: u32| -> Vec<(f64, f64)> {
        let images: Vec<_> = (0..6).map(|seed| render(&scene, kind, params, spp, seed)).collect();
        (0..3)
            .map(|c| {
                let v: Vec<f64> = images
                    .iter()
                    .map(|img| img.pixels.iter().map(|p| f64::from(p[c])).sum::<f64>() / img.pixels.len() as f64)
                    .collect();
                let m = v.iter().sum::<f64>() / 6.0;
                let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / 5.0;
                (m, (var / 6.0).sqrt())
            })
            .collect()
    };
    let base = means("path", "max_depth = 1000", 256);
    let ours = means("vcm", "max_depth = 1000\nradius_factor = 0.05", 32);
    for (c, ((m, se), (m0, se0))) in ours.into_iter().zip(base).enumerate() {
        let z = ((m - m0).abs() - 0.01 * m0).max(0.0) / (se * se + se0 * se0).sqrt();
        assert!(z < 4.0, "channel {c}: vcm {m} ± {se} vs path {m0} ± {se0}");
    }
}

/// Asserts that `kind` agrees with `path` on `scene` over the whole image and in every block of
/// [`agreement::blocks`] (4 standard errors each: with 24 blocks a false alarm has odds of
/// about 1 in 700 per scene).
fn assert_blocks_agree(scene: &photon_bench::scene::Scene, kind: &str, what: &str) {
    assert_blocks_agree_within(scene, (kind, "", 0.0), what);
}

/// [`assert_blocks_agree`] for `kind` with TOML `params`, allowing a relative `slack` beyond the
/// 4 standard errors (a consistent estimator's bias: `vcm`'s merging).
fn assert_blocks_agree_within(
    scene: &photon_bench::scene::Scene,
    (kind, params, slack): (&str, &str, f64),
    what: &str,
) {
    let agree = |label: String, (m, se): (f64, f64), (m0, se0): (f64, f64)| {
        let d = (m - m0).abs() - slack * m0;
        let z = d.max(0.0) / (se * se + se0 * se0).sqrt();
        assert!(
            z < 4.0,
            "{label}: {m} ± {se} vs path {m0} ± {se0} (z beyond the slack {z:.2})"
        );
    };
    // `path` is the noisier of the two in these dim foggy rooms: 8 times the samples.
    agree(
        format!("{kind}, {what}"),
        image_mean(scene, kind, params, 32),
        image_mean(scene, "path", "", 256),
    );
    let ours = block_means(scene, kind, params, 32);
    let base = block_means(scene, "path", "", 256);
    for (i, (a, b)) in ours.into_iter().zip(base).enumerate() {
        agree(format!("{kind}, {what}, block {i}"), a, b);
    }
}

/// A shadow ray that passes a `null` medium boundary and goes on to an emitter it meets at a
/// grazing angle just beyond (a fog box's top 0.05 below a ceiling lamp) carries the closed-form
/// transmittance to the lamp. Re-spawned parallel past the boundary, as Mitsuba 3.9.1's
/// `volpath` does, its origin's offset along the boundary's normal made it strike the lamp short
/// of its end: next-event estimation lost the lamp for fog points near the box's top
/// (docs/design.md, "2026-11-28: shadow rays past a passed surface").
#[test]
fn a_shadow_ray_past_a_null_boundary_reaches_a_grazing_emitter() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        "{CAMERA}[materials.boundary]\ntype = \"null\"\n[materials.white]\ntype = \"diffuse\"\nreflectance = [0.7, 0.7, 0.7]\n\
         [media.fog]\ntype = \"homogeneous\"\nsigma_t = [0.5, 0.5, 0.5]\nalbedo = [0.8, 0.8, 0.8]\n\
         [[shapes]]\ntype = \"box\"\nmaterial = \"boundary\"\nmin = [-2, 0, -2]\nmax = [2, 2.4, 2]\ninterior = \"fog\"\n\
         [[shapes]]\ntype = \"quad\"\nmaterial = \"white\"\ncenter = [0, 2.45, 0]\nsize = [0.6, 0.6]\nfacing = \"-y\"\n\
         emission = {{ radiance = [6, 6, 6] }}\n"
    );
    let scene = load(dir.path(), "lamp.toml", &text).unwrap();
    let mut rng = photon_bench::sampling::Rng::for_task(1, [0, 0, 0]);
    let fog = scene.media.iter().position(|m| m.name == "fog").unwrap() as u32;
    let lamp = glam::Vec3::new(0.1, 2.45, 0.1);
    for x in [[0.3, 2.39, 0.0], [1.0, 2.39, 0.0], [1.9, 2.399, -1.9], [0.0, 2.2, 0.0]] {
        let x = glam::Vec3::from_array(x);
        let d = (lamp - x).normalize();
        let mut ray = photon_bench::geometry::Ray::new(x, d);
        ray.t_max = (lamp - x).length() * (1.0 - 1e-4);
        let tr = scene.transmittance(Some(fog), &ray, &mut rng);
        let expected = (-0.5 * (2.4 - x.y) / d.y).exp();
        assert!(
            (tr - glam::Vec3::splat(expected)).abs().max_element() < 1e-4,
            "from {x}: transmittance {tr}, expected {expected}"
        );
    }
}
