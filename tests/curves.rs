//! Linear curves (TOML `type = "linear_curve"`, Mitsuba's `linearcurve`): the tessellated tube
//! against the analytic union of spheres and touching cones, Mitsuba's texture coordinates on
//! it, every strategy agreeing on a scene with curves, the Mitsuba element read and written,
//! bad input refused.

mod agreement;

use agreement::{assert_light_starting_strategies_agree, assert_refused, floor_under, load_text as load};
use glam::{DVec2, DVec3, Vec3};
use photon_bench::geometry::Ray;
use photon_bench::sampling::Rng;

/// Two curves: a bent one whose radius changes along it, and a straight one.
const CURVES: &str =
    "-0.8 0.3 0 0.1\n-0.2 0.6 0.3 0.1\n0.4 0.3 -0.2 0.15\n0.8 0.5 0.1 0.06\n\n0.5 0.2 0.6 0.05\n-0.5 0.25 0.6 0.05\n";

/// The curves under a transform that stretches and turns their points (not their radii).
const SHAPE: &str = "[[shapes]]\ntype = \"linear_curve\"\nmaterial = \"checks\"\nfile = \"zig.txt\"\n\
    transform = [{ scale = [1.2, 1, 0.8] }, { rotate_y = 30 }]\n\n\
    [materials.checks]\ntype = \"diffuse\"\nreflectance = { type = \"checkerboard\", color0 = [0.8, 0.8, 0.8], color1 = [0.2, 0.3, 0.6] }\n";

const LIGHT: &str = "type = \"point\"\nposition = [0.3, 2, 0.4]\nintensity = [4, 4, 4]";

fn scene_text() -> String {
    floor_under(LIGHT) + "\n" + SHAPE
}

/// The control points in the world (the scene's transform applied by hand), per curve.
fn world_curves() -> Vec<Vec<(DVec3, f64)>> {
    let (s, c) = 30f64.to_radians().sin_cos();
    CURVES
        .split("\n\n")
        .map(|curve| {
            curve
                .lines()
                .map(|l| {
                    let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
                    let p = DVec3::new(1.2 * v[0], v[1], 0.8 * v[2]);
                    // A turn of 30° about +y.
                    (DVec3::new(c * p.x + s * p.z, p.y, -s * p.x + c * p.z), v[3])
                })
                .collect()
        })
        .collect()
}

/// One segment's profile in its half-plane: axial y from a, radial x.
struct Segment {
    a: DVec3,
    axis: DVec3,
    length: f64,
    r: (f64, f64),
    sin: f64,
    cos: f64,
}

impl Segment {
    fn new((a, ra): (DVec3, f64), (b, rb): (DVec3, f64)) -> Self {
        let length = (b - a).length();
        let sin = (ra - rb) / length;
        Self {
            a,
            axis: (b - a) / length,
            length,
            r: (ra, rb),
            sin,
            cos: (1.0 - sin * sin).sqrt(),
        }
    }

    /// (y, x) of `p`.
    fn profile(&self, p: DVec3) -> DVec2 {
        let d = p - self.a;
        let y = d.dot(self.axis);
        DVec2::new(y, (d - y * self.axis).length())
    }

    /// Signed distance of `p` to the convex hull of the two spheres: nearest the start sphere
    /// where p projects before the start's circle of contact on the touching line, nearest the
    /// end sphere past the end's, nearest the touching line between.
    fn distance(&self, p: DVec3) -> f64 {
        let q = self.profile(p);
        let n = DVec2::new(self.sin, self.cos);
        let t = DVec2::new(self.cos, -self.sin);
        let s = (q - self.r.0 * n).dot(t);
        if s < 0.0 {
            q.length() - self.r.0
        } else if s > self.length * self.cos {
            (q - DVec2::new(self.length, 0.0)).length() - self.r.1
        } else {
            q.dot(n) - self.r.0
        }
    }

    /// The axis parameter t of a point on the cone (module doc of `curves.rs`): r(t) = x / cos α,
    /// y = t L + r(t) sin α.
    fn cone_t(&self, p: DVec3) -> f64 {
        let q = self.profile(p);
        (q.x - q.y * self.sin / self.cos) / self.length
    }
}

fn segments() -> Vec<Segment> {
    world_curves()
        .iter()
        .flat_map(|c| c.windows(2).map(|w| Segment::new(w[0], w[1])).collect::<Vec<_>>())
        .collect()
}

/// The scene of two curves (its directory kept alive) and the index of the curves' material.
fn curve_scene() -> (tempfile::TempDir, photon_bench::scene::Scene, u32) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("zig.txt"), CURVES).unwrap();
    let scene = load(dir.path(), "curves.toml", &scene_text()).unwrap();
    let curve = curve_material(&scene);
    (dir, scene, curve)
}

/// The index of the curves' material.
fn curve_material(scene: &photon_bench::scene::Scene) -> u32 {
    scene.materials.iter().position(|m| m.name == "checks").unwrap() as u32
}

fn union_distance(segments: &[Segment], p: DVec3) -> f64 {
    segments.iter().map(|s| s.distance(p)).fold(f64::INFINITY, f64::min)
}

/// Rays aimed at the curves from all around: every hit on the curve lies on the union's
/// surface (within 2·10⁻⁴ of the largest radius: chords around and along a cap each fall
/// 7.5·10⁻⁵ r short) with the union's normal, nothing of the ray
/// before it is inside the union, and a ray that misses never passes inside it.
#[test]
fn the_tube_is_the_union_of_spheres_and_touching_cones() {
    let (_dir, scene, curve) = curve_scene();
    let segs = segments();
    let curve_points: Vec<DVec3> = world_curves().concat().iter().map(|c| c.0).collect();
    let mut rng = Rng::for_task(3, [0, 0, 0]);
    let (mut hits, mut misses) = (0, 0);
    for _ in 0..20_000 {
        // A point near the curves, seen from a random point 2 away.
        let k = (rng.uniform() * (curve_points.len() - 1) as f32) as usize;
        let target = curve_points[k].lerp(curve_points[k + 1], f64::from(rng.uniform()))
            + 0.2 * (rng.uniform2().extend(rng.uniform()).as_dvec3() - DVec3::splat(0.5));
        let from = target + 2.0 * photon_bench::sampling::sample_uniform_sphere(rng.uniform2()).as_dvec3();
        if from.y < 0.05 {
            continue;
        }
        let d = (target - from).normalize();
        let hit = scene.intersect(&Ray::new(from.as_vec3(), d.as_vec3()));
        let t_end = match &hit {
            Some(h) if h.material == curve => {
                let p = h.p.as_dvec3();
                let f = union_distance(&segs, p);
                assert!(f.abs() < 2e-4 * 0.15, "hit {p} at distance {f} from the union");
                // The normal: the union's gradient, by central differences.
                let e = 1e-6;
                let g = DVec3::new(
                    union_distance(&segs, p + DVec3::X * e) - union_distance(&segs, p - DVec3::X * e),
                    union_distance(&segs, p + DVec3::Y * e) - union_distance(&segs, p - DVec3::Y * e),
                    union_distance(&segs, p + DVec3::Z * e) - union_distance(&segs, p - DVec3::Z * e),
                )
                .normalize();
                assert!(
                    g.dot(h.frame.n.as_dvec3()).abs() > 0.999,
                    "normal {} vs the union's {g} at {p}",
                    h.frame.n
                );
                hits += 1;
                f64::from(h.t)
            }
            _ => {
                misses += 1;
                4.0
            }
        };
        for i in 0..400 {
            let t = t_end * (f64::from(i) + 0.5) / 400.0;
            if t < t_end - 1e-3 {
                assert!(
                    union_distance(&segs, from + d * t) > -1e-4,
                    "the ray passes inside at t = {t}"
                );
            }
        }
    }
    assert!(hits > 2000 && misses > 2000, "{hits} hits, {misses} misses");
}

/// The texture coordinates on the cones are Mitsuba's: v = (t + k) / N for segment k of N,
/// u = atan2(r̂ · e_rot, r̂ · e_rad) / 2π with e_rot the +z guide made perpendicular to the
/// axis and e_rad = e_rot × axis (checked away from the seam and the joints).
#[test]
fn texture_coordinates_are_mitsubas() {
    let (_dir, scene, curve) = curve_scene();
    let segs = segments();
    let n = segs.len() as f64;
    let mut rng = Rng::for_task(5, [0, 0, 0]);
    let mut checked = 0;
    for _ in 0..20_000 {
        let k = (rng.uniform() * segs.len() as f32) as usize;
        let s = &segs[k];
        let target = s.a + s.axis * s.length * f64::from(rng.uniform());
        let from = target + 2.0 * photon_bench::sampling::sample_uniform_sphere(rng.uniform2()).as_dvec3();
        let Some(hit) = scene.intersect(&Ray::new(from.as_vec3(), (target - from).normalize().as_vec3())) else {
            continue;
        };
        let p = hit.p.as_dvec3();
        // Only hits clearly on this segment's cone, away from every other segment.
        let on_cone = s.distance(p).abs() < 1e-4 && {
            let t = s.cone_t(p);
            (0.03..0.97).contains(&t)
        };
        let alone = segs.iter().enumerate().all(|(j, o)| j == k || o.distance(p) > 0.01);
        if hit.material != curve || !on_cone || !alone {
            continue;
        }
        let t = s.cone_t(p);
        let e_rot = (DVec3::Z - s.axis * s.axis.z).normalize();
        let e_rad = e_rot.cross(s.axis);
        let q = p - s.a;
        let radial = (q - q.dot(s.axis) * s.axis).normalize();
        let u = radial
            .dot(e_rot)
            .atan2(radial.dot(e_rad))
            .rem_euclid(std::f64::consts::TAU)
            / std::f64::consts::TAU;
        if !(0.01..0.99).contains(&u) {
            continue;
        }
        let uv = scene.tex_point(&hit).uv.as_dvec2();
        let want = DVec2::new(u, (t + k as f64) / n);
        assert!((uv - want).abs().max_element() < 2e-3, "segment {k}: {uv} vs {want}");
        checked += 1;
    }
    assert!(checked > 1000, "{checked}");
}

/// A room with linear and B-spline curves (whose open ends let rays into and out of them
/// through their culled back faces): the strategies that start paths on lights agree with
/// `path`.
#[test]
fn strategies_agree_on_curves() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("zig.txt"), CURVES).unwrap();
    std::fs::write(dir.path().join("spline.txt"), CURVES.split("\n\n").next().unwrap()).unwrap();
    let text = scene_text().replace("resolution = [24, 24]", "resolution = [12, 12]")
        + "\n[[shapes]]\ntype = \"bspline_curve\"\nmaterial = \"checks\"\nfile = \"spline.txt\"\n\
           transform = { translate = [0, 0.4, 0.3] }\n";
    let scene = load(dir.path(), "room.toml", &text).unwrap();
    assert_light_starting_strategies_agree(&scene);
}

/// The exporter writes Mitsuba's `linearcurve` with the file and the transform, which loads
/// back as the same triangles; Mitsuba's element is read with its `to_world`; bad curves are
/// refused in one line naming the file and the line.
#[test]
fn curves_are_read_written_and_checked() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("zig.txt"), CURVES).unwrap();
    let toml = dir.path().join("c.toml");
    std::fs::write(&toml, scene_text()).unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    let xml = out.join("c.xml");
    photon_bench::scene::export::export_file(&toml, &xml).unwrap();
    let text = std::fs::read_to_string(&xml).unwrap();
    assert!(text.contains(r#"<shape type="linearcurve">"#), "{text}");
    let (a, _) = photon_bench::scene::load::load_scene_with_stats(&toml).unwrap();
    let (b, _) = photon_bench::scene::load::load_scene_with_stats(&xml).unwrap();
    assert_eq!(a.primitives.len(), b.primitives.len());
    let c = &world_curves()[0];
    let aim = (0.5 * (c[0].0 + c[1].0)).as_vec3();
    let probe = Ray::new(
        aim + Vec3::new(0.1, 2.0, 0.05),
        (-Vec3::new(0.1, 2.0, 0.05)).normalize(),
    );
    let (ha, hb) = (a.intersect(&probe).unwrap(), b.intersect(&probe).unwrap());
    assert!(
        (ha.t - hb.t).abs() < 1e-5 && ha.material == curve_material(&a),
        "{} vs {}",
        ha.t,
        hb.t
    );

    let refused = |curves: &str, expect: &[&str]| {
        std::fs::write(dir.path().join("zig.txt"), curves).unwrap();
        let e = load(dir.path(), "bad.toml", &scene_text())
            .err()
            .expect("refused")
            .to_string();
        assert_refused(&e, expect);
    };
    refused("0 0 0 0.1\n1 0 0\n", &["shapes[1].file", "zig.txt", "line 2"]);
    refused("0 0 0 0.1\n", &["shapes[1].file", "1 control point(s)", "at least 2"]);
    refused("0 0 0 0.5\n0.1 0 0 0.1\n", &["shapes[1].file", "holds the other"]);
    refused("0 0 0 0.1\n1 0 0 -1\n", &["shapes[1].file", "positive radius"]);
    std::fs::remove_file(dir.path().join("zig.txt")).unwrap();
    let e = load(dir.path(), "bad.toml", &scene_text()).err().unwrap().to_string();
    assert_refused(&e, &["shapes[1].file", "zig.txt"]);
}

/// A straight B-spline tube (control points −1.5, −0.5, 0.5, 1.5 on the x axis, radius 0.2):
/// its one segment runs from x = −0.5 to 0.5 (the uniform cubic B-spline starts at
/// (P₀ + 4P₁ + P₂)/6), rays from above meet it at distance 5 − 0.2 with v = x + ½ and u = 0 (the
/// top, e_rad = e_rot × x̂ = +y with e_rot = +z), nothing beyond its ends, and rays along its
/// axis pass through its open ends and its inside (Embree culls curves' back faces; Mitsuba
/// 3.9.1's `ray_intersect` on this curve gives exactly these hits and misses).
#[test]
fn bspline_tubes_are_open_and_parameterized_as_mitsubas() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("line.txt"),
        "-1.5 0 0 0.2\n-0.5 0 0 0.2\n0.5 0 0 0.2\n1.5 0 0 0.2\n",
    )
    .unwrap();
    let text = floor_under(LIGHT)
        + "\n[[shapes]]\ntype = \"bspline_curve\"\nmaterial = \"checks\"\nfile = \"line.txt\"\ntransform = { translate = [0, 1, 0] }\n\n\
           [materials.checks]\ntype = \"diffuse\"\nreflectance = { type = \"checkerboard\" }\n";
    let scene = load(dir.path(), "line.toml", &text).unwrap();
    let curve = curve_material(&scene);
    for x in [-0.49f32, -0.3, 0.0, 0.2, 0.49] {
        let hit = scene.intersect(&Ray::new(Vec3::new(x, 6.0, 0.0), -Vec3::Y)).unwrap();
        assert_eq!(hit.material, curve, "x = {x}");
        assert!((hit.t - 4.8).abs() < 1e-4, "x = {x}: t = {}", hit.t);
        let uv = scene.tex_point(&hit).uv;
        assert!((uv.y - (x + 0.5)).abs() < 2e-3, "x = {x}: v = {}", uv.y);
        assert!(uv.x.min(1.0 - uv.x) < 2e-3, "x = {x}: u = {}", uv.x);
        assert!((hit.frame.n - Vec3::Y).length() < 1e-3);
    }
    for x in [-0.55f32, 0.55] {
        let hit = scene.intersect(&Ray::new(Vec3::new(x, 6.0, 0.0), -Vec3::Y)).unwrap();
        assert_ne!(hit.material, curve, "x = {x}: beyond the segment's end");
    }
    // Into the open end at a slant, to meet the inside wall from its back, and out of the
    // inside through the wall: nothing there.
    for (from, to) in [
        (Vec3::new(-5.0, 2.0, 0.0), Vec3::new(0.0, 0.9, 0.0)),
        (Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.3, 1.5, 0.1)),
        (Vec3::new(0.0, 1.05, 0.05), Vec3::new(-0.2, 0.0, -0.3)),
    ] {
        let hit = scene.intersect(&Ray::new(from, (to - from).normalize()));
        assert!(
            hit.is_none_or(|h| h.material != curve),
            "from {from} toward {to}: {hit:?}"
        );
    }
}
