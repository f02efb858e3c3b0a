//! Light selection at one receiver for next-event estimation: ∝ power (one table for the
//! scene) or ∝ a local estimate of each light's unoccluded contribution, and the selection
//! probability the MIS weight of a BSDF-sampled hit on a light needs.

use super::Scene;
use crate::color::luminance;
use crate::geometry::Primitive;
use crate::light::sphere_cone::one_minus_cos_max;
use crate::light::{
    AreaLight, LOCAL_SELECTION_MAX_LIGHTS, LightSample, LightSampling, LightSelection, PointPdf, Receiver,
    SphereSampling, sample_sphere_cone, sphere_cone_pdf,
};
use glam::{Vec2, Vec3};
use std::f32::consts::TAU;

/// Upper bound of the receiver's cosine over a cone of directions (axis `axis`, half-angle
/// θh given by its cosine and sine): cos(max(0, θn − θh)) with θn the angle between `n` and
/// the axis, or of |cos| when `two_sided`. Returns ≤ 0 when the whole cone lies below the
/// horizon of `n`.
#[inline]
fn cosine_bound(n: Vec3, two_sided: bool, axis: Vec3, cos_h: f32, sin_h: f32) -> f32 {
    let mut cos_n = n.dot(axis).clamp(-1.0, 1.0);
    if two_sided {
        cos_n = cos_n.abs();
    }
    if cos_n >= cos_h || cos_h <= 0.0 {
        // The normal lies inside the cone, or the cone spans a hemisphere or more.
        return 1.0;
    }
    let sin_n = (1.0 - cos_n * cos_n).max(0.0).sqrt();
    cos_n * cos_h + sin_n * sin_h
}

/// Solid angle of triangle (a, b, c) seen from `x` [Van Oosterom & Strackee 1983, "The Solid
/// Angle of a Plane Triangle", IEEE Trans. Biomed. Eng. 30(2)]: tan(Ω/2) =
/// |a·(b×c)| / (|a||b||c| + (a·b)|c| + (a·c)|b| + (b·c)|a|) with a, b, c taken from x. The
/// triple product is computed from the edges, (b − a)×(c − a)·(a − x), which keeps its
/// precision when the triangle is small and far.
#[inline]
fn triangle_solid_angle([v0, v1, v2]: [Vec3; 3], x: Vec3) -> f32 {
    let (a, b, c) = (v0 - x, v1 - x, v2 - x);
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let num = (v1 - v0).cross(v2 - v0).dot(a).abs();
    let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * num.atan2(den)
}

/// Light i's weight for [`LightSelection::Local`] at `r`: Y(Le) · Ω(x) · c̄(x), the luminance of
/// its radiance times the solid angle it subtends times an upper bound of the receiver's cosine
/// over its directions (a bounding cone: exact for a sphere; for a triangle, the cone around
/// the direction to its centroid through its farthest vertex). Zero exactly when the light
/// cannot contribute: a one-sided emitter whose emitting side faces away from x, a one-sided
/// sphere seen from inside, or a light entirely below the horizon of a reflect-only receiver.
pub fn local_weight(light: &AreaLight, prim: &Primitive, r: &Receiver) -> f32 {
    let le = luminance(light.emission.le).max(0.0);
    let x = r.p;
    let (solid_angle, axis, cos_h) = match *prim {
        Primitive::Sphere { center, radius } => {
            let to_c = center - x;
            let (d2, r2) = (to_c.length_squared(), radius * radius);
            if d2 <= r2 {
                // Inside: an outward emitter sends nothing here; a two-sided one surrounds x.
                return if light.emission.two_sided { le * 2.0 * TAU } else { 0.0 };
            }
            let omc = one_minus_cos_max(r2, d2);
            (TAU * omc, to_c / d2.sqrt(), 1.0 - omc)
        }
        Primitive::Triangle(v) => {
            let normal = (v[1] - v[0]).cross(v[2] - v[0]);
            if !light.emission.two_sided && normal.dot(x - v[0]) <= 0.0 {
                return 0.0;
            }
            let axis = ((v[0] + v[1] + v[2]) / 3.0 - x).normalize_or_zero();
            if axis == Vec3::ZERO {
                return le * TAU;
            }
            let cos_h = v
                .iter()
                .map(|&p| axis.dot((p - x).normalize_or_zero()))
                .fold(1.0f32, f32::min);
            (triangle_solid_angle(v, x), axis, cos_h)
        }
    };
    let sin_h = (1.0 - cos_h * cos_h).max(0.0).sqrt();
    let cos_bound = cosine_bound(r.n, r.two_sided, axis, cos_h, sin_h);
    if cos_bound <= 0.0 {
        return 0.0;
    }
    le * solid_angle * cos_bound
}

/// Light selection at one receiver: built once per vertex, used to pick the emitter for
/// next-event estimation there and, for MIS, to give the probability with which that same
/// vertex would have picked a light that a BSDF-sampled ray from it hits. Small and `Copy`:
/// the path keeps the previous vertex's one for the MIS weight. The local weights themselves
/// live in a [`LocalWeights`] buffer owned by the caller, which [`LightContext::choose`] reads
/// right after [`LightSampling::at`] filled it; [`LightContext::pmf`] recomputes the one weight
/// it needs, bit for bit the same value.
///
/// Every selection picks among the scene's emitters in [`Scene::emitter`]'s order (area
/// lights, delta lights, the environment), so a scene with area lights only selects exactly
/// as it did before delta lights and environments existed.
#[derive(Clone, Copy, Debug)]
pub struct LightContext {
    /// The shading point; its normal and sidedness only with local selection (they are not
    /// needed otherwise and not computed).
    pub receiver: Receiver,
    sphere: SphereSampling,
    /// The sum of the local weights of every emitter; `None` for power and uniform selection.
    local_total: Option<f32>,
    /// Every emitter with the same probability (Mitsuba 3's emitter selection).
    uniform: bool,
    /// Probability of picking the scene's environment (0 without one).
    environment: f32,
}

/// What next-event estimation picked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Emitter {
    /// Area light `i` of `Scene::lights`.
    Area(usize),
    /// Delta light `i` of `Scene::delta_lights`.
    Delta(usize),
    /// The scene's environment.
    Environment,
}

/// Scratch space for the local weights of every emitter at one receiver.
#[derive(Clone, Debug)]
pub struct LocalWeights([f32; LOCAL_SELECTION_MAX_LIGHTS]);

impl Default for LocalWeights {
    fn default() -> Self {
        Self([0.0; LOCAL_SELECTION_MAX_LIGHTS])
    }
}

/// An emitter's weight for [`LightSelection::Local`] at `r`, in the units of [`local_weight`]
/// (luminance of the unoccluded irradiance, up to the cosine bound): a delta light's incident
/// Y(I falloff / r²) or Y(E) times the receiver's cosine toward it; the environment's mean
/// radiance over the hemisphere above the receiver (the sphere for a transmitting one).
pub fn emitter_weight(scene: &Scene, emitter: Emitter, r: &Receiver) -> f32 {
    match emitter {
        Emitter::Area(i) => {
            let light = &scene.lights[i];
            local_weight(light, &scene.primitives[light.prim as usize], r)
        }
        Emitter::Delta(i) => scene.delta_lights[i].illuminate(r.p).map_or(0.0, |s| {
            let cos = r.n.dot(s.wi);
            let cos = if r.two_sided { cos.abs() } else { cos.max(0.0) };
            luminance(s.li).max(0.0) * cos
        }),
        Emitter::Environment => scene.environment.as_ref().map_or(0.0, |e| {
            luminance(e.mean_radiance()).max(0.0) * if r.two_sided { 2.0 * TAU } else { TAU }
        }),
    }
}

impl LightSampling {
    /// The light selection at a shading point `p`. Local selection builds the full receiver with
    /// `receiver` and writes every emitter's weight into `weights` (O(#emitters)); power
    /// selection needs neither, so the per-vertex cost of the default stays a few instructions.
    #[inline]
    pub fn at(
        &self,
        scene: &Scene,
        p: Vec3,
        receiver: impl FnOnce() -> Receiver,
        weights: &mut Option<LocalWeights>,
    ) -> LightContext {
        let count = scene.emitter_count();
        if self.selection == LightSelection::Local && count <= LOCAL_SELECTION_MAX_LIGHTS {
            let r = receiver();
            let w = weights.get_or_insert_with(LocalWeights::default);
            let mut total = 0.0f32;
            for (i, wi) in w.0[..count].iter_mut().enumerate() {
                *wi = emitter_weight(scene, scene.emitter(i), &r);
                total += *wi;
            }
            let environment = match scene.environment_index() {
                Some(i) if total > 0.0 => w.0[i] / total,
                _ => 0.0,
            };
            return LightContext {
                receiver: r,
                sphere: self.sphere,
                local_total: Some(total),
                uniform: false,
                environment,
            };
        }
        let uniform = self.selection == LightSelection::Uniform;
        let environment = match (&scene.environment, uniform) {
            (None, _) => 0.0,
            (Some(_), true) => 1.0 / count as f32,
            (Some(_), false) => scene.environment_power_share(),
        };
        LightContext {
            receiver: Receiver {
                p,
                n: Vec3::ZERO,
                two_sided: true,
            },
            sphere: self.sphere,
            local_total: None,
            uniform,
            environment,
        }
    }
}

impl LightContext {
    /// Picks an emitter with `u ∈ [0, 1)`, and its probability; `None` when nothing can
    /// contribute at the receiver (local selection only). `weights` must be the buffer
    /// [`LightSampling::at`] filled for this context.
    #[inline]
    pub fn choose(&self, scene: &Scene, weights: &Option<LocalWeights>, u: f32) -> Option<(Emitter, f32)> {
        let count = scene.emitter_count();
        if self.uniform {
            let i = ((u * count as f32) as usize).min(count - 1);
            return Some((scene.emitter(i), 1.0 / count as f32));
        }
        let (Some(total), Some(weights)) = (self.local_total, weights) else {
            let (i, pmf, _) = scene.light_selection.sample(u);
            return Some((scene.emitter(i), pmf));
        };
        if total <= 0.0 {
            return None;
        }
        let w = &weights.0[..count];
        let target = u * total;
        let mut acc = 0.0f32;
        let mut last = None;
        for (i, &wi) in w.iter().enumerate() {
            if wi > 0.0 {
                acc += wi;
                last = Some(i);
                if target < acc {
                    break;
                }
            }
        }
        // Rounding may leave u · total at or past the last partial sum: the last light takes it.
        last.map(|i| (scene.emitter(i), w[i] / total))
    }

    /// Probability that [`LightContext::choose`] picks area light `i`.
    #[inline]
    pub fn pmf(&self, scene: &Scene, i: usize) -> f32 {
        match self.local_total {
            None if self.uniform => 1.0 / scene.emitter_count() as f32,
            None => scene.light_selection.pmf(i),
            Some(total) if total > 0.0 => {
                let light = &scene.lights[i];
                local_weight(light, &scene.primitives[light.prim as usize], &self.receiver) / total
            }
            Some(_) => 0.0,
        }
    }

    /// Solid-angle density with which next-event estimation here samples world direction `w`
    /// toward the environment, selection included (the light pdf of the MIS weight of a
    /// BSDF-sampled ray that escapes the scene).
    #[inline]
    pub fn pdf_environment_w(&self, scene: &Scene, w: Vec3) -> f32 {
        match &scene.environment {
            Some(env) if self.environment > 0.0 => self.environment * env.pdf(w),
            _ => 0.0,
        }
    }

    /// A point on light `light` for next-event estimation at the receiver (cone sampling of
    /// spheres when selected and the receiver is outside).
    #[inline]
    pub fn sample_point(&self, light: &AreaLight, prim: &Primitive, u: Vec2) -> LightSample {
        if let (SphereSampling::Cone, Primitive::Sphere { center, radius }) = (self.sphere, *prim)
            && let Some(s) = sample_sphere_cone(center, radius, self.receiver.p, u)
        {
            return s;
        }
        let lp = light.sample_point(prim, u);
        LightSample {
            p: lp.p,
            n: lp.n,
            pdf: PointPdf::Area(lp.pdf_a),
        }
    }

    /// Solid-angle density at the receiver with which next-event estimation here produces the
    /// point a ray from the receiver hit on light `i`, selection included: the light pdf of
    /// the MIS weight for emission found by BSDF sampling [Veach 1997, eq. (9.12)]. `dist` is
    /// the distance to the hit and `cos_light` the |cosine| at the light.
    #[inline]
    pub fn pdf_w(&self, scene: &Scene, i: usize, dist: f32, cos_light: f32) -> f32 {
        let light = &scene.lights[i];
        let pmf = self.pmf(scene, i);
        if let (SphereSampling::Cone, Primitive::Sphere { center, radius }) =
            (self.sphere, scene.primitives[light.prim as usize])
            && let Some(pdf_w) = sphere_cone_pdf(center, radius, self.receiver.p)
        {
            return pmf * pdf_w;
        }
        pmf * dist * dist / (light.area * cos_light)
    }
}
