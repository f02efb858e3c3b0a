//! Area lights: any emissive primitive (quad and mesh triangles, spheres). Each emissive
//! primitive is one light.
//!
//! Photon emission (and light sub-paths) choose lights in proportion to their emitted power and
//! points uniformly by area. Next-event estimation on eye paths ([`LightSampling`]) chooses
//! either by power or by a local estimate of each light's contribution at the shading point
//! ([`LightSelection`]), and samples sphere lights either by area or uniformly in the cone they
//! subtend ([`SphereSampling`]); [`LightContext`] keeps both choices for one shading point, so
//! that the MIS weight of a BSDF-sampled hit on a light uses the density light sampling there
//! would have had.

use crate::color::luminance;
use crate::geometry::{Frame, Primitive};
use crate::sampling::{sample_uniform_sphere, sample_uniform_triangle};
use crate::scene::Scene;
use glam::{Vec2, Vec3};
use serde::Deserialize;
use std::f32::consts::{PI, TAU};

/// Emission attached to a primitive: constant radiance `le` leaving the side its geometric
/// normal points to, or both sides when `two_sided`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emission {
    pub le: Vec3,
    pub two_sided: bool,
}

/// One emissive primitive.
#[derive(Clone, Copy, Debug)]
pub struct AreaLight {
    /// Index of the primitive in `Scene::primitives`.
    pub prim: u32,
    pub emission: Emission,
    pub area: f32,
}

/// A point sampled uniformly on a light's surface.
#[derive(Clone, Copy, Debug)]
pub struct LightPoint {
    pub p: Vec3,
    /// Unit geometric normal.
    pub n: Vec3,
    /// Area density of the point on this light (1 / area).
    pub pdf_a: f32,
}

impl AreaLight {
    /// Radiance leaving the light at a point with normal `n` in direction `w`.
    #[inline]
    pub fn le(&self, n: Vec3, w: Vec3) -> Vec3 {
        if self.emission.two_sided || n.dot(w) > 0.0 {
            self.emission.le
        } else {
            Vec3::ZERO
        }
    }

    /// Emitted power Φ = π A Le per side [Lambertian emitter], per channel.
    pub fn power(&self) -> Vec3 {
        let sides = if self.emission.two_sided { 2.0 } else { 1.0 };
        self.emission.le * (PI * self.area * sides)
    }

    /// A uniformly distributed point on the light's surface.
    #[inline]
    pub fn sample_point(&self, prim: &Primitive, u: Vec2) -> LightPoint {
        let p = match *prim {
            Primitive::Triangle([a, b, c]) => {
                let bary = sample_uniform_triangle(u);
                bary.x * a + bary.y * b + (1.0 - bary.x - bary.y) * c
            }
            Primitive::Sphere { center, radius } => center + radius * sample_uniform_sphere(u),
        };
        LightPoint {
            p,
            n: prim.geometric_normal(p),
            pdf_a: 1.0 / self.area,
        }
    }
}

/// How next-event estimation picks one light among the scene's emissive primitives.
///
/// `"power"` picks light i with probability Φᵢ / Σ Φ (luminance of the emitted power,
/// `Scene::light_selection`): one table for the whole scene, blind to where the shading point
/// is. `"local"` picks ∝ an estimate of light i's unoccluded contribution at the shading point,
/// [`local_weight`] = Y(Leᵢ) · Ωᵢ(x) · c̄ᵢ(x) (solid angle times an upper bound of the receiver
/// cosine), the per-point importance many-light samplers use [Shirley, Wang & Zimmerman 1996,
/// "Monte Carlo Techniques for Direct Lighting Calculations", ACM TOG 15(1); Conty Estevez &
/// Kulla 2018, "Importance Sampling of Many Lights with Adaptive Tree Splitting", HPG, whose
/// bounding-cone cosine bound this borrows]. Why: with power selection a weak light next to the
/// shading point (Jensen 1995's bulb inside its lamp shade) is rarely picked although it
/// dominates there. It costs O(#lights) per vertex, so scenes with more than
/// [`LOCAL_SELECTION_MAX_LIGHTS`] emissive primitives fall back to power selection.
///
/// Unbiasedness: a light gets weight 0 only when it provably contributes nothing at the
/// point (one-sided emitter facing away, or entirely below the horizon of a reflect-only
/// BSDF); any other light's weight is positive (up to f32 underflow of Ω for a light seen
/// exactly edge-on, whose contribution ∝ cos θ' vanishes with it). With MIS a zero-probability
/// light is covered by BSDF sampling anyway, as long as the MIS weight uses the same pmf
/// ([`LightContext::pdf_w`]).
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum LightSelection {
    #[default]
    Power,
    Local,
}

/// How next-event estimation samples a point on a sphere light (triangles are always sampled
/// uniformly by area).
///
/// `"area"` samples the whole sphere uniformly by area: from outside, half the points lie on
/// the far side, hidden by the sphere itself, and the solid-angle pdf varies with 1/cos θ'
/// across the visible cap. `"cone"` samples directions uniformly inside the cone the sphere
/// subtends at the shading point x and takes the near intersection, pdf 1 / (2π (1 − cos θmax))
/// with sin θmax = r / |c − x| [Shirley, Wang & Zimmerman 1996; the approach of pbrt-v3's
/// `Sphere::Sample(ref, u)`]: every sample lands on the visible cap and the estimator of an
/// unoccluded sphere's irradiance has only the receiver cosine's variance. At points on or
/// inside the sphere (|c − x|² ≤ 1.0001 r², pbrt's margin) there is no cone and area sampling
/// is used.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum SphereSampling {
    #[default]
    Area,
    Cone,
}

/// Light sampling options of next-event estimation on eye paths (`path`, `photon_guided`,
/// `photon_map`'s direct term).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LightSampling {
    pub selection: LightSelection,
    pub sphere: SphereSampling,
}

/// Largest number of lights [`LightSelection::Local`] evaluates at every vertex; scenes with
/// more emissive primitives (an emissive OBJ mesh) use power selection instead. Every shipped
/// scene has at most four.
pub const LOCAL_SELECTION_MAX_LIGHTS: usize = 64;

/// Points closer to a sphere's centre than this factor times r² count as on or inside it:
/// pbrt's margin, so that a point on the sphere itself never builds a degenerate cone.
const SPHERE_INSIDE: f32 = 1.0001;

/// The point next-event estimation samples lights for.
#[derive(Clone, Copy, Debug)]
pub struct Receiver {
    pub p: Vec3,
    /// Unit shading normal turned to the side of ωo.
    pub n: Vec3,
    /// The BSDF transmits: light from both sides of the surface counts.
    pub two_sided: bool,
}

/// How a sampled light point's density is expressed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PointPdf {
    /// Density per unit area on the light (uniform area sampling: 1 / A).
    Area(f32),
    /// Density per unit solid angle at the receiver (cone sampling of a sphere).
    SolidAngle(f32),
}

/// A point sampled on a light for a receiver.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    pub p: Vec3,
    /// Unit geometric normal at `p`.
    pub n: Vec3,
    pub pdf: PointPdf,
}

/// The cone a sphere of radius r subtends from a point at squared distance d² > r² from its
/// centre: 1 − cos θmax, computed as sin²θmax / (1 + cos θmax) so that small, distant spheres
/// do not lose it to cancellation.
#[inline]
fn one_minus_cos_max(r2: f32, d2: f32) -> f32 {
    let sin2 = (r2 / d2).min(1.0);
    sin2 / (1.0 + (1.0 - sin2).sqrt())
}

/// Solid-angle density of [`sample_sphere_cone`]: uniform in the cone, 1 / (2π (1 − cos θmax)).
/// `None` when `x` is on or inside the sphere (no cone: area sampling is used there).
#[inline]
pub fn sphere_cone_pdf(center: Vec3, radius: f32, x: Vec3) -> Option<f32> {
    let (d2, r2) = ((center - x).length_squared(), radius * radius);
    (d2 > SPHERE_INSIDE * r2).then(|| 1.0 / (TAU * one_minus_cos_max(r2, d2)))
}

/// A point on the part of a sphere visible from `x`, reached by a direction uniform in the cone
/// the sphere subtends [Shirley, Wang & Zimmerman 1996]; `None` when `x` is on or inside.
///
/// The direction makes angle θ with the axis x → c, cos θ = 1 − u₀ (1 − cos θmax); its near
/// intersection with the sphere is found as the angle α at the centre between c → x and
/// c → p: from the triangle x, c, p (|c − x| = d, |p − c| = r), d sin θ = r sin(θ + α) gives
/// cos α = (d/r) sin²θ + cos θ √(1 − (d/r)² sin²θ), which stays accurate for distant spheres
/// where intersecting the ray would cancel. The point is then exact on the sphere.
pub fn sample_sphere_cone(center: Vec3, radius: f32, x: Vec3, u: Vec2) -> Option<LightSample> {
    let to_c = center - x;
    let (d2, r2) = (to_c.length_squared(), radius * radius);
    if d2 <= SPHERE_INSIDE * r2 {
        return None;
    }
    let omc_max = one_minus_cos_max(r2, d2);
    let omc = u.x * omc_max;
    let cos_t = 1.0 - omc;
    let sin2_t = omc * (2.0 - omc);
    // (d/r)² sin²θ ≤ 1 inside the cone; rounding may step past it at the silhouette.
    let k = (d2 / r2 * sin2_t).min(1.0);
    let cos_a = (d2 / r2).sqrt() * sin2_t + cos_t * (1.0 - k).sqrt();
    let sin_a = (1.0 - cos_a * cos_a).max(0.0).sqrt();
    let phi = TAU * u.y;
    // Frame around the axis c → x; the point lies on the side the direction leans to.
    let w = -to_c / d2.sqrt();
    let frame = Frame::from_normal(w);
    let n = frame.to_world(Vec3::new(sin_a * phi.cos(), sin_a * phi.sin(), cos_a));
    Some(LightSample {
        p: center + radius * n,
        n,
        pdf: PointPdf::SolidAngle(1.0 / (TAU * omc_max)),
    })
}

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

/// Light selection at one receiver: built once per vertex, used to pick the light for
/// next-event estimation there and, for MIS, to give the probability with which that same
/// vertex would have picked a light that a BSDF-sampled ray from it hits. Small and `Copy`:
/// the path keeps the previous vertex's one for the MIS weight. The local weights themselves
/// live in a [`LocalWeights`] buffer owned by the caller, which [`LightContext::choose`] reads
/// right after [`LightSampling::at`] filled it; [`LightContext::pmf`] recomputes the one weight
/// it needs, bit for bit the same value.
#[derive(Clone, Copy, Debug)]
pub struct LightContext {
    /// The shading point; its normal and sidedness only with local selection (they are not
    /// needed otherwise and not computed).
    pub receiver: Receiver,
    sphere: SphereSampling,
    /// The sum of the local weights of every light; `None` for power selection.
    local_total: Option<f32>,
}

/// Scratch space for the local weights of every light at one receiver.
#[derive(Clone, Debug)]
pub struct LocalWeights([f32; LOCAL_SELECTION_MAX_LIGHTS]);

impl Default for LocalWeights {
    fn default() -> Self {
        Self([0.0; LOCAL_SELECTION_MAX_LIGHTS])
    }
}

impl LightSampling {
    /// The light selection at a shading point `p`. Local selection builds the full receiver with
    /// `receiver` and writes every light's weight into `weights` (O(#lights)); power selection
    /// needs neither, so the per-vertex cost of the default stays a few instructions.
    #[inline]
    pub fn at(
        &self,
        scene: &Scene,
        p: Vec3,
        receiver: impl FnOnce() -> Receiver,
        weights: &mut Option<LocalWeights>,
    ) -> LightContext {
        if self.selection == LightSelection::Local && scene.lights.len() <= LOCAL_SELECTION_MAX_LIGHTS {
            let r = receiver();
            let w = weights.get_or_insert_with(LocalWeights::default);
            let mut total = 0.0f32;
            for (wi, light) in w.0.iter_mut().zip(&scene.lights) {
                *wi = local_weight(light, &scene.primitives[light.prim as usize], &r);
                total += *wi;
            }
            return LightContext {
                receiver: r,
                sphere: self.sphere,
                local_total: Some(total),
            };
        }
        LightContext {
            receiver: Receiver {
                p,
                n: Vec3::ZERO,
                two_sided: true,
            },
            sphere: self.sphere,
            local_total: None,
        }
    }
}

impl LightContext {
    /// Picks a light with `u ∈ [0, 1)`: its index and probability; `None` when no light can
    /// contribute at the receiver (local selection only). `weights` must be the buffer
    /// [`LightSampling::at`] filled for this context.
    #[inline]
    pub fn choose(&self, scene: &Scene, weights: &Option<LocalWeights>, u: f32) -> Option<(usize, f32)> {
        let (Some(total), Some(weights)) = (self.local_total, weights) else {
            let (i, pmf, _) = scene.light_selection.sample(u);
            return Some((i, pmf));
        };
        if total <= 0.0 {
            return None;
        }
        let w = &weights.0[..scene.lights.len()];
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
        last.map(|i| (i, w[i] / total))
    }

    /// Probability that [`LightContext::choose`] picks light `i`.
    #[inline]
    pub fn pmf(&self, scene: &Scene, i: usize) -> f32 {
        match self.local_total {
            None => scene.light_selection.pmf(i),
            Some(total) if total > 0.0 => {
                let light = &scene.lights[i];
                local_weight(light, &scene.primitives[light.prim as usize], &self.receiver) / total
            }
            Some(_) => 0.0,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::test_scenes::SceneBuilder;
    use crate::sampling::Rng;
    use crate::sampling::chi2::{CHI2_ALPHA, DirectionTest, chi2_statistic, chi2_test_directions};

    /// The cone sampler, as next-event estimation uses it (direction from x to the sampled
    /// point), draws directions with the density it reports: χ² over the sphere of directions,
    /// for cones from nearly a hemisphere (x just outside the sphere) to narrow ones, around +z
    /// (cone edges on cell boundaries) and around a tilted axis.
    #[test]
    fn sphere_cone_sampler_passes_chi2_against_its_pdf() {
        let x = Vec3::new(0.3, -0.2, 0.1);
        let radius = 0.5;
        for (k, (distance, axis)) in [
            (1.05 * radius, Vec3::Z),
            (1.5 * radius, Vec3::Z),
            (3.0 * radius, Vec3::Z),
            (1.2 * radius, Vec3::new(0.4, -0.7, 0.2).normalize()),
        ]
        .into_iter()
        .enumerate()
        {
            let center = x + distance * axis;
            let pdf = sphere_cone_pdf(center, radius, x).unwrap();
            let cos_max = (1.0 - (radius / distance).powi(2)).sqrt();
            let report = chi2_test_directions(
                |rng: &mut Rng| {
                    let s = sample_sphere_cone(center, radius, x, rng.uniform2()).unwrap();
                    assert!(((s.p - center).length() - radius).abs() < 1e-5 * radius, "{s:?}");
                    assert!((s.n - (s.p - center) / radius).length() < 1e-5);
                    let PointPdf::SolidAngle(pdf_w) = s.pdf else {
                        panic!("cone sampling reports a solid-angle pdf")
                    };
                    Some(((s.p - x).normalize(), pdf_w))
                },
                // A band of 1e-6 in cos θ around the cone's edge absorbs the rounding of
                // directions taken from points on the silhouette.
                |w| if w.dot(axis) >= cos_max - 1e-6 { pdf } else { 0.0 },
                DirectionTest {
                    theta_bins: 40,
                    seed: 20 + k as u64,
                    ..DirectionTest::default()
                },
            );
            assert!(report.passes(CHI2_ALPHA), "d = {distance}, axis {axis}: {report:?}");
            assert!((report.pdf_integral - 1.0).abs() < 1e-3, "{report:?}");
        }
    }

    /// A point on or inside the sphere has no cone: the sampler and its pdf both decline (the
    /// caller samples by area), with pbrt's margin of 1.0001 r².
    #[test]
    fn sphere_cone_sampler_declines_on_and_inside_the_sphere() {
        let (c, r) = (Vec3::new(1.0, 2.0, 3.0), 0.25);
        for x in [c, c + Vec3::new(0.1, 0.0, 0.0), c + Vec3::new(0.0, r, 0.0)] {
            assert!(sample_sphere_cone(c, r, x, Vec2::splat(0.3)).is_none());
            assert!(sphere_cone_pdf(c, r, x).is_none());
        }
        assert!(sphere_cone_pdf(c, r, c + Vec3::new(0.0, 1.01 * r, 0.0)).is_some());
    }

    /// A small, distant sphere (θmax ≈ 10⁻⁴): 1 − cos θmax keeps its precision (the naive
    /// 1 − √(1 − sin²θmax) is zero in f32 here) and samples land on the visible cap.
    #[test]
    fn sphere_cone_sampler_keeps_precision_for_distant_spheres() {
        let (c, r, x) = (Vec3::new(0.0, 1000.0, 0.0), 0.1, Vec3::ZERO);
        let exact = {
            let s2 = (r as f64 / 1000.0).powi(2);
            1.0 - (1.0 - s2).sqrt()
        };
        let pdf = sphere_cone_pdf(c, r, x).unwrap() as f64;
        let want = 1.0 / (std::f64::consts::TAU * exact);
        assert!((pdf - want).abs() < 1e-5 * want, "{pdf} vs {want}");
        let mut rng = Rng::for_task(5, [0, 0, 0]);
        for _ in 0..1000 {
            let s = sample_sphere_cone(c, r, x, rng.uniform2()).unwrap();
            assert!(s.n.dot(x - s.p) > 0.0, "on the near side: {s:?}");
            assert!(((s.p - c).length() - r).abs() < 1e-4, "{s:?}");
        }
    }

    /// Irradiance from a sphere light fully above the horizon of a receiver facing its centre
    /// is E = π Le sin²θmax. Both samplers estimate it without bias; the cone sampler with
    /// variance several times lower (no samples wasted on the far side, no 1/cos θ').
    #[test]
    fn both_sphere_samplers_estimate_the_irradiance_of_a_sphere() {
        let (c, r, x) = (Vec3::new(0.2, 0.9, -0.1), 0.3, Vec3::ZERO);
        let n = c.normalize();
        let le = 2.0f64;
        let d2 = c.length_squared() as f64;
        let exact = std::f64::consts::PI * le * (r as f64).powi(2) / d2;
        let light = AreaLight {
            prim: 0,
            emission: Emission {
                le: Vec3::splat(le as f32),
                two_sided: false,
            },
            area: 4.0 * PI * r * r,
        };
        let prim = Primitive::Sphere { center: c, radius: r };
        let estimate = |cone: bool| {
            let mut rng = Rng::for_task(9, [cone as u64, 0, 0]);
            let samples = 200_000;
            let (mut s1, mut s2) = (0.0f64, 0.0f64);
            for _ in 0..samples {
                let u = rng.uniform2();
                let s = if cone {
                    sample_sphere_cone(c, r, x, u).unwrap()
                } else {
                    let lp = light.sample_point(&prim, u);
                    LightSample {
                        p: lp.p,
                        n: lp.n,
                        pdf: PointPdf::Area(lp.pdf_a),
                    }
                };
                let to = s.p - x;
                let d2 = to.length_squared();
                let wi = to / d2.sqrt();
                // The sphere hides its own far side: a point is visible when it faces x.
                let visible = s.n.dot(-wi) > 0.0;
                let pdf_w = match s.pdf {
                    PointPdf::Area(pdf_a) => pdf_a * d2 / s.n.dot(wi).abs(),
                    PointPdf::SolidAngle(p) => p,
                };
                let v = if visible {
                    (light.le(s.n, -wi).x * n.dot(wi).max(0.0) / pdf_w) as f64
                } else {
                    0.0
                };
                s1 += v;
                s2 += v * v;
            }
            let m = s1 / samples as f64;
            let var = s2 / samples as f64 - m * m;
            (m, (var / samples as f64).sqrt(), var)
        };
        let (m_area, se_area, var_area) = estimate(false);
        let (m_cone, se_cone, var_cone) = estimate(true);
        assert!(
            (m_area - exact).abs() < 4.5 * se_area,
            "area {m_area} ± {se_area} vs {exact}"
        );
        assert!(
            (m_cone - exact).abs() < 4.5 * se_cone,
            "cone {m_cone} ± {se_cone} vs {exact}"
        );
        assert!(var_area > 4.0 * var_cone, "variance area {var_area} vs cone {var_cone}");
    }

    /// A scene with lights of every kind around the origin: a one-sided quad (two triangles)
    /// facing −y above, a two-sided quad to the side, a one-sided and a two-sided sphere.
    fn mixed_lights() -> Scene {
        let mut b = SceneBuilder::new();
        let black = b.lambertian(Vec3::ZERO);
        b.quad(
            Vec3::new(-0.5, 1.0, -0.5),
            Vec3::X,
            Vec3::Z,
            black,
            Some(Vec3::splat(3.0)),
        );
        b.quad(
            Vec3::new(1.5, -0.5, -0.3),
            Vec3::new(0.0, 0.0, 0.6),
            Vec3::new(0.0, 0.8, 0.0),
            black,
            Some(Vec3::splat(1.0)),
        );
        let sphere = |le: f32, two_sided| Emission {
            le: Vec3::splat(le),
            two_sided,
        };
        b.sphere_light(Vec3::new(-0.6, 0.3, 0.4), 0.1, black, sphere(10.0, false));
        b.sphere_light(Vec3::new(0.3, -0.7, -0.2), 0.2, black, sphere(5.0, true));
        b.build()
    }

    /// Unbiasedness of local selection needs a positive weight for every light that can
    /// contribute at the receiver. For random receivers (reflecting or transmitting, any
    /// normal) and random points on every light, whenever the point emits towards x and lies
    /// on the receiver's side (either side when transmitting), the light's weight is positive;
    /// and a light with weight 0 never has such a point.
    #[test]
    fn local_weight_is_positive_for_every_light_that_can_contribute() {
        let scene = mixed_lights();
        assert_eq!(scene.lights.len(), 6);
        let mut rng = Rng::for_task(13, [0, 0, 0]);
        let (mut zero, mut positive) = (0, 0);
        for _ in 0..4000 {
            let p = Vec3::new(
                rng.uniform() * 4.0 - 2.0,
                rng.uniform() * 3.0 - 1.5,
                rng.uniform() * 3.0 - 1.5,
            );
            let r = Receiver {
                p,
                n: sample_uniform_sphere(rng.uniform2()),
                two_sided: rng.uniform() < 0.3,
            };
            for light in &scene.lights {
                let prim = &scene.primitives[light.prim as usize];
                let w = local_weight(light, prim, &r);
                assert!(w.is_finite() && w >= 0.0, "{w}");
                if w > 0.0 {
                    positive += 1;
                    continue;
                }
                zero += 1;
                for _ in 0..200 {
                    let lp = light.sample_point(prim, rng.uniform2());
                    let wi = (lp.p - p).normalize();
                    let emits = light.le(lp.n, -wi) != Vec3::ZERO;
                    let cos = r.n.dot(wi);
                    let side = if r.two_sided { cos != 0.0 } else { cos > 0.0 };
                    assert!(!(emits && side), "weight 0 but {lp:?} lights {r:?}");
                }
            }
        }
        assert!(
            zero > 1000 && positive > 10_000,
            "both cases exercised: {zero} zero, {positive} positive"
        );
    }

    /// Near a light its local weight dominates; a one-sided light seen from behind gets none.
    #[test]
    fn local_selection_prefers_the_light_next_to_the_receiver() {
        let scene = mixed_lights();
        let sampling = LightSampling {
            selection: LightSelection::Local,
            sphere: SphereSampling::Cone,
        };
        // Just beside the small one-sided sphere (light 4), facing it.
        let r = Receiver {
            p: Vec3::new(-0.6, 0.3, 0.52),
            n: -Vec3::Z,
            two_sided: false,
        };
        let ctx = sampling.at(&scene, r.p, || r, &mut None);
        assert!(ctx.pmf(&scene, 4) > 0.9, "{}", ctx.pmf(&scene, 4));
        assert!(scene.light_selection.pmf(4) < 0.3);
        // Above the ceiling quad (lights 0 and 1 emit downwards): they get probability 0.
        let above = LightSampling {
            selection: LightSelection::Local,
            sphere: SphereSampling::Area,
        }
        .at(
            &scene,
            Vec3::new(0.0, 1.5, 0.0),
            || Receiver {
                p: Vec3::new(0.0, 1.5, 0.0),
                n: -Vec3::Y,
                two_sided: true,
            },
            &mut None,
        );
        assert_eq!(above.pmf(&scene, 0), 0.0);
        assert_eq!(above.pmf(&scene, 1), 0.0);
        let total: f32 = (0..scene.lights.len()).map(|i| above.pmf(&scene, i)).sum();
        assert!((total - 1.0).abs() < 1e-5, "{total}");
    }

    /// `choose` picks lights with the frequencies `pmf` reports (χ² on the counts), for power
    /// and local selection at receivers where the pmfs differ.
    #[test]
    fn light_choice_frequencies_match_the_reported_pmf() {
        let scene = mixed_lights();
        let n_lights = scene.lights.len();
        let mut rng = Rng::for_task(17, [0, 0, 0]);
        for (k, selection) in [LightSelection::Power, LightSelection::Local, LightSelection::Local]
            .into_iter()
            .enumerate()
        {
            let r = Receiver {
                p: Vec3::new(0.1 * k as f32, 0.2, -0.3 + 0.2 * k as f32),
                n: Vec3::new(0.3, 1.0, -0.2 * k as f32).normalize(),
                two_sided: k == 2,
            };
            let mut weights = None;
            let ctx = LightSampling {
                selection,
                sphere: SphereSampling::Area,
            }
            .at(&scene, r.p, || r, &mut weights);
            let n = 100_000;
            let mut counts = vec![0.0f64; n_lights];
            for _ in 0..n {
                let (i, pmf) = ctx.choose(&scene, &weights, rng.uniform()).unwrap();
                // Bit for bit: the MIS weight recomputes the one weight it needs.
                assert_eq!(pmf, ctx.pmf(&scene, i));
                counts[i] += 1.0;
            }
            let expected: Vec<f64> = (0..n_lights).map(|i| ctx.pmf(&scene, i) as f64 * n as f64).collect();
            let chi2 = chi2_statistic(&counts, &expected, 5.0);
            assert!(
                chi2.p_value > CHI2_ALPHA,
                "{selection:?} at {r:?}: {chi2:?} {counts:?} {expected:?}"
            );
        }
    }

    /// The light pdf of the MIS weight ([`LightContext::pdf_w`]) is the density light sampling
    /// reports for the same point: area sampling's p_A r² / |cos θ'| times the pmf, or the
    /// cone's density times the pmf, for every option.
    #[test]
    fn mis_light_pdf_equals_the_sampling_density() {
        let scene = mixed_lights();
        let mut rng = Rng::for_task(19, [0, 0, 0]);
        for selection in [LightSelection::Power, LightSelection::Local] {
            for sphere in [SphereSampling::Area, SphereSampling::Cone] {
                let sampling = LightSampling { selection, sphere };
                let mut weights = None;
                let r = Receiver {
                    p: Vec3::new(0.0, 0.1, 0.0),
                    n: Vec3::Y,
                    two_sided: true,
                };
                let ctx = sampling.at(&scene, r.p, || r, &mut weights);
                for _ in 0..2000 {
                    let Some((i, pmf)) = ctx.choose(&scene, &weights, rng.uniform()) else {
                        continue;
                    };
                    let light = &scene.lights[i];
                    let s = ctx.sample_point(light, &scene.primitives[light.prim as usize], rng.uniform2());
                    let to = s.p - ctx.receiver.p;
                    let (d2, wi) = (to.length_squared(), to.normalize());
                    let cos_light = s.n.dot(wi).abs();
                    let sampled = match s.pdf {
                        PointPdf::Area(pdf_a) => pmf * pdf_a * d2 / cos_light,
                        PointPdf::SolidAngle(pdf_w) => pmf * pdf_w,
                    };
                    let mis = ctx.pdf_w(&scene, i, d2.sqrt(), cos_light);
                    assert!(
                        (sampled - mis).abs() <= 1e-4 * sampled,
                        "{selection:?} {sphere:?} light {i}: {sampled} vs {mis}"
                    );
                }
            }
        }
    }
}
