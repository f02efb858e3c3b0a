//! pbrt-v4 scenes (`*.pbrt`): the Cornell box written in pbrt's format renders as the same box
//! written in ours (which matches Mitsuba 3's); pbrt's left-handed camera mirrors the image;
//! transforms, the attribute stack, orientation, materials, lights and media mean what pbrt-v4
//! says; what is not read is refused in one line naming the line.

mod agreement;

use agreement::{assert_refused, block_means, judge_blocks, load_text as load};
use glam::Vec2;
use photon_bench::bsdf::Bsdf;
use photon_bench::scene::Scene;
use photon_bench::scene::load::load_scene_bytes;
use std::path::Path;

/// A shipped scene at a test resolution (pbrt's film or our camera's).
fn small(file: &str, from: &str, to: &str) -> Scene {
    let path = Path::new(file);
    let text = std::fs::read_to_string(path).unwrap().replace(from, to);
    assert!(text.contains(to), "{file}: the resolution replacement must apply");
    load_scene_bytes(path, text.as_bytes()).unwrap().0
}

fn pbrt_box() -> Scene {
    small(
        "scenes/pbrt/cornell-box-pbrt.pbrt",
        "\"integer xresolution\" 256 \"integer yresolution\" 256",
        "\"integer xresolution\" 24 \"integer yresolution\" 24",
    )
}

fn toml_box() -> Scene {
    small(
        "scenes/cornell-box.toml",
        "resolution = [256, 256]",
        "resolution = [24, 24]",
    )
}

/// The same camera (every ray to 10⁻⁵), the same surface area per reflectance and the same
/// emitted power, and the same image: `path` on both, block by block (3 × 3 pixels, 6 seeds)
/// within 4 standard errors.
#[test]
fn a_pbrt_cornell_box_renders_as_the_toml_one() {
    let (p, t) = (pbrt_box(), toml_box());
    for raster in [Vec2::new(0.5, 0.5), Vec2::new(12.3, 7.9), Vec2::new(23.9, 20.1)] {
        let (a, b) = (p.camera.generate_ray(raster), t.camera.generate_ray(raster));
        assert!(
            (a.o - b.o).length() < 1e-5 && (a.d - b.d).length() < 1e-5,
            "{raster}: {a:?} vs {b:?}"
        );
    }
    let area_by_reflectance = |s: &Scene| {
        let mut v: Vec<(String, f64)> = Vec::new();
        for (prim, attrs) in s.primitives.iter().zip(&s.attrs) {
            let Bsdf::Lambertian(l) = &s.materials[attrs.material as usize].bsdf else {
                panic!("diffuse only")
            };
            let key = format!("{:.4}", l.reflectance);
            match v.iter_mut().find(|(k, _)| *k == key) {
                Some((_, a)) => *a += prim.area() as f64,
                None => v.push((key, prim.area() as f64)),
            }
        }
        v.sort_by(|a, b| a.0.cmp(&b.0));
        v
    };
    let (ap, at) = (area_by_reflectance(&p), area_by_reflectance(&t));
    assert_eq!(ap.len(), at.len());
    for ((k, a), (k2, b)) in ap.iter().zip(&at) {
        assert_eq!(k, k2);
        assert!((a / b - 1.0).abs() < 1e-5, "{k}: area {a} vs {b}");
    }
    let (pp, pt) = (p.total_power(), t.total_power());
    assert!((pp - pt).length() < 1e-4 * pt.length(), "{pp} vs {pt}");
    let reference = block_means(&t, "path", "", 64);
    judge_blocks(&p, &reference, ("path", "", 64, 0.0), |_| false);
}

/// pbrt's `LookAt` makes camera-space x = up × view, which goes to the right of the image: the
/// box seen through pbrt's camera without `Scale -1 1 1` is the TOML box's image mirrored, ray
/// for ray.
#[test]
fn pbrts_left_handed_camera_mirrors_the_image() {
    let path = Path::new("scenes/pbrt/cornell-box-pbrt.pbrt");
    let text = std::fs::read_to_string(path)
        .unwrap()
        .replace("Scale -1 1 1\n", "")
        .replace(
            "xresolution\" 256 \"integer yresolution\" 256",
            "xresolution\" 24 \"integer yresolution\" 24",
        );
    let p = load_scene_bytes(path, text.as_bytes()).unwrap().0;
    assert_eq!(p.camera.width, 24);
    let t = toml_box();
    let w = t.camera.width as f32;
    assert!(p.camera.flip_x && !t.camera.flip_x);
    for raster in [Vec2::new(3.5, 4.5), Vec2::new(12.3, 17.9), Vec2::new(20.0, 2.0)] {
        let a = p.camera.generate_ray(raster);
        let b = t.camera.generate_ray(Vec2::new(w - raster.x, raster.y));
        assert!((a.d - b.d).length() < 1e-5, "{raster}: {} vs {}", a.d, b.d);
    }
}

/// A light above a floor, with everything written through pbrt's transforms and attributes.
fn lit_floor(extra: &str) -> String {
    format!(
        r#"LookAt 0 1 4  0 0 0  0 1 0
Camera "perspective" "float fov" 50
Film "rgb" "integer xresolution" 12 "integer yresolution" 9
PixelFilter "box"
WorldBegin
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
AttributeBegin
  Rotate -90 1 0 0
  Scale 4 4 1
  Shape "trianglemesh" "point3 P" [-1 -1 0  1 -1 0  1 1 0] "integer indices" [0 1 2]
  Shape "trianglemesh" "point3 P" [-1 -1 0  1 1 0  -1 1 0]
AttributeEnd
{extra}
"#
    )
}

/// Transforms compose as pbrt's (the floor, rotated and scaled, lies in y = 0 facing up and
/// spans [−4, 4]²); `AttributeEnd` restores the transform; an area light's side follows the
/// winding, turned around by `ReverseOrientation`; a `Translate`d sphere lands where pbrt puts it;
/// point and distant lights and the constant sky take pbrt's parameters.
#[test]
fn transforms_attributes_orientation_and_lights_mean_what_pbrt_says() {
    let dir = tempfile::tempdir().unwrap();
    let s = load(
        dir.path(),
        "a.pbrt",
        &lit_floor("LightSource \"point\" \"rgb I\" [1 2 3] \"point3 from\" [0 2 0] \"float scale\" 2"),
    )
    .unwrap();
    let (lo, hi) = s.bounds();
    assert!(
        (lo - glam::Vec3::new(-4.0, 0.0, -4.0)).length() < 1e-5
            && (hi - glam::Vec3::new(4.0, 0.0, 4.0)).length() < 1e-5,
        "{lo} {hi}"
    );
    let hit = s
        .intersect(&photon_bench::geometry::Ray::new(
            glam::Vec3::new(0.3, 1.0, 0.2),
            -glam::Vec3::Y,
        ))
        .unwrap();
    assert!(hit.ng.y > 0.99, "the floor faces up: {}", hit.ng);
    assert_eq!(s.delta_lights.len(), 1);
    assert!(
        (s.delta_lights[0].power(1.0) - 4.0 * std::f32::consts::PI * glam::Vec3::new(2.0, 4.0, 6.0)).length() < 1e-3
    );

    // A one-sided emitter facing down lights the floor; turned around it faces up and does not
    // (the camera, below it, sees the floor only).
    let light = |reverse: &str| {
        format!(
            "AttributeBegin\n  Translate 0 2.5 0\n  {reverse}\n  AreaLightSource \"diffuse\" \"rgb L\" [4 4 4]\n  \
             Shape \"trianglemesh\" \"point3 P\" [-0.5 0 -0.5  0.5 0 -0.5  0.5 0 0.5  -0.5 0 0.5] \"integer indices\" [0 1 2 0 2 3]\nAttributeEnd\n\
             Shape \"sphere\" \"float radius\" 0.1"
        )
    };
    let down = load(dir.path(), "d.pbrt", &lit_floor(&light(""))).unwrap();
    let up = load(dir.path(), "u.pbrt", &lit_floor(&light("ReverseOrientation"))).unwrap();
    let mean = |s: &Scene| {
        let img = agreement::render_image(s, "path", "max_depth = 1", 16, 1);
        img.pixels.iter().map(|p| p.x as f64).sum::<f64>() / img.pixels.len() as f64
    };
    let (m_down, m_up) = (mean(&down), mean(&up));
    assert!(
        m_down > 0.01 && m_up < 0.02 * m_down,
        "facing down {m_down}, turned up {m_up}"
    );
    // The sphere after AttributeEnd sits at the origin, not at the light's translation.
    let sphere = down
        .primitives
        .iter()
        .find_map(|p| match p {
            photon_bench::geometry::Primitive::Sphere { center, radius } => Some((*center, *radius)),
            _ => None,
        })
        .unwrap();
    assert!(sphere.0.length() < 1e-6 && (sphere.1 - 0.1).abs() < 1e-6, "{sphere:?}");

    let sky = load(
        dir.path(),
        "s.pbrt",
        &lit_floor("LightSource \"infinite\" \"rgb L\" [0.2 0.3 0.4]\nLightSource \"distant\" \"point3 from\" [0 1 0] \"point3 to\" [0 0 0] \"rgb L\" [3 3 3]"),
    )
    .unwrap();
    assert!((sky.environment.as_ref().unwrap().mean_radiance() - glam::Vec3::new(0.2, 0.3, 0.4)).length() < 1e-6);
    assert_eq!(sky.delta_lights.len(), 1);
}

/// pbrt-v4's materials as ours: roughness remapped to α = √roughness (GGX), a smooth conductor
/// below α 10⁻³, named metal spectra, `mix` as a blend of weight `amount`.
#[test]
fn materials_map_to_ours() {
    let dir = tempfile::tempdir().unwrap();
    let scene = |material: &str| {
        load(
            dir.path(),
            "m.pbrt",
            &lit_floor(&format!(
                "LightSource \"point\" \"rgb I\" [1 1 1] \"point3 from\" [0 2 0]\n{material}\nShape \"sphere\" \"float radius\" 0.3"
            )),
        )
        .unwrap()
    };
    let last = |s: &Scene| {
        let attrs = s.attrs.last().unwrap();
        s.materials[attrs.material as usize].bsdf.clone()
    };
    match last(&scene(
        "Material \"conductor\" \"spectrum eta\" \"metal-Au-eta\" \"spectrum k\" \"metal-Au-k\" \"float roughness\" 0.09",
    )) {
        Bsdf::RoughConductor(c) => {
            assert!((c.distribution.alpha_u - 0.3).abs() < 1e-6, "{:?}", c.distribution);
            assert_eq!(c.distribution.kind, photon_bench::bsdf::MicrofacetType::Ggx);
            assert!(c.distribution.height_correlated, "pbrt-v4's masking");
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(last(&scene("Material \"conductor\"")), Bsdf::Conductor(_)));
    // η and k as RGB, and pbrt-v4's reflectance mode: η = 1, k = 2√r / √(1 − r), whose
    // normal-incidence Fresnel reflectance is r.
    match last(&scene(
        "Material \"conductor\" \"rgb eta\" [0.2 0.4 1.4] \"rgb k\" [3.9 2.4 1.6]",
    )) {
        Bsdf::Conductor(c) => assert!((c.ior.eta - glam::Vec3::new(0.2, 0.4, 1.4)).length() < 1e-6),
        other => panic!("{other:?}"),
    }
    match last(&scene("Material \"conductor\" \"rgb reflectance\" [0.9 0.5 0.1]")) {
        Bsdf::Conductor(c) => {
            let f = photon_bench::bsdf::fresnel_conductor(1.0, c.ior.eta, c.ior.k);
            assert!((f - glam::Vec3::new(0.9, 0.5, 0.1)).length() < 1e-4, "{f}");
        }
        other => panic!("{other:?}"),
    }
    // A spectrum file of pairs (pbrt's .spd) for k beside a named η.
    std::fs::write(
        dir.path().join("k.spd"),
        "# k of a grey metal\n400 2.0\n500 2.0\n600 2.0\n700 2.0\n",
    )
    .unwrap();
    match last(&scene(
        "Material \"conductor\" \"spectrum eta\" \"metal-Au-eta\" \"spectrum k\" \"k.spd\"",
    )) {
        Bsdf::Conductor(c) => {
            // Converted as Mitsuba converts an unbounded spectrum (so the same spectrum in a
            // Mitsuba file gives the same k; a flat spectrum is not grey in sRGB).
            let pairs = [(400.0, 2.0), (500.0, 2.0), (600.0, 2.0), (700.0, 2.0)];
            let k = photon_bench::spectrum::list_to_srgb(&pairs, false).0.as_vec3();
            assert!((c.ior.k - k).length() < 1e-5, "{} vs {k}", c.ior.k);
            let au = photon_bench::bsdf::ConductorIor::named("Au").unwrap();
            assert!((c.ior.eta - au.eta).length() < 1e-6);
        }
        other => panic!("{other:?}"),
    }
    assert!(
        matches!(last(&scene("Material \"dielectric\" \"float eta\" 1.33")), Bsdf::Dielectric(d) if (d.ior - 1.33).abs() < 1e-6)
    );
    let mix = "MakeNamedMaterial \"a\" \"string type\" \"diffuse\"\nMakeNamedMaterial \"b\" \"string type\" \"conductor\"\n\
               Material \"mix\" \"string materials\" [\"a\" \"b\"] \"float amount\" 0.25";
    match last(&scene(mix)) {
        Bsdf::Blend(b) => assert!((b.weight - 0.25).abs() < 1e-6 && matches!(b.bsdfs[1], Bsdf::Conductor(_))),
        other => panic!("{other:?}"),
    }
}

/// What is not read is refused in one line naming the file's line and the directive.
#[test]
fn what_is_not_read_is_refused_naming_the_line() {
    let dir = tempfile::tempdir().unwrap();
    for (extra, expect) in [
        ("Material \"hair\"", &["line 13", "Material", "hair"][..]),
        (
            "MakeNamedMedium \"fog\"",
            &["line 13", "MakeNamedMedium", "string type"],
        ),
        (
            "MakeNamedMedium \"fog\" \"string type\" \"uniformgrid\"",
            &["line 13", "uniformgrid", "not read"],
        ),
        (
            "MakeNamedMedium \"fog\" \"string type\" \"homogeneous\" \"string preset\" \"Skin1\"",
            &["line 13", "preset"],
        ),
        (
            "MakeNamedMedium \"fog\" \"string type\" \"homogeneous\" \"rgb Le\" [1 1 1]",
            &["line 13", "Le", "emitting"],
        ),
        (
            "MakeNamedMedium \"fog\" \"string type\" \"homogeneous\" \"float g\" 1",
            &["line 13", "g:", "(-1, 1)"],
        ),
        (
            "MakeNamedMedium \"fog\" \"string type\" \"homogeneous\" \"rgb sigma_a\" [1 -1 1]",
            &["line 13", "sigma_a", ">= 0"],
        ),
        (
            "MakeNamedMedium \"fog\" \"string type\" \"homogeneous\" \"float sigma_t\" 1",
            &["line 13", "sigma_t"],
        ),
        (
            "MediumInterface \"nowhere\" \"\"",
            &["line 13", "MediumInterface", "no medium named \"nowhere\""],
        ),
        ("MediumInterface 1 2", &["line 13", "medium names"]),
        ("ObjectInstance \"tree\"", &["line 13", "no object named"]),
        ("ObjectBegin \"tree\"", &["ObjectBegin", "never ended"]),
        (
            "ObjectBegin \"a\"\nAreaLightSource \"diffuse\"\nShape \"sphere\"\nObjectEnd",
            &["line 15", "area light", "ObjectBegin"],
        ),
        ("ObjectEnd", &["line 13", "no ObjectBegin"]),
        (
            "Shape \"loopsubdiv\" \"point3 P\" [0 0 0 1 0 0 0 1 0 -1 0 0 0 -1 0] \"integer indices\" [0 1 2 0 3 4]",
            &["line 13", "loopsubdiv", "not a manifold at vertex 0"],
        ),
        (
            "Shape \"loopsubdiv\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"integer indices\" [0 1 5]",
            &["line 13", "indices", "[0, 3)"],
        ),
        (
            "Shape \"sphere\" \"float phimax\" 180",
            &["line 13", "Shape", "partial"],
        ),
        (
            "Shape \"sphere\" \"float radius\" [1 2]",
            &["line 13", "radius", "one float"],
        ),
        (
            "Material \"diffuse\" \"rgb reflectance\" [0.5 0.5]",
            &["line 13", "3 numbers"],
        ),
        ("LightSource \"goniometric\"", &["line 13", "goniometric"]),
        (
            "LightSource \"spot\" \"float coneangle\" 30 \"float conedeltaangle\" 40",
            &["line 13", "conedeltaangle"],
        ),
        (
            "Shape \"sphere\" \"float radius\" 1 \"float radiuz\" 2",
            &["line 13", "radiuz"],
        ),
        ("NamedMaterial \"nowhere\"", &["line 13", "no material named"]),
        ("AttributeEnd", &["line 13", "no AttributeBegin"]),
        ("AttributeBegin", &["never ended"]),
    ] {
        let err = load(dir.path(), "bad.pbrt", &lit_floor(extra))
            .err()
            .expect(extra)
            .to_string();
        assert_refused(&err, expect);
        assert!(err.contains("bad.pbrt"), "{err}");
    }
}

/// The two pieces a pbrt scene needs that TOML scenes now have as well: a `triangles` shape
/// (a mesh written in the file; bad indices refused naming the field) and a mirrored camera
/// (`flip_x`), which Mitsuba files write as a scale of −1 in the sensor's `to_world`: exported
/// and read back, the rays are the same.
#[test]
fn inline_triangles_and_mirrored_cameras_in_toml_and_mitsuba() {
    let dir = tempfile::tempdir().unwrap();
    let triangles = "type = \"triangles\"\nmaterial = \"grey\"\npositions = [[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]]\n\
                     indices = [0, 2, 1, 0, 3, 2]\nuv = [[0, 0], [1, 0], [1, 1], [0, 1]]";
    let scene = |shape: &str, flip: bool| {
        format!(
            "[camera]\neye = [0, 1, 4]\nlook_at = [0, 0, 0]\nfov_y = 40\nresolution = [16, 12]\nflip_x = {flip}\n\
             [materials.grey]\ntype = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n[[shapes]]\n{shape}\n\
             [[lights]]\ntype = \"point\"\nposition = [0, 2, 0]\nintensity = [1, 1, 1]\n"
        )
    };
    let s = load(dir.path(), "t.toml", &scene(triangles, true)).unwrap();
    assert_eq!(s.primitives.len(), 2);
    let hit = s
        .intersect(&photon_bench::geometry::Ray::new(
            glam::Vec3::new(0.2, 1.0, 0.3),
            -glam::Vec3::Y,
        ))
        .unwrap();
    assert!(hit.ng.y > 0.99, "wound to face up: {}", hit.ng);
    let uv = s.uv(&hit);
    assert!((uv - Vec2::new(0.6, 0.65)).length() < 1e-5, "{uv}");
    for (bad, expect) in [
        ("indices = [0, 2]", &["shapes[0].indices", "multiple of 3"][..]),
        ("indices = [0, 2, 7]", &["shapes[0].indices", "7"]),
    ] {
        let text = scene(triangles, false).replace("indices = [0, 2, 1, 0, 3, 2]", bad);
        assert_refused(&load(dir.path(), "b.toml", &text).err().unwrap().to_string(), expect);
    }
    let plain = load(dir.path(), "p.toml", &scene(triangles, false)).unwrap();
    let raster = Vec2::new(3.25, 5.5);
    let (a, b) = (
        s.camera.generate_ray(raster),
        plain.camera.generate_ray(Vec2::new(16.0 - raster.x, raster.y)),
    );
    assert!((a.d - b.d).length() < 1e-6, "{} vs {}", a.d, b.d);
    // Mitsuba: a mirrored sensor frame is a mirrored image, both ways.
    let toml = dir.path().join("m.toml");
    let quad = "type = \"quad\"\nmaterial = \"grey\"\ncorner = [-1, 0, -1]\nedge_u = [0, 0, 2]\nedge_v = [2, 0, 0]";
    std::fs::write(&toml, scene(quad, true)).unwrap();
    let xml = dir.path().join("m.xml");
    photon_bench::scene::export::export_file(&toml, &xml).unwrap();
    let back = photon_bench::scene::load::load_scene_with_stats(&xml).unwrap().0;
    assert!(back.camera.flip_x);
    let c = back.camera.generate_ray(raster);
    assert!((c.d - a.d).length() < 1e-5, "{} vs {}", c.d, a.d);
}

/// A `bilinearmesh` of flat patches is the two triangles pbrt's patch spans, with its front
/// side: the floor written as one patch renders bit-identically to the floor written as two
/// triangles; a curved patch is refused naming the line.
#[test]
fn flat_bilinear_patches_are_their_two_triangles() {
    let dir = tempfile::tempdir().unwrap();
    let light = "LightSource \"point\" \"rgb I\" [1 1 1] \"point3 from\" [0 2 0]";
    let triangles = load(dir.path(), "t.pbrt", &lit_floor(light)).unwrap();
    let patch = lit_floor(light).replace(
        "  Shape \"trianglemesh\" \"point3 P\" [-1 -1 0  1 -1 0  1 1 0] \"integer indices\" [0 1 2]\n  \
         Shape \"trianglemesh\" \"point3 P\" [-1 -1 0  1 1 0  -1 1 0]",
        "  Shape \"bilinearmesh\" \"point3 P\" [-1 -1 0  1 -1 0  -1 1 0  1 1 0]",
    );
    assert!(patch.contains("bilinearmesh"));
    let bilinear = load(dir.path(), "b.pbrt", &patch).unwrap();
    assert_eq!(bilinear.primitives, triangles.primitives);
    let bits = |s: &Scene| -> Vec<u32> {
        let img = agreement::render_image(s, "path", "max_depth = 2", 4, 3);
        img.pixels.iter().flat_map(|p| p.to_array()).map(f32::to_bits).collect()
    };
    assert_eq!(bits(&bilinear), bits(&triangles));
    let curved = patch.replace("-1 1 0  1 1 0]", "-1 1 0  1 1 0.5]");
    let err = load(dir.path(), "c.pbrt", &curved).err().unwrap().to_string();
    assert_refused(&err, &["line 10", "bilinearmesh", "curved"]);
}

const LIGHT: &str = "LightSource \"point\" \"rgb I\" [1 1 1] \"point3 from\" [0 3 0]";

/// Object instancing: the shapes of `ObjectBegin` … `ObjectEnd` are not in the scene until an
/// `ObjectInstance` puts a copy there, with the transform at the instance applied after the one
/// at the definition (pbrt-v4's world-from-instance); the scene equals the one with the copies
/// written out.
#[test]
fn object_instances_are_their_shapes_where_pbrt_puts_them() {
    let dir = tempfile::tempdir().unwrap();
    let object = "ObjectBegin \"pole\"\n  Translate 0 0.5 0\n  Shape \"trianglemesh\" \"point3 P\" [-0.1 -0.5 0  0.1 -0.5 0  0.1 0.5 0] \"integer indices\" [0 1 2]\nObjectEnd";
    let instanced = load(
        dir.path(),
        "i.pbrt",
        &lit_floor(&format!(
            "{LIGHT}\n{object}\nAttributeBegin\n  Translate 2 0 0\n  ObjectInstance \"pole\"\nAttributeEnd\nAttributeBegin\n  Translate -2 0 1\n  Scale 2 2 2\n  ObjectInstance \"pole\"\nAttributeEnd"
        )),
    )
    .unwrap();
    let written = load(
        dir.path(),
        "w.pbrt",
        &lit_floor(&format!(
            "{LIGHT}\nAttributeBegin\n  Translate 2 0.5 0\n  Shape \"trianglemesh\" \"point3 P\" [-0.1 -0.5 0  0.1 -0.5 0  0.1 0.5 0] \"integer indices\" [0 1 2]\nAttributeEnd\n\
             AttributeBegin\n  Translate -2 0 1\n  Scale 2 2 2\n  Translate 0 0.5 0\n  Shape \"trianglemesh\" \"point3 P\" [-0.1 -0.5 0  0.1 -0.5 0  0.1 0.5 0] \"integer indices\" [0 1 2]\nAttributeEnd",
        )),
    )
    .unwrap();
    assert_eq!(instanced.primitives.len(), written.primitives.len());
    for (a, b) in instanced.primitives.iter().zip(&written.primitives) {
        assert_eq!(format!("{a:?}"), format!("{b:?}"));
    }
    // Defined but never instanced: nothing but the floor.
    let unused = load(dir.path(), "u.pbrt", &lit_floor(&format!("{LIGHT}\n{object}"))).unwrap();
    assert_eq!(unused.primitives.len(), 2);
}

/// `loopsubdiv`: a closed control mesh (an octahedron) refined `levels` times into 8 · 4^levels
/// triangles on its limit surface, the top vertex where Loop's limit mask puts it.
#[test]
fn loop_subdivision_surfaces_are_refined_onto_their_limit() {
    let dir = tempfile::tempdir().unwrap();
    let s = load(
        dir.path(),
        "l.pbrt",
        &lit_floor(&format!(
            "{LIGHT}\nAttributeBegin\nTranslate 0 1 0\nShape \"loopsubdiv\" \"integer levels\" 2 \"point3 P\" [1 0 0 -1 0 0 0 1 0 0 -1 0 0 0 1 0 0 -1]\n\
             \"integer indices\" [0 2 4 2 1 4 1 3 4 3 0 4 2 0 5 1 2 5 3 1 5 0 3 5]\nAttributeEnd",
        )),
    )
    .unwrap();
    let triangles = s
        .primitives
        .iter()
        .filter(|p| matches!(p, photon_bench::geometry::Primitive::Triangle { .. }))
        .count();
    assert_eq!(triangles, 2 + 8 * 16);
    // The limit of an octahedron's vertex (valence 4: γ = 1/8) is halfway to the centre, at
    // any level: (1 − 4γ) v + γ Σ ring = v / 2 for a ring summing to zero.
    let (lo, hi) = s.bounds();
    let r = (hi.y - 1.0) as f64;
    assert!((r - 0.5).abs() < 1e-6, "{lo} {hi}");
    let hit = s
        .intersect(&photon_bench::geometry::Ray::new(
            glam::Vec3::new(0.0, 3.0, 0.0),
            -glam::Vec3::Y,
        ))
        .unwrap();
    assert!(((hit.p.y - 1.0) as f64 - r).abs() < 1e-4, "{}", hit.p);
}

/// pbrt-v4's spot: from `from` toward `to` through the transform, full intensity inside
/// coneangle − conedeltaangle, smoothstep(cos coneangle, cos beam, cos θ) out to coneangle,
/// dark beyond; its power 2π I ((1 − cos θ_b) + (cos θ_b − cos θ_c)/2).
#[test]
fn pbrt_spots_fall_off_as_pbrt_says() {
    let dir = tempfile::tempdir().unwrap();
    let s = load(
        dir.path(),
        "s.pbrt",
        &lit_floor(
            "AttributeBegin\nTranslate 0 2 0\nLightSource \"spot\" \"rgb I\" [2 2 2] \"point3 from\" [0 0 0] \"point3 to\" [0 -1 0] \"float coneangle\" 30 \"float conedeltaangle\" 10\nAttributeEnd",
        ),
    )
    .unwrap();
    let light = &s.delta_lights[0];
    let at = |deg: f64| {
        let x = 2.0 * deg.to_radians().tan();
        let inc = light.illuminate(glam::Vec3::new(x as f32, 0.0, 0.0));
        inc.map_or(0.0, |i| (i.li.x * i.dist * i.dist / 2.0) as f64)
    };
    assert!((at(0.0) - 1.0).abs() < 1e-5 && (at(19.0) - 1.0).abs() < 1e-5);
    assert!(at(30.5) == 0.0);
    let (c, b, x) = (
        30f64.to_radians().cos(),
        20f64.to_radians().cos(),
        25f64.to_radians().cos(),
    );
    let t = (x - c) / (b - c);
    assert!((at(25.0) - t * t * (3.0 - 2.0 * t)).abs() < 1e-4, "{}", at(25.0));
    let power = 2.0 * std::f64::consts::TAU * ((1.0 - b) + 0.5 * (b - c));
    assert!((light.power(1.0).x as f64 / power - 1.0).abs() < 1e-5);
}

/// pbrt-v4's image `infinite` light: a square equal-area map, turned by the transform, read by
/// nearest texel; a uniform white map scaled by s renders as the constant sky of radiance s,
/// and a single bright texel lights the direction pbrt's mapping gives it.
#[test]
fn equal_area_environment_maps_are_read_as_pbrt_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let n = 8u32;
    image::RgbImage::from_pixel(n, n, image::Rgb([255, 255, 255]))
        .save(dir.path().join("white.png"))
        .unwrap();
    let mut spot = image::RgbImage::from_pixel(n, n, image::Rgb([0, 0, 0]));
    spot.put_pixel(5, 2, image::Rgb([255, 255, 255]));
    spot.save(dir.path().join("spot.png")).unwrap();
    let sky = |light: &str| load(dir.path(), "e.pbrt", &lit_floor(light)).unwrap();
    let mean = |s: &Scene| agreement::image_mean(s, "path", "max_depth = 3", 64);
    let map = sky("LightSource \"infinite\" \"string filename\" \"white.png\" \"float scale\" 0.3");
    let constant = sky("LightSource \"infinite\" \"rgb L\" [0.3 0.3 0.3]");
    let (a, b) = (mean(&map), mean(&constant));
    assert!(
        (a.0 - b.0).abs() < 4.0 * (a.1 * a.1 + b.1 * b.1).sqrt(),
        "{a:?} vs {b:?}"
    );

    let turned =
        sky("AttributeBegin\nRotate 90 1 0 0\nLightSource \"infinite\" \"string filename\" \"spot.png\"\nAttributeEnd");
    let env = turned.environment.as_ref().unwrap();
    let centre = glam::Vec2::new(5.5, 2.5) / n as f32;
    let local = photon_bench::light::equal_area::square_to_sphere(centre);
    let world = glam::Quat::from_rotation_x(90f32.to_radians()) * local;
    assert!((env.le(world) - glam::Vec3::ONE).length() < 1e-6, "{}", env.le(world));
    assert_eq!(env.le(local), glam::Vec3::ZERO, "the map is turned");
    // Its sampling finds the texel: every sample lands there.
    let s = env.sample(glam::Vec2::new(0.3, 0.7)).unwrap();
    assert!(s.wi.dot(world) > 0.8 && (s.le - glam::Vec3::ONE).length() < 1e-6);
    let err = load(
        dir.path(),
        "bad.pbrt",
        &lit_floor("LightSource \"infinite\" \"string filename\" \"white.png\" \"string portal\" \"x\""),
    )
    .err()
    .unwrap()
    .to_string();
    assert_refused(&err, &["line 13", "portal"]);
}

/// gzip-compressed files as pbrt-v4 reads them: the scene itself (`.pbrt.gz`), an `Include`d
/// file and a PLY mesh (`.ply.gz`); includes, also inside includes, are relative to the main
/// file's directory (pbrt's search directory); a damaged stream is refused in one line.
#[test]
fn gzip_compressed_scenes_includes_and_meshes_are_read() {
    use std::io::Write;
    let dir = tempfile::tempdir().unwrap();
    let gz = |path: &std::path::Path, text: &str| {
        let mut z = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(text.as_bytes()).unwrap();
        std::fs::write(path, z.finish().unwrap()).unwrap();
    };
    std::fs::create_dir(dir.path().join("geometry")).unwrap();
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
               element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0.5 0\n1 0.5 0\n0 0.5 1\n3 0 1 2\n";
    gz(&dir.path().join("geometry/tri.ply.gz"), ply);
    // Included from geometry/, naming its own include relative to the main file.
    gz(
        &dir.path().join("geometry/outer.pbrt.gz"),
        "Include \"geometry/inner.pbrt\"\n",
    );
    std::fs::write(
        dir.path().join("geometry/inner.pbrt"),
        "Shape \"plymesh\" \"string filename\" \"geometry/tri.ply.gz\"\n",
    )
    .unwrap();
    let main = dir.path().join("scene.pbrt.gz");
    gz(
        &main,
        &lit_floor(&format!("{LIGHT}\nInclude \"geometry/outer.pbrt.gz\"")),
    );
    let s = photon_bench::scene::load::load_scene_with_stats(&main).unwrap().0;
    assert_eq!(s.primitives.len(), 3, "the floor's two triangles and the PLY's one");
    std::fs::write(dir.path().join("geometry/outer.pbrt.gz"), b"not gzip").unwrap();
    let err = photon_bench::scene::load::load_scene_with_stats(&main)
        .err()
        .unwrap()
        .to_string();
    assert_refused(&err, &["outer.pbrt.gz", "gzip"]);
}

/// A PLY mesh turned around by `ReverseOrientation`: where the file has no normals the winding
/// decides its front and turns; where it has normals they decide, as pbrt-v4 does.
#[test]
fn reverse_orientation_turns_a_ply_mesh_where_its_winding_decides() {
    let dir = tempfile::tempdir().unwrap();
    let quad = |normals: bool| {
        let (props, n) = if normals {
            ("property float nx\nproperty float ny\nproperty float nz\n", " 0 -1 0")
        } else {
            ("", "")
        };
        format!(
            "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n{props}\
             element face 2\nproperty list uchar int vertex_indices\nend_header\n\
             -0.5 0 -0.5{n}\n0.5 0 -0.5{n}\n0.5 0 0.5{n}\n-0.5 0 0.5{n}\n3 0 1 2\n3 0 2 3\n"
        )
    };
    std::fs::write(dir.path().join("bare.ply"), quad(false)).unwrap();
    std::fs::write(dir.path().join("normals.ply"), quad(true)).unwrap();
    let lit = |file: &str, reverse: &str| {
        let s = load(
            dir.path(),
            "p.pbrt",
            &lit_floor(&format!(
                "AttributeBegin\n  Translate 0 2.5 0\n  {reverse}\n  AreaLightSource \"diffuse\" \"rgb L\" [4 4 4]\n  \
                 Shape \"plymesh\" \"string filename\" \"{file}\"\nAttributeEnd"
            )),
        )
        .unwrap();
        let img = agreement::render_image(&s, "path", "max_depth = 1", 16, 1);
        img.pixels.iter().map(|p| p.x as f64).sum::<f64>() / img.pixels.len() as f64
    };
    let (down, up) = (lit("bare.ply", ""), lit("bare.ply", "ReverseOrientation"));
    assert!(down > 0.01 && up < 0.02 * down, "facing down {down}, turned up {up}");
    let (a, b) = (lit("normals.ply", ""), lit("normals.ply", "ReverseOrientation"));
    assert!(a > 0.01 && (a - b).abs() < 1e-9, "with normals: {a} vs {b}");
}

/// The shipped pbrt-v4 still life loads with everything it was written to show: layered
/// materials, a Loop-subdivision blob and three instanced pebbles, a smoothstep spot and an
/// equal-area sky.
#[test]
fn the_shipped_pbrt_still_life_loads_with_its_features() {
    use photon_bench::light::environment::Radiance;
    let s = small(
        "scenes/pbrt/coated-still-life.pbrt",
        "\"integer xresolution\" 160 \"integer yresolution\" 120",
        "\"integer xresolution\" 16 \"integer yresolution\" 12",
    );
    let coated = s.materials.iter().filter(|m| matches!(m.bsdf, Bsdf::Coated(_))).count();
    assert_eq!(coated, 3, "blob, sphere and pebble");
    let triangles = s
        .primitives
        .iter()
        .filter(|p| matches!(p, photon_bench::geometry::Primitive::Triangle { .. }))
        .count();
    assert_eq!(
        triangles,
        2 + 12 * 64 + 3 * 8 * 16,
        "floor, blob (3 levels), three pebbles (2 levels)"
    );
    assert!(matches!(&s.delta_lights[0], photon_bench::light::delta::DeltaLight::Spot(sp) if sp.is_smoothstep()));
    assert!(matches!(
        s.environment.as_ref().unwrap().radiance,
        Radiance::EqualArea(_)
    ));
}

/// pbrt-v4's `scale` texture (and an `imagemap`'s own `scale`): the texture's values times the
/// factor — a checkerboard's colours, a bitmap's texels, a constant made uniform; a scaled
/// bitmap has no Mitsuba equivalent and is not exported.
#[test]
fn scale_textures_multiply_what_they_scale() {
    let dir = tempfile::tempdir().unwrap();
    image::RgbImage::from_pixel(2, 2, image::Rgb([255, 255, 255]))
        .save(dir.path().join("white.png"))
        .unwrap();
    let reflectance_at = |textures: &str, uv: glam::Vec2| {
        let s = load(
            dir.path(),
            "t.pbrt",
            &lit_floor(&format!(
                "{LIGHT}\n{textures}\nMaterial \"diffuse\" \"texture reflectance\" \"s\"\nShape \"sphere\" \"float radius\" 0.3"
            )),
        )
        .unwrap();
        let m = &s.materials[s.attrs.last().unwrap().material as usize];
        m.textures[0].1.eval(uv)
    };
    let checks = "Texture \"c\" \"spectrum\" \"checkerboard\" \"rgb tex1\" [0.8 0.6 0.4] \"rgb tex2\" [0.2 0.2 0.2]\n\
                  Texture \"s\" \"spectrum\" \"scale\" \"texture tex\" \"c\" \"float scale\" 0.5";
    let (a, b) = (
        reflectance_at(checks, glam::Vec2::new(0.5, 0.5)),
        reflectance_at(checks, glam::Vec2::new(1.5, 0.5)),
    );
    let (lo, hi) = (a.min(b), a.max(b));
    assert!(
        (hi - glam::Vec3::new(0.4, 0.3, 0.2)).length() < 1e-6 && (lo - glam::Vec3::splat(0.1)).length() < 1e-6,
        "{a} {b}"
    );
    let image = "Texture \"i\" \"spectrum\" \"imagemap\" \"string filename\" \"white.png\" \"float scale\" 0.5\n\
                 Texture \"s\" \"spectrum\" \"scale\" \"texture tex\" \"i\" \"float scale\" 0.6";
    assert!((reflectance_at(image, glam::Vec2::splat(0.3)) - glam::Vec3::splat(0.3)).length() < 1e-6);
    let constant = "Texture \"s\" \"spectrum\" \"scale\" \"rgb tex\" [0.5 0.4 0.3] \"float scale\" 0.5";
    assert!((reflectance_at(constant, glam::Vec2::splat(0.7)) - glam::Vec3::new(0.25, 0.2, 0.15)).length() < 1e-6);
    // Exported to Mitsuba: refused, naming the file.
    let path = dir.path().join("t.pbrt");
    std::fs::write(
        &path,
        lit_floor(&format!("{LIGHT}\n{image}\nMaterial \"diffuse\" \"texture reflectance\" \"s\"\nShape \"sphere\" \"float radius\" 0.3")),
    )
    .unwrap();
    let err = photon_bench::scene::export::export_file(&path, &dir.path().join("t.xml"))
        .err()
        .unwrap()
        .to_string();
    assert!(err.contains("white.png") && err.contains("scaled bitmap"), "{err}");
}

/// A pbrt scene exported to Mitsuba 3 (`bench export-mitsuba` on a `.pbrt`) reads back as the
/// same scene: the camera's rays (pbrt's mirrored camera as Mitsuba's scaled sensor frame), the
/// triangles and the materials.
#[test]
fn a_pbrt_scene_exports_to_mitsuba_as_the_same_scene() {
    let dir = tempfile::tempdir().unwrap();
    let file = std::path::Path::new("scenes/pbrt/cornell-box-pbrt.pbrt");
    let out = dir.path().join("box.xml");
    photon_bench::scene::export::export_file(file, &out).unwrap();
    let (p, m) = (
        photon_bench::scene::load::load_scene_with_stats(file).unwrap().0,
        photon_bench::scene::load::load_scene_with_stats(&out).unwrap().0,
    );
    assert_eq!(p.primitives.len(), m.primitives.len());
    for raster in [Vec2::new(0.5, 0.5), Vec2::new(100.3, 17.9), Vec2::new(255.9, 200.1)] {
        let (a, b) = (p.camera.generate_ray(raster), m.camera.generate_ray(raster));
        assert!(
            (a.d - b.d).length() < 1e-5 && (a.o - b.o).length() < 1e-5,
            "{raster}: {} vs {}",
            a.d,
            b.d
        );
    }
    let reflectances = |s: &Scene| {
        let mut v: Vec<String> = s.materials.iter().map(|m| format!("{:?}", m.bsdf.albedo())).collect();
        v.sort();
        v
    };
    assert_eq!(reflectances(&p), reflectances(&m));
}

/// A `triangles` shape exports as a PLY file beside the XML: with vertex normals against its
/// winding it is rewound so that Mitsuba's front (the winding's) is ours (the normals'), and a
/// ray meets the same surface, facing the same way, in the scene read back.
#[test]
fn inline_triangles_export_as_ply_files_with_their_front_side() {
    let dir = tempfile::tempdir().unwrap();
    let toml = r#"[camera]
eye = [0, 2, 3]
look_at = [0, 0, 0]
fov_y = 40
resolution = [8, 6]
[materials.m]
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]
[[shapes]]
type = "triangles"
material = "m"
positions = [[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]]
indices = [0, 1, 2, 0, 2, 3]
normals = [[0, 1, 0], [0, 1, 0], [0, 1, 0], [0, 1, 0]]
uv = [[0, 0], [1, 0], [1, 1], [0, 1]]
emission = { radiance = [1, 1, 1] }
"#;
    let path = dir.path().join("t.toml");
    std::fs::write(&path, toml).unwrap();
    let out = dir.path().join("t.xml");
    photon_bench::scene::export::export_file(&path, &out).unwrap();
    assert!(dir.path().join("t-triangles-0.ply").exists());
    let (a, b) = (
        photon_bench::scene::load::load_scene_with_stats(&path).unwrap().0,
        photon_bench::scene::load::load_scene_with_stats(&out).unwrap().0,
    );
    let ray = photon_bench::geometry::Ray::new(glam::Vec3::new(0.3, 2.0, 0.2), -glam::Vec3::Y);
    let (ha, hb) = (a.intersect(&ray).unwrap(), b.intersect(&ray).unwrap());
    assert!(ha.ng.y > 0.99 && hb.ng.y > 0.99, "{} {}", ha.ng, hb.ng);
    assert!((ha.p - hb.p).length() < 1e-5);
    assert!((a.texture_point(&ha).uv - b.texture_point(&hb).uv).length() < 1e-5);
    assert_eq!(a.lights.len(), b.lights.len());
}

/// pbrt-v4's media: `MakeNamedMedium "homogeneous"` becomes our medium (σ_t = scale (σ_a +
/// σ_s), albedo σ_s / σ_t, Henyey–Greenstein g), `MediumInterface` gives a shape its interior
/// and exterior where its two sides differ and the camera its outside, and `Material
/// "interface"` is `null`: the scene (camera in fog, a glass ball of milk, an interface ball of
/// smoke, a floor and a spherical lamp) loads as the same scene written in TOML, and `path`
/// renders the two alike (image means within 4 standard errors).
#[test]
fn pbrt_media_mean_what_pbrt_says() {
    let dir = tempfile::tempdir().unwrap();
    let pbrt = "LookAt 0 1 3.5  0 0.8 0  0 1 0\n\
        MediumInterface \"fog\" \"fog\"\n\
        Camera \"perspective\" \"float fov\" 50\n\
        Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 12\n\
        PixelFilter \"box\"\n\
        MakeNamedMedium \"fog\" \"string type\" \"homogeneous\" \"rgb sigma_a\" [0.03 0.08 0.15] \"rgb sigma_s\" [0.27 0.32 0.35] \"float g\" 0.5\n\
        MakeNamedMedium \"milk\" \"string type\" \"homogeneous\" \"rgb sigma_a\" [0.1 0.2 0.4] \"rgb sigma_s\" [1.9 1.8 1.6] \"float scale\" 0.5\n\
        MakeNamedMedium \"smoke\" \"string type\" \"homogeneous\" \"float g\" -0.3\n\
        WorldBegin\n\
        Material \"diffuse\" \"rgb reflectance\" [0.7 0.7 0.7]\n\
        Shape \"trianglemesh\" \"point3 P\" [-3 0 -3  3 0 -3  3 0 3  -3 0 3] \"integer indices\" [0 2 1 0 3 2]\n\
        AttributeBegin\n\
          AreaLightSource \"diffuse\" \"rgb L\" [6 6 6]\n\
          Translate 0 2.5 0\n\
          Shape \"sphere\" \"float radius\" 0.3\n\
        AttributeEnd\n\
        AttributeBegin\n\
          MediumInterface \"milk\" \"fog\"\n\
          Material \"dielectric\" \"float eta\" 1.3\n\
          Translate 0.5 0.5 0\n\
          Shape \"sphere\" \"float radius\" 0.5\n\
        AttributeEnd\n\
        AttributeBegin\n\
          MediumInterface \"smoke\" \"fog\"\n\
          Material \"interface\"\n\
          Translate -0.6 0.6 -0.3\n\
          Shape \"sphere\" \"float radius\" 0.5\n\
        AttributeEnd\n";
    let toml = "[camera]\neye = [0, 1, 3.5]\nlook_at = [0, 0.8, 0]\nup = [0, 1, 0]\nfov_y = 50\nresolution = [16, 12]\nmedium = \"fog\"\n\
        [materials.white]\ntype = \"diffuse\"\nreflectance = [0.7, 0.7, 0.7]\n\
        [materials.glass]\ntype = \"dielectric\"\nior = 1.3\n\
        [materials.boundary]\ntype = \"null\"\n\
        [media.fog]\ntype = \"homogeneous\"\nsigma_t = [0.3, 0.4, 0.5]\nalbedo = [0.9, 0.8, 0.7]\nphase = { type = \"hg\", g = 0.5 }\n\
        [media.milk]\ntype = \"homogeneous\"\nsigma_t = [2, 2, 2]\nscale = 0.5\nalbedo = [0.95, 0.9, 0.8]\nphase = { type = \"hg\", g = 0 }\n\
        [media.smoke]\ntype = \"homogeneous\"\nsigma_t = [2, 2, 2]\nalbedo = [0.5, 0.5, 0.5]\nphase = { type = \"hg\", g = -0.3 }\n\
        [[shapes]]\ntype = \"quad\"\nmaterial = \"white\"\ncenter = [0, 0, 0]\nsize = [6, 6]\nfacing = \"+y\"\n\
        [[shapes]]\ntype = \"sphere\"\nmaterial = \"white\"\ncenter = [0, 2.5, 0]\nradius = 0.3\nemission = { radiance = [6, 6, 6] }\n\
        [[shapes]]\ntype = \"sphere\"\nmaterial = \"glass\"\ncenter = [0.5, 0.5, 0]\nradius = 0.5\ninterior = \"milk\"\nexterior = \"fog\"\n\
        [[shapes]]\ntype = \"sphere\"\nmaterial = \"boundary\"\ncenter = [-0.6, 0.6, -0.3]\nradius = 0.5\ninterior = \"smoke\"\nexterior = \"fog\"\n";
    let (p, t) = (
        load(dir.path(), "fog.pbrt", pbrt).unwrap(),
        load(dir.path(), "fog.toml", toml).unwrap(),
    );
    let medium = |s: &Scene, m: Option<u32>| m.map(|i| s.media[i as usize].name.clone());
    assert_eq!(medium(&p, p.camera_medium).as_deref(), Some("fog"));
    for name in ["fog", "milk", "smoke"] {
        let find = |s: &Scene| s.media.iter().find(|m| m.name == name).cloned().unwrap();
        let (a, b) = (find(&p), find(&t));
        assert!(
            (a.sigma_t - b.sigma_t).abs().max_element() < 1e-6,
            "{name}: σ_t {} vs {}",
            a.sigma_t,
            b.sigma_t
        );
        assert!(
            (a.albedo_at(glam::Vec3::ZERO) - b.albedo_at(glam::Vec3::ZERO))
                .abs()
                .max_element()
                < 1e-6,
            "{name}: albedo"
        );
        assert_eq!(a.phase.mean_cosine(), b.phase.mean_cosine(), "{name}: g");
    }
    // Every sphere's media: the lamp none (no MediumInterface transition), the balls theirs.
    let spheres = |s: &Scene| -> Vec<(Option<String>, Option<String>)> {
        s.attrs
            .iter()
            .zip(&s.primitives)
            .filter(|(_, prim)| matches!(prim, photon_bench::geometry::Primitive::Sphere { .. }))
            .map(|(a, _)| (medium(s, a.interior), medium(s, a.exterior)))
            .collect()
    };
    let mut sp = spheres(&p);
    sp.sort();
    let mut st = spheres(&t);
    st.sort();
    assert_eq!(sp, st);
    assert!(sp.contains(&(Some("milk".into()), Some("fog".into()))), "{sp:?}");
    let passed = |s: &Scene| {
        s.attrs
            .iter()
            .filter(|a| s.materials[a.material as usize].opacity_at(|| Vec2::ZERO) == 0.0)
            .count()
    };
    assert!(passed(&p) > 0 && passed(&p) == passed(&t), "`interface` is `null`");
    let mean = |s: &Scene| agreement::image_mean(s, "path", "max_depth = 8", 64);
    agreement::assert_agrees("pbrt media", mean(&p), mean(&t));
}

/// pbrt-v4's `normalmap` on a material and `alpha` on shapes: at every floor hit the model's
/// normal is the one pbrt-v4's `NormalMap` makes — the picture read linearly, bilinear with
/// repeat at (u, 1 − v), 2c − 1 normalised in the frame (∂p/∂u, n × ∂p/∂u, n) — computed here
/// from the picture's bytes; a shape's `float alpha` is its material's opacity and a
/// `texture alpha` pbrt's checkerboard of α over (u, v), the material underneath unchanged.
#[test]
fn normal_maps_and_alpha_mean_what_pbrt_says() {
    let dir = tempfile::tempdir().unwrap();
    // A 3 × 2 map of normals tilted every way (odd sizes catch a transposed lookup).
    let texels: [[[u8; 3]; 3]; 2] = [
        [[200, 128, 220], [90, 170, 230], [128, 60, 200]],
        [[40, 128, 210], [160, 200, 190], [128, 128, 255]],
    ];
    agreement::write_png(&dir.path().join("tiles.png"), &texels);
    let pbrt = "LookAt 0 5 3  0 0 0  0 1 0\n\
        Camera \"perspective\" \"float fov\" 60\n\
        Film \"rgb\" \"integer xresolution\" 20 \"integer yresolution\" 16\n\
        WorldBegin\n\
        LightSource \"distant\" \"point3 from\" [0 1 0] \"point3 to\" [0 0 0] \"rgb L\" [2 2 2]\n\
        Texture \"checks\" \"float\" \"checkerboard\" \"float tex1\" 0.25 \"float tex2\" 1 \"float uscale\" 4 \"float vscale\" 4\n\
        Material \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5] \"string normalmap\" \"tiles.png\"\n\
        Shape \"trianglemesh\" \"point3 P\" [-4 0 4  4 0 4  4 0 -4  -4 0 -4] \"integer indices\" [0 1 2 0 2 3]\n\
            \"point2 uv\" [0 0  1.5 0  1.5 2.5  0 2.5]\n\
        Material \"diffuse\" \"rgb reflectance\" [0.8 0.2 0.2]\n\
        AttributeBegin\n\
          Translate 1 0.5 0\n\
          Shape \"sphere\" \"float radius\" 0.5 \"float alpha\" 0.3\n\
        AttributeEnd\n\
        Shape \"trianglemesh\" \"point3 P\" [-2 0 -1  0 0 -1  0 2 -1  -2 2 -1] \"integer indices\" [0 1 2 0 2 3]\n\
            \"point2 uv\" [0 0  1 0  1 1  0 1] \"texture alpha\" \"checks\"\n\
        Shape \"trianglemesh\" \"point3 P\" [2 0 -2  3 0 -2  3 1 -2] \"float alpha\" 1\n\
        AttributeBegin\n\
          AreaLightSource \"diffuse\" \"rgb L\" [50 50 50]\n\
          Shape \"sphere\" \"float radius\" 0.4 \"float alpha\" 0\n\
          Shape \"trianglemesh\" \"point3 P\" [-1 0.1 0  1 0.1 0  0 0.1 1] \"float alpha\" 0\n\
        AttributeEnd\n";
    let scene = load(dir.path(), "mapped.pbrt", pbrt).unwrap();
    // Shapes of α 0 are nothing in pbrt-v4 (no hit, no emission, even as area lights): the
    // sphere at the origin and the triangle over the floor are left out.
    assert!(scene.lights.is_empty(), "no area light: {}", scene.lights.len());
    let channel = |x: i64, y: i64, c: usize| {
        let (w, h) = (3i64, 2i64);
        f32::from(texels[y.rem_euclid(h) as usize][x.rem_euclid(w) as usize][c]) / 255.0
    };
    let pbrt_normal = |uv: Vec2| {
        let (x, y) = (uv.x * 3.0 - 0.5, (1.0 - uv.y) * 2.0 - 0.5);
        let (xi, yi) = (x.floor(), y.floor());
        let (dx, dy) = (x - xi, y - yi);
        let (xi, yi) = (xi as i64, yi as i64);
        let c = |k| {
            (1.0 - dx) * (1.0 - dy) * channel(xi, yi, k)
                + dx * (1.0 - dy) * channel(xi + 1, yi, k)
                + (1.0 - dx) * dy * channel(xi, yi + 1, k)
                + dx * dy * channel(xi + 1, yi + 1, k)
        };
        glam::Vec3::new(2.0 * c(0) - 1.0, 2.0 * c(1) - 1.0, 2.0 * c(2) - 1.0).normalize()
    };
    let (mut floor_hits, mut sheet_hits, mut ball_hits) = (0, 0, 0);
    for y in 0..16 {
        for x in 0..20 {
            let ray = scene.camera.generate_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let Some(hit) = scene.intersect(&ray) else { continue };
            let uv = scene.uv(&hit);
            let material = &scene.materials[hit.material as usize];
            match material.opacity {
                // The floor: ∂p/∂u = (8/1.5) x̂, its normal ŷ.
                None if hit.p.y.abs() < 1e-4 => {
                    floor_hits += 1;
                    let bsdf = scene.bsdf(&hit);
                    let Bsdf::NormalMapped(mapped) = &*bsdf else {
                        panic!("a normal-mapped floor: {bsdf:?}")
                    };
                    let (s, n) = (glam::Vec3::X, glam::Vec3::Y);
                    let local = pbrt_normal(uv);
                    let want = local.x * s + local.y * n.cross(s) + local.z * n;
                    let got = hit.frame.to_world(mapped.normal);
                    assert!((got - want).length() < 2e-4, "uv {uv}: {got} vs pbrt's {want}");
                }
                // The triangle of α = 1 (pbrt's default): opaque, no mask.
                None => assert!((hit.p.z + 2.0).abs() < 1e-4, "an opaque hit at {}", hit.p),
                Some(_) if (hit.p - glam::Vec3::new(1.0, 0.5, 0.0)).length() < 0.5 + 1e-3 => {
                    ball_hits += 1;
                    assert_eq!(material.opacity_at(|| uv), 0.3);
                }
                Some(_) => {
                    sheet_hits += 1;
                    let even = ((4.0 * uv.x).floor() + (4.0 * uv.y).floor()) as i64 % 2 == 0;
                    let want = if even { 0.25 } else { 1.0 };
                    assert!(
                        (material.opacity_at(|| uv) - want).abs() < 1e-6,
                        "uv {uv}: {} vs {want}",
                        material.opacity_at(|| uv)
                    );
                }
            }
            if material.opacity.is_some() {
                let Bsdf::Lambertian(l) = &material.bsdf else {
                    panic!("the masked material is the diffuse one: {:?}", material.bsdf)
                };
                assert!((l.reflectance - glam::Vec3::new(0.8, 0.2, 0.2)).length() < 1e-6);
            }
        }
    }
    assert!(
        floor_hits > 100 && sheet_hits > 3 && ball_hits > 0,
        "{floor_hits} {sheet_hits} {ball_hits}"
    );
    // α = 1 is opaque (pbrt's default): no mask on the last triangle; the two masked shapes
    // share the red material in two masks.
    let masks = scene.materials.iter().filter(|m| m.opacity.is_some()).count();
    assert_eq!(masks, 2);
    // An area light with 0 < α < 1, and α outside [0, 1], are refused naming the line.
    for (shape, expect) in [
        (
            "AreaLightSource \"diffuse\" \"rgb L\" [1 1 1]\nShape \"sphere\" \"float alpha\" 0.5",
            &["line 4", "area light with alpha"][..],
        ),
        (
            "Shape \"sphere\" \"float alpha\" -0.5",
            &["line 3", "alpha", "[0, 1]"][..],
        ),
        (
            "Shape \"sphere\" \"texture alpha\" \"none\"",
            &["line 3", "no float texture named \"none\""][..],
        ),
    ] {
        let text = format!("WorldBegin\nMaterial \"diffuse\"\n{shape}\n");
        let err = load(dir.path(), "bad.pbrt", &text).err().expect("refused").to_string();
        assert_refused(&err, expect);
    }
}

/// pbrt-v4's film bounds: `cropwindow` [x0 x1 y0 y1] (fractions, each pair ordered and
/// clamped) covers pixels ⌈res · min⌉ … ⌈res · max⌉ and wins over `pixelbounds` (pixels,
/// clipped to the film); the field of view stays the whole film's. A `constant` texture is
/// its value everywhere: the floor renders as with the plain colour.
#[test]
fn crop_windows_and_constant_textures_mean_what_pbrt_says() {
    let dir = tempfile::tempdir().unwrap();
    let scene = |film: &str, floor: &str| {
        let text = lit_floor(&format!(
            "LightSource \"point\" \"rgb I\" [3 3 3] \"point3 from\" [0 2 0]\n{floor}\n\
             Shape \"trianglemesh\" \"point3 P\" [-3 0.01 -3  3 0.01 -3  3 0.01 3  -3 0.01 3] \"integer indices\" [0 2 1 0 3 2]"
        ))
        .replace(
            "\"integer xresolution\" 12 \"integer yresolution\" 9",
            &format!("\"integer xresolution\" 64 \"integer yresolution\" 48 {film}"),
        );
        load(dir.path(), "crop.pbrt", &text)
    };
    let plain = "Material \"diffuse\" \"rgb reflectance\" [0.2 0.4 0.6]";
    let full = scene("", plain).unwrap();
    for (film, offset, size) in [
        ("\"float cropwindow\" [0.5 0.2 0.1 0.6]", (13, 5), (19, 24)),
        ("\"integer pixelbounds\" [10 30 4 60]", (10, 4), (20, 44)),
        (
            "\"integer pixelbounds\" [0 8 0 8] \"float cropwindow\" [-0.5 0.25 0.5 1.5]",
            (0, 24),
            (16, 24),
        ),
    ] {
        let crop = scene(film, plain).unwrap();
        assert_eq!((crop.camera.width, crop.camera.height), size, "{film}");
        assert_eq!(
            (crop.camera.film, crop.camera.crop_offset),
            ((64, 48), offset),
            "{film}"
        );
        let within = Vec2::new(3.5, 2.5);
        let (a, b) = (
            full.camera
                .generate_ray(within + Vec2::new(offset.0 as f32, offset.1 as f32)),
            crop.camera.generate_ray(within),
        );
        assert!((a.d - b.d).length() < 1e-6, "{film}: {} vs {}", a.d, b.d);
    }
    for bad in [
        "\"float cropwindow\" [0.5 0.5 0 1]",
        "\"float cropwindow\" [0 1 0]",
        "\"integer pixelbounds\" [70 80 0 10]",
    ] {
        let err = scene(bad, plain).err().expect("refused").to_string();
        assert_refused(&err, &["line 3", "Film"]);
    }
    // A constant texture (spectrum and float) is its value at every point.
    let constant = "Texture \"c\" \"spectrum\" \"constant\" \"rgb value\" [0.2 0.4 0.6]\n\
                    Material \"diffuse\" \"texture reflectance\" \"c\"";
    let (a, b) = (scene("", plain).unwrap(), scene("", constant).unwrap());
    let (ia, ib) = (
        agreement::render_image(&a, "path", "max_depth = 1", 2, 3),
        agreement::render_image(&b, "path", "max_depth = 1", 2, 3),
    );
    for (p, q) in ia.pixels.iter().zip(&ib.pixels) {
        assert!(
            (*p - *q).abs().max_element() <= 1e-6 * p.max_element().max(1.0),
            "{p} vs {q}"
        );
    }
    let sheet = lit_floor(
        "LightSource \"point\" \"rgb I\" [3 3 3] \"point3 from\" [0 2 0]\n\
         Texture \"a\" \"float\" \"constant\" \"float value\" 0.25\n\
         Shape \"trianglemesh\" \"point3 P\" [-1 0 -1  1 0 -1  1 1 -1] \"texture alpha\" \"a\"",
    );
    let masked = load(dir.path(), "sheet.pbrt", &sheet).unwrap();
    let opacities: Vec<f32> = masked
        .materials
        .iter()
        .filter_map(|m| m.opacity.as_ref().map(|_| m.opacity_at(|| Vec2::new(0.3, 0.7))))
        .collect();
    assert_eq!(opacities, [0.25]);
}

/// A float texture as a conductor's or dielectric's roughness: at every hit α is pbrt-v4's
/// √r of the texture's value r there (`remaproughness`, the default), or r itself when the
/// file turns remapping off; a number beside a texture (`vroughness`) is remapped alike.
/// Coated models refuse a textured roughness in one line naming the parameter.
#[test]
fn textured_roughness_means_what_pbrt_says() {
    let dir = tempfile::tempdir().unwrap();
    let scene_with = |material: &str| {
        format!(
            "LookAt 0 5 3  0 0 0  0 1 0\n\
             Camera \"perspective\" \"float fov\" 60\n\
             Film \"rgb\" \"integer xresolution\" 20 \"integer yresolution\" 16\n\
             WorldBegin\n\
             LightSource \"distant\" \"point3 from\" [0 1 0] \"point3 to\" [0 0 0] \"rgb L\" [2 2 2]\n\
             Texture \"checks\" \"float\" \"checkerboard\" \"float tex1\" 0.04 \"float tex2\" 0.36 \"float uscale\" 4 \"float vscale\" 4\n\
             {material}\n\
             Shape \"trianglemesh\" \"point3 P\" [-4 0 4  4 0 4  4 0 -4  -4 0 -4] \"integer indices\" [0 1 2 0 2 3]\n\
                 \"point2 uv\" [0 0  1 0  1 1  0 1]\n"
        )
    };
    // pbrt-v4's checkerboard: tex1 where ⌊4u⌋ + ⌊4v⌋ is even, tex2 where it is odd.
    let checks = |uv: Vec2| {
        if ((uv.x * 4.0).floor() + (uv.y * 4.0).floor()) as i64 % 2 == 0 {
            0.04f32
        } else {
            0.36
        }
    };
    // (material, whether r is remapped, α_v when it is a number rather than the texture's).
    let cases = [
        ("Material \"conductor\" \"texture roughness\" \"checks\"", true, None),
        (
            "Material \"conductor\" \"texture roughness\" \"checks\" \"bool remaproughness\" false",
            false,
            None,
        ),
        (
            "Material \"dielectric\" \"texture uroughness\" \"checks\" \"float vroughness\" 0.09",
            true,
            Some(0.3f32),
        ),
    ];
    for (material, remap, fixed_v) in cases {
        let scene = load(dir.path(), "rough.pbrt", &scene_with(material)).unwrap();
        let mut hits = 0;
        for y in 0..16 {
            for x in 0..20 {
                let ray = scene.camera.generate_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                let Some(hit) = scene.intersect(&ray) else { continue };
                let uv = scene.uv(&hit);
                let d = match &*scene.bsdf(&hit) {
                    Bsdf::RoughConductor(b) => b.distribution,
                    Bsdf::RoughDielectric(b) => b.distribution,
                    other => panic!("{material}: {other:?}"),
                };
                let au = if remap { checks(uv).sqrt() } else { checks(uv) };
                let av = fixed_v.unwrap_or(au);
                assert!(
                    (d.alpha_u - au).abs() < 1e-5 && (d.alpha_v - av).abs() < 1e-5,
                    "{material} at uv {uv}: α = ({}, {}), pbrt ({au}, {av})",
                    d.alpha_u,
                    d.alpha_v
                );
                hits += 1;
            }
        }
        assert!(hits > 100, "{material}: {hits} hits");
    }
    let err = load(
        dir.path(),
        "coated.pbrt",
        &scene_with("Material \"coateddiffuse\" \"texture roughness\" \"checks\""),
    )
    .err()
    .expect("refused")
    .to_string();
    assert!(
        err.contains("texture roughness") && err.contains("conductor and dielectric only"),
        "{err}"
    );
}
