//! Mesh attributes (TOML `type = "mesh_attribute"`, Mitsuba's `mesh_attribute`): a PLY mesh's
//! vertex and face values read as Mitsuba 3.9.1 reads them, against closed forms under a sun;
//! every strategy rendering a vertex-coloured room as `path` does; Mitsuba's element read and
//! exported; bad input refused in one line.

mod agreement;

use agreement::{
    assert_light_starting_strategies_agree, assert_refused, floor_under, load_text as load, render_image as render,
};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;
use std::path::Path;

/// The reflectance every vertex of the floor carries: linear in (x, z), so that interpolating
/// it over either triangle gives this function everywhere.
fn rho(x: f32, z: f32) -> Vec3 {
    Vec3::new(0.5 + 0.1 * x, 0.5 - 0.1 * z, 0.3 + 0.04 * (x + z))
}

/// A 6 × 6 floor at y = 0 as a PLY file of two triangles with vertex normals +y: the first
/// wound counter-clockwise seen from above, the second clockwise, so that the loader turns it
/// around (its vertices 1 and 2 swapped) and its attributes must follow. Vertex colours as
/// `color_0..2` (`vertex_color`), face colours as `r g b` (`face_color`).
fn floor_ply(dir: &Path) {
    let corners = [(-3.0f32, -3.0f32), (3.0, -3.0), (3.0, 3.0), (-3.0, 3.0)];
    let mut ply = String::from(
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\nproperty float color_0\nproperty float color_1\n\
         property float color_2\nelement face 2\nproperty list uchar int vertex_indices\nproperty float r\n\
         property float g\nproperty float b\nend_header\n",
    );
    for (x, z) in corners {
        let c = rho(x, z);
        ply += &format!("{x} 0 {z} 0 1 0 {} {} {}\n", c.x, c.y, c.z);
    }
    ply += "3 0 2 1 0.2 0.4 0.6\n3 0 2 3 0.7 0.5 0.1\n";
    std::fs::write(dir.join("floor.ply"), ply).unwrap();
}

/// The floor of [`floor_under`] (under a sun straight down, E = 2) replaced by the PLY floor
/// with `texture` (a TOML texture table) as its reflectance.
fn floor_scene(texture: &str) -> String {
    floor_under("type = \"directional\"\ndirection = [0, -1, 0]\nirradiance = [2, 2, 2]")
        .replace("reflectance = [0.5, 0.5, 0.5]", &format!("reflectance = {texture}"))
        .replace(
            "type = \"quad\"\nmaterial = \"grey\"\ncenter = [0, 0, 0]\nsize = [6, 6]\nfacing = \"+y\"",
            "type = \"mesh\"\nmaterial = \"grey\"\nfile = \"floor.ply\"",
        )
}

/// Where each pixel's centre sees the floor, in pixel order.
fn floor_points(scene: &photon_bench::scene::Scene) -> Vec<(f32, f32)> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let ray = scene.camera.generate_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let p = ray.o + ray.d * (-ray.o.y / ray.d.y);
            (p.x, p.z)
        })
        .collect()
}

/// Asserts that `pixels` show the linear field `f` of the floor: each pixel within the field's
/// range over its footprint (its samples fall anywhere in it), and the pixels' mean error zero
/// within 10⁻⁴ (a uniform sample's expectation of a linear field is the field at the footprint's
/// centre: the floor maps affinely to the image, the camera looking straight down).
fn assert_linear_field(scene: &photon_bench::scene::Scene, pixels: &[Vec3], f: impl Fn(f32, f32) -> Vec3) {
    let points = floor_points(scene);
    let half = (points[1].0 - points[0].0).abs() / 2.0;
    let mut sum = Vec3::ZERO;
    for (p, &(x, z)) in pixels.iter().zip(&points) {
        let want = f(x, z);
        let corners = [(-half, -half), (half, -half), (-half, half), (half, half)].map(|(dx, dz)| f(x + dx, z + dz));
        let (lo, hi) = (
            corners.iter().fold(Vec3::INFINITY, |m, c| m.min(*c)),
            corners.iter().fold(Vec3::NEG_INFINITY, |m, c| m.max(*c)),
        );
        assert!(
            p.cmpge(lo - 1e-5).all() && p.cmple(hi + 1e-5).all(),
            "at ({x}, {z}): {p} outside [{lo}, {hi}]"
        );
        sum += *p - want;
    }
    let mean = sum / pixels.len() as f32;
    assert!(mean.abs().max_element() < 1e-4, "mean error {mean}");
}

/// Under a sun along the normal a diffuse floor reflects ρ/π · E with ρ the attribute there:
/// vertex colours interpolated with the barycentrics (a linear field stays that field over both
/// triangles, the turned one included — swapping its corners' values would change it), face
/// colours constant over each triangle.
#[test]
fn vertex_and_face_attributes_shade_a_floor_as_mitsuba_interpolates_them() {
    let dir = tempfile::tempdir().unwrap();
    floor_ply(dir.path());
    let e = 2.0 * FRAC_1_PI;
    // As it is, and scaled as Mitsuba's `scale`.
    for (texture, k) in [
        (r#"{ type = "mesh_attribute", name = "vertex_color" }"#, 1.0),
        (
            r#"{ type = "mesh_attribute", name = "vertex_color", scale = 0.5 }"#,
            0.5,
        ),
    ] {
        let scene = load(dir.path(), "v.toml", &floor_scene(texture)).unwrap();
        let img = render(&scene, "path", "max_depth = 1", 4, 1);
        assert_linear_field(&scene, &img.pixels, |x, z| k * rho(x, z) * e);
    }
    // Faces: the first triangle (x > z side) is (0.2, 0.4, 0.6), the second (0.7, 0.5, 0.1);
    // pixels whose footprint straddles the diagonal are skipped.
    let scene = load(
        dir.path(),
        "f.toml",
        &floor_scene(r#"{ type = "mesh_attribute", name = "face_color" }"#),
    )
    .unwrap();
    let img = render(&scene, "path", "max_depth = 1", 4, 1);
    let mut checked = 0;
    for (p, (x, z)) in img.pixels.iter().zip(floor_points(&scene)) {
        if (x - z).abs() < 0.3 {
            continue;
        }
        let c = if x > z {
            Vec3::new(0.2, 0.4, 0.6)
        } else {
            Vec3::new(0.7, 0.5, 0.1)
        };
        assert!(
            (*p - c * e).abs().max_element() < 2e-5,
            "at ({x}, {z}): {p} vs {}",
            c * e
        );
        checked += 1;
    }
    assert!(checked > 400, "{checked}");
}

/// A room whose floor is the vertex-coloured mesh: the unbiased strategies agree with `path`.
#[test]
fn strategies_agree_on_a_vertex_coloured_floor() {
    let dir = tempfile::tempdir().unwrap();
    floor_ply(dir.path());
    let text = floor_scene(r#"{ type = "mesh_attribute", name = "vertex_color" }"#)
        .replace("resolution = [24, 24]", "resolution = [12, 12]")
        .replace(
            "[[lights]]\ntype = \"directional\"\ndirection = [0, -1, 0]\nirradiance = [2, 2, 2]",
            "[[shapes]]\ntype = \"sphere\"\nmaterial = \"white\"\ncenter = [0.5, 0.4, 0.3]\nradius = 0.3\n\n\
             [[shapes]]\ntype = \"quad\"\nmaterial = \"white\"\ncenter = [2, 2, 0]\nsize = [1, 1]\nfacing = \"-y\"\n\
             emission = { radiance = [6, 6, 6] }\n\n[materials.white]\ntype = \"diffuse\"\nreflectance = [0.7, 0.7, 0.7]",
        );
    let scene = load(dir.path(), "room.toml", &text).unwrap();
    assert_light_starting_strategies_agree(&scene);
}

/// Mitsuba's `mesh_attribute` in a `diffuse` on a `ply` shape reads as the TOML texture; the
/// exporter writes it back as Mitsuba's element.
#[test]
fn mitsubas_mesh_attribute_is_read_and_exported() {
    let dir = tempfile::tempdir().unwrap();
    floor_ply(dir.path());
    let xml = r#"<scene version="3.0.0">
    <sensor type="perspective"><float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 3, 0" target="0, 0, 0" up="0, 0, -1"/></transform>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/>
            <rfilter type="box"/></film></sensor>
    <emitter type="directional"><vector name="direction" x="0" y="-1" z="0"/><rgb name="irradiance" value="2"/></emitter>
    <shape type="ply"><string name="filename" value="floor.ply"/>
        <bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance">
            <string name="name" value="vertex_color"/></texture></bsdf></shape>
</scene>"#;
    let scene = load(dir.path(), "floor.xml", xml).unwrap();
    let img = render(&scene, "path", "max_depth = 1", 16, 1);
    assert_linear_field(&scene, &img.pixels, |x, z| rho(x, z) * 2.0 * FRAC_1_PI);
    let toml = dir.path().join("floor.toml");
    std::fs::write(
        &toml,
        floor_scene(r#"{ type = "mesh_attribute", name = "vertex_color", scale = 0.5 }"#),
    )
    .unwrap();
    let out = dir.path().join("exported.xml");
    photon_bench::scene::export::export_file(&toml, &out).unwrap();
    let written = std::fs::read_to_string(&out).unwrap();
    assert!(
        written.contains(r#"<texture type="mesh_attribute" name="reflectance">"#),
        "{written}"
    );
    assert!(
        written.contains(r#"<string name="name" value="vertex_color"/>"#),
        "{written}"
    );
    assert!(written.contains(r#"<float name="scale" value="0.5"/>"#), "{written}");
}

/// One line, naming the field, for a mesh attribute a shape lacks, a name without Mitsuba's
/// prefix, values outside a reflectance's range, and a mesh attribute where only (u, v)
/// textures are read.
#[test]
fn bad_mesh_attributes_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    floor_ply(dir.path());
    let refused = |texture: &str| refusal(load(dir.path(), "bad.toml", &floor_scene(texture)));
    assert_refused(
        &refused(r#"{ type = "mesh_attribute", name = "vertex_weight" }"#),
        &["materials.grey.reflectance.name", "shapes[0]", "\"vertex_weight\""],
    );
    assert_refused(
        &refused(r#"{ type = "mesh_attribute", name = "color" }"#),
        &["materials.grey.reflectance.name", "\"vertex_\" or \"face_\""],
    );
    assert_refused(
        &refused(r#"{ type = "mesh_attribute", name = "vertex_color", scale = 3 }"#),
        &["materials.grey.reflectance", "[0, 1]"],
    );
    // A quad has no attributes.
    let quad = floor_under("type = \"directional\"\ndirection = [0, -1, 0]\nirradiance = [2, 2, 2]").replace(
        "reflectance = [0.5, 0.5, 0.5]",
        r#"reflectance = { type = "mesh_attribute", name = "face_color" }"#,
    );
    let err = refusal(load(dir.path(), "quad.toml", &quad));
    assert_refused(
        &err,
        &["materials.grey.reflectance.name", "shapes[0]", "\"face_color\""],
    );
    // As a mask's opacity: (u, v) textures only.
    let mask = floor_scene("[0.5, 0.5, 0.5]").replace(
        "[materials.grey]\ntype = \"diffuse\"",
        "[materials.grey]\ntype = \"mask\"\nopacity = { type = \"mesh_attribute\", name = \"vertex_color\" }\n\
         bsdf = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }\n[materials.unused]\ntype = \"diffuse\"",
    );
    let err = refusal(load(dir.path(), "mask.toml", &mask));
    assert_refused(
        &err,
        &["materials.grey.opacity", "colour (reflectance) parameters only"],
    );
}

/// The message of a scene that must not load.
fn refusal(loaded: photon_bench::error::Result<photon_bench::scene::Scene>) -> String {
    match loaded {
        Ok(_) => panic!("the scene loaded"),
        Err(e) => e.to_string(),
    }
}
