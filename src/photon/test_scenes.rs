//! Small scenes built in code for the photon tests, and an analytic irradiance.

use crate::bsdf::{Bsdf, Lambertian};
use crate::camera::Camera;
use crate::geometry::Primitive;
use crate::light::Emission;
use crate::scene::{Material, PrimAttrs, Scene};
use glam::Vec3;

/// Collects materials and primitives, then assembles a [`Scene`].
pub struct SceneBuilder {
    materials: Vec<Material>,
    prims: Vec<Primitive>,
    attrs: Vec<PrimAttrs>,
}

impl SceneBuilder {
    pub fn new() -> Self {
        Self {
            materials: Vec::new(),
            prims: Vec::new(),
            attrs: Vec::new(),
        }
    }

    pub fn material(&mut self, bsdf: Bsdf) -> u32 {
        self.materials
            .push(Material::new(format!("m{}", self.materials.len()), bsdf));
        self.materials.len() as u32 - 1
    }

    pub fn lambertian(&mut self, reflectance: Vec3) -> u32 {
        self.material(Bsdf::Lambertian(Lambertian { reflectance }))
    }

    /// The parallelogram corner + s·eu + t·ev (two triangles), front side eu × ev; emitting
    /// `le` from the front when given.
    pub fn quad(&mut self, corner: Vec3, eu: Vec3, ev: Vec3, material: u32, le: Option<Vec3>) {
        let (a, b, c, d) = (corner, corner + eu, corner + eu + ev, corner + ev);
        for tri in [[a, b, c], [a, c, d]] {
            self.prims.push(Primitive::Triangle(tri));
            self.attrs.push(PrimAttrs {
                emission: le.map(|le| Emission { le, two_sided: false }),
                ..PrimAttrs::new(material)
            });
        }
    }

    pub fn sphere(&mut self, center: Vec3, radius: f32, material: u32) {
        self.prims.push(Primitive::Sphere { center, radius });
        self.attrs.push(PrimAttrs::new(material));
    }

    /// A sphere emitting `emission` from its surface.
    pub fn sphere_light(&mut self, center: Vec3, radius: f32, material: u32, emission: Emission) {
        self.prims.push(Primitive::Sphere { center, radius });
        self.attrs.push(PrimAttrs {
            emission: Some(emission),
            ..PrimAttrs::new(material)
        });
    }

    /// The closed unit cube [0, 1]³ seen from inside: floor, four walls and a ceiling that
    /// emits `le` downward; every face uses `material`.
    pub fn closed_box(&mut self, material: u32, le: Vec3) {
        let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
        self.quad(Vec3::ZERO, z, x, material, None); // floor, +y
        self.quad(y, x, z, material, Some(le)); // ceiling, −y
        self.quad(Vec3::ZERO, y, z, material, None); // x = 0, +x
        self.quad(x, z, y, material, None); // x = 1, −x
        self.quad(Vec3::ZERO, x, y, material, None); // z = 0, +z
        self.quad(z, y, x, material, None); // z = 1, −z
    }

    pub fn build(self) -> Scene {
        self.build_with(Camera::new(
            Vec3::new(0.5, 0.5, -1.0),
            Vec3::splat(0.5),
            Vec3::Y,
            60.0,
            8,
            8,
        ))
    }

    /// The scene, seen through `camera`.
    pub fn build_with(self, camera: Camera) -> Scene {
        Scene::assemble(
            "photon-test".into(),
            "photon-test".into(),
            "0".into(),
            camera,
            self.materials,
            self.prims,
            self.attrs,
            Vec::new(),
        )
        .expect("test scenes have a light")
    }
}

/// A closed unit box whose six faces all emit `le` inward and reflect with albedo `rho`, seen
/// from inside: the radiance leaving every point is exactly Le / (1 − ρ). The 30° camera sees
/// only the far wall, at least 0.25 from its edges, so every photon disc lies inside one face.
pub fn emitting_box(rho: f32, mirror_sphere: bool) -> Scene {
    let mut b = SceneBuilder::new();
    let m = b.lambertian(Vec3::splat(rho));
    let le = Some(Vec3::ONE);
    let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
    b.quad(Vec3::ZERO, z, x, m, le);
    b.quad(y, x, z, m, le);
    b.quad(Vec3::ZERO, y, z, m, le);
    b.quad(x, z, y, m, le);
    b.quad(Vec3::ZERO, x, y, m, le);
    b.quad(z, y, x, m, le);
    if mirror_sphere {
        // A perfect mirror in the field of view: eye paths pass it by sampling, and in a
        // furnace it changes nothing (it reflects all it receives). (A Phong lobe would not do:
        // its energy below the horizon is lost.)
        let g = b.material(Bsdf::Mirror(crate::bsdf::Mirror { reflectance: Vec3::ONE }));
        b.sphere(Vec3::new(0.5, 0.5, 0.7), 0.08, g);
    }
    let camera = Camera::new(
        Vec3::new(0.5, 0.5, 0.05),
        Vec3::new(0.5, 0.5, 1.0),
        Vec3::Y,
        30.0,
        16,
        16,
    );
    b.build_with(camera)
}

/// Exact irradiance at `x` (unit normal `n`) from a planar polygon of constant radiance `le`
/// facing `x` and entirely above its horizon (Lambert's formula, see Arvo 1995, "Applications
/// of Irradiance Tensors"): E = Le/2 · |Σ_i Θ_i n · (v_i × v_{i+1}) / |v_i × v_{i+1}||, with v_i
/// the unit vectors to the vertices and Θ_i the angle between consecutive ones.
pub fn polygon_irradiance(poly: &[Vec3], le: Vec3, x: Vec3, n: Vec3) -> Vec3 {
    let v: Vec<glam::DVec3> = poly.iter().map(|p| (*p - x).as_dvec3().normalize()).collect();
    let n = n.as_dvec3();
    let mut sum = 0.0f64;
    for i in 0..v.len() {
        let (a, b) = (v[i], v[(i + 1) % v.len()]);
        let theta = a.dot(b).clamp(-1.0, 1.0).acos();
        sum += theta * n.dot(a.cross(b).normalize());
    }
    le * (0.5 * sum.abs()) as f32
}
