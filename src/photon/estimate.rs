//! Density estimation from a photon map [Jensen 1996]: irradiance and reflected radiance at a
//! surface point x with unit normal n from the photons nearest to x.
//!
//! E(x) ≈ Σ_p w_p ΔΦ_p / (c · π r²),   L_r(x, ωo) ≈ Σ_p f_r(x, ωo, ω_p) w_p ΔΦ_p / (c · π r²)
//!
//! The photon powers ΔΦ_p are flux arriving at the surface, so there is no cosine factor here
//! (adding one is the "photon mapping darker than path tracing" bug listed in NOTES.md).
//!
//! Decisions:
//! - **Which photons.** The N nearest within `max_radius` that pass two tests:
//!   the stored normal must agree with n (n_p · n ≥ `normal_dot`, default 0.5), and the photon
//!   must arrive from the front (ω_p · n > 0). The first rejects photons on other surfaces
//!   (the adjacent wall of a corner has dot ≈ 0, the other side of a thin wall or of a
//!   two-sided sheet has dot ≈ −1), with margin for the normal's quantisation (≤ 2.5°) and for
//!   curved surfaces (a sphere of radius R keeps photons within arc length ≈ R π/3). Because
//!   the tests run *inside* the k-nearest search, back-side photons never shrink the search
//!   radius (the bug of mitsuba#145). For diffuse transmission, estimate each side with its
//!   own normal (E on the back side is the estimate with −n).
//! - **Radius r.** With N photons found, r is the distance to the farthest of them (Jensen's
//!   "expanding sphere"). With fewer found, r = `max_radius`: the whole disc was searched, and
//!   dividing by the smaller disc of the few photons found would overestimate sparse regions.
//!   (With an infinite `max_radius` and fewer than N photons in the map, r falls back to the
//!   farthest photon found.) No photon gives 0.
//! - **Filter.** [`Filter::Box`] weighs every photon 1 (c = 1). [`Filter::Cone`] weighs a
//!   photon at distance d by w_p = 1 − d / (k r) and normalises by c = 1 − 2 / (3k)
//!   [Jensen 1996, cone filter; k = 1.1 in the paper].

use super::PhotonMap;
use super::kdtree::Neighbour;
use super::record::Photon;
use crate::error::{Error, Result};
use glam::Vec3;
use serde::Deserialize;
use std::cell::RefCell;
use std::f32::consts::PI;

/// Weighting of the photons within the estimate's disc.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Filter {
    /// Every photon weighs 1.
    #[default]
    Box,
    /// w = 1 − d / (k r), normalised by 1 − 2/(3k) [Jensen 1996]; k ≥ 1 (1.1 in the paper).
    Cone { k: f32 },
}

/// Parameters of a density estimate.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct EstimateParams {
    /// Photons per estimate, N (default 50; Christensen 1999 uses 50 in the Cornell box and
    /// quotes 30–200 as typical).
    pub nearest: usize,
    /// Search radius bound in scene units (default ∞: pure N-nearest). Set it to a few percent
    /// of the scene size so that sparse regions do not average over far-away surfaces.
    pub max_radius: f32,
    /// Minimum n_p · n of a photon's stored normal with the query normal (default 0.5).
    pub normal_dot: f32,
    /// Photon weighting (default [`Filter::Box`]).
    pub filter: Filter,
}

impl Default for EstimateParams {
    fn default() -> Self {
        Self {
            nearest: 50,
            max_radius: f32::INFINITY,
            normal_dot: 0.5,
            filter: Filter::Box,
        }
    }
}

impl EstimateParams {
    /// Checks the ranges: N ≥ 1, `max_radius` > 0 (∞ allowed), `normal_dot` ∈ [−1, 1],
    /// cone k ≥ 1 (finite).
    pub fn validate(&self) -> Result<()> {
        if self.nearest == 0 {
            return Err(Error::new("nearest must be at least 1, got 0"));
        }
        if self.max_radius.is_nan() || self.max_radius <= 0.0 {
            return Err(Error::new(format!(
                "max_radius must be positive, got {}",
                self.max_radius
            )));
        }
        if !(-1.0..=1.0).contains(&self.normal_dot) {
            return Err(Error::new(format!(
                "normal_dot must lie in [-1, 1], got {}",
                self.normal_dot
            )));
        }
        if let Filter::Cone { k } = self.filter
            && !(k.is_finite() && k >= 1.0)
        {
            return Err(Error::new(format!("the cone filter's k must be ≥ 1, got {k}")));
        }
        Ok(())
    }
}

/// The result of a density estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Irradiance E (W/m²) or radiance L (W/(m² sr)), per channel.
    pub value: Vec3,
    /// Photons used.
    pub photons: usize,
    /// Radius r of the disc the value was averaged over (0 when no photon was found).
    pub radius: f32,
}

thread_local! {
    /// Reused k-nearest buffers, one per thread (taken out while in use, so re-entrant calls
    /// just allocate).
    static NEIGHBOURS: RefCell<Vec<Neighbour>> = const { RefCell::new(Vec::new()) };
}

/// The photons an estimate on the side of `n` may use: stored normal within the cone of
/// `normal_dot`, arriving from the front (see the module doc).
fn accept(n: Vec3, params: &EstimateParams) -> impl Fn(&Photon) -> bool + '_ {
    move |p: &Photon| p.normal().dot(n) >= params.normal_dot && p.direction().dot(n) > 0.0
}

impl PhotonMap {
    /// Irradiance E(x) on the side of unit normal `n` (see the module doc).
    pub fn irradiance(&self, x: Vec3, n: Vec3, params: &EstimateParams) -> Estimate {
        self.estimate(x, n, params, |_| Vec3::ONE)
    }

    /// Reflected radiance L_r(x, ωo) = Σ f_r(ωo, ω_p) ΔΦ_p w_p / (c π r²) on the side of `n`;
    /// `f_r(wi)` evaluates the BSDF (without cosine) for the world-space unit direction ω_p the
    /// photon came from, for the caller's fixed ωo. For a Lambertian surface this is ρ/π · E.
    pub fn radiance(&self, x: Vec3, n: Vec3, params: &EstimateParams, f_r: impl Fn(Vec3) -> Vec3) -> Estimate {
        self.estimate(x, n, params, f_r)
    }

    /// Irradiance as [`PhotonMap::irradiance`], from the photons for which `also` holds as well.
    /// `also` may be costly (a ray): it is tested only on photons that pass the normal and side
    /// tests and are no farther than the estimate's N-th photon ([`KdTree::k_nearest_tested`]).
    ///
    /// [`KdTree::k_nearest_tested`]: super::kdtree::KdTree::k_nearest_tested
    pub fn irradiance_where(
        &self,
        x: Vec3,
        n: Vec3,
        params: &EstimateParams,
        also: impl Fn(&Photon) -> bool,
    ) -> Estimate {
        self.with_found(
            |found| {
                self.tree()
                    .k_nearest_tested(x, params.nearest, params.max_radius, accept(n, params), &also, found)
            },
            |found| self.density(found, params, |_| Vec3::ONE),
        )
    }

    fn estimate(&self, x: Vec3, n: Vec3, params: &EstimateParams, f_r: impl Fn(Vec3) -> Vec3) -> Estimate {
        self.with_found(
            |found| {
                self.tree()
                    .k_nearest_into(x, params.nearest, params.max_radius, accept(n, params), found)
            },
            |found| self.density(found, params, f_r),
        )
    }

    /// Runs `search` into this thread's reused neighbour buffer and `sum` over what it found.
    fn with_found(
        &self,
        search: impl FnOnce(&mut Vec<Neighbour>),
        sum: impl FnOnce(&[Neighbour]) -> Estimate,
    ) -> Estimate {
        let mut found = NEIGHBOURS.with(|b| std::mem::take(&mut *b.borrow_mut()));
        search(&mut found);
        let result = sum(&found);
        NEIGHBOURS.with(|b| *b.borrow_mut() = found);
        result
    }

    /// Sums the photons found (in the kd-tree's heap order: `found[0]` is the farthest) into a
    /// density estimate.
    fn density(&self, found: &[Neighbour], params: &EstimateParams, f_r: impl Fn(Vec3) -> Vec3) -> Estimate {
        let Some(farthest) = found.first() else {
            return Estimate {
                value: Vec3::ZERO,
                photons: 0,
                radius: 0.0,
            };
        };
        let r = if found.len() < params.nearest && params.max_radius.is_finite() {
            params.max_radius
        } else {
            farthest.dist2.sqrt()
        };
        if r <= 0.0 {
            // N photons at one point: a density of infinity is no estimate.
            return Estimate {
                value: Vec3::ZERO,
                photons: found.len(),
                radius: 0.0,
            };
        }
        let photons = self.photons();
        let mut sum = Vec3::ZERO;
        let norm = match params.filter {
            Filter::Box => {
                for nb in found {
                    let p = &photons[nb.index as usize];
                    sum += f_r(p.direction()) * p.power();
                }
                1.0
            }
            Filter::Cone { k } => {
                for nb in found {
                    let p = &photons[nb.index as usize];
                    let w = 1.0 - nb.dist2.sqrt() / (k * r);
                    sum += f_r(p.direction()) * p.power() * w;
                }
                1.0 - 2.0 / (3.0 * k)
            }
        };
        Estimate {
            value: sum / (norm * PI * r * r),
            photons: found.len(),
            radius: r,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::record::Rgbe;
    use crate::photon::test_scenes::{SceneBuilder, polygon_irradiance};
    use crate::photon::trace::{TraceParams, trace_photons};
    use crate::sampling::{Rng, sample_concentric_disk};
    use glam::Vec2;

    /// A black 6 × 6 floor at y = 0 under a 0.2 × 0.2 light at height 1 facing down.
    fn floor_under_light(le: Vec3, below: Option<Vec3>) -> (crate::scene::Scene, Vec<[Vec3; 4]>) {
        let mut b = SceneBuilder::new();
        let black = b.lambertian(Vec3::ZERO);
        b.quad(
            Vec3::new(-3.0, 0.0, -3.0),
            Vec3::new(0.0, 0.0, 6.0),
            Vec3::new(6.0, 0.0, 0.0),
            black,
            None,
        );
        let top = [
            Vec3::new(-0.1, 1.0, -0.1),
            Vec3::new(0.1, 1.0, -0.1),
            Vec3::new(0.1, 1.0, 0.1),
            Vec3::new(-0.1, 1.0, 0.1),
        ];
        b.quad(top[0], top[1] - top[0], top[3] - top[0], black, Some(le));
        let mut lights = vec![top];
        if let Some(le_below) = below {
            let bot = top.map(|v| Vec3::new(v.x, -1.0, v.z));
            b.quad(bot[0], bot[3] - bot[0], bot[1] - bot[0], black, Some(le_below));
            lights.push(bot);
        }
        (b.build(), lights)
    }

    /// Exact irradiance averaged over the disc of radius r about x on the floor (the value a
    /// fixed-radius estimate converges to).
    fn disc_average(light: &[Vec3; 4], le: Vec3, x: Vec3, n: Vec3, r: f32) -> Vec3 {
        let m = 64;
        let mut sum = Vec3::ZERO;
        for i in 0..m {
            for j in 0..m {
                let d = sample_concentric_disk(Vec2::new((i as f32 + 0.5) / m as f32, (j as f32 + 0.5) / m as f32));
                sum += polygon_irradiance(light, le, x + Vec3::new(d.x, 0.0, d.y) * r, n);
            }
        }
        sum / (m * m) as f32
    }

    #[test]
    fn polygon_irradiance_matches_the_small_light_limit() {
        // Far below a small light: E ≈ Le A cos θ cos θ' / d².
        let light = [
            Vec3::new(-0.01, 5.0, -0.01),
            Vec3::new(0.01, 5.0, -0.01),
            Vec3::new(0.01, 5.0, 0.01),
            Vec3::new(-0.01, 5.0, 0.01),
        ];
        let x = Vec3::new(1.0, 0.0, 2.0);
        let d = Vec3::new(0.0, 5.0, 0.0) - x;
        let cos = 5.0 / d.length();
        let approx = 0.0004 * cos * cos / d.length_squared();
        let exact = polygon_irradiance(&light, Vec3::ONE, x, Vec3::Y).x;
        assert!((exact / approx - 1.0).abs() < 1e-3, "{exact} vs {approx}");
    }

    #[test]
    fn fixed_radius_irradiance_matches_the_analytic_value() {
        let le = Vec3::new(10.0, 5.0, 2.0);
        let (scene, lights) = floor_under_light(le, None);
        let params = TraceParams {
            photons: 1_000_000,
            ..TraceParams::default()
        };
        let traced = trace_photons(&scene, &params, 3);
        let map = PhotonMap::build(traced.global);
        // Every photon carries Φ / N; RGBE rounds it the same way for all of them.
        let d_phi = scene.total_power() / params.photons as f32;
        let rounding = Rgbe::encode(d_phi).decode() / d_phi;
        let r = 0.15;
        let est = EstimateParams {
            nearest: usize::MAX,
            max_radius: r,
            ..EstimateParams::default()
        };
        for x in [
            Vec3::ZERO,
            Vec3::new(0.5, 0.0, 0.2),
            Vec3::new(-0.3, 0.0, -0.8),
            Vec3::new(1.0, 0.0, 0.6),
        ] {
            let e = map.irradiance(x, Vec3::Y, &est);
            let want = disc_average(&lights[0], le, x, Vec3::Y, r) * rounding;
            // The photon count in the disc is binomial: relative σ ≤ 1/√(expected count).
            let expected_count = want.x * PI * r * r / (d_phi.x * rounding.x);
            let tol = 4.0 / expected_count.sqrt();
            assert_eq!(e.radius, r);
            assert!(
                ((e.value / want) - Vec3::ONE).abs().max_element() < tol,
                "at {x}: {} vs {want} (count {}, expected {expected_count}, tol {tol})",
                e.value,
                e.photons
            );
            // The same photons with the cone filter: same value up to the filter's smoothing.
            let cone = map.irradiance(
                x,
                Vec3::Y,
                &EstimateParams {
                    filter: Filter::Cone { k: 1.1 },
                    ..est.clone()
                },
            );
            assert!(
                ((cone.value / want) - Vec3::ONE).abs().max_element() < 2.0 * tol,
                "cone at {x}"
            );
            // A Lambertian radiance estimate is ρ/π times the irradiance, with no extra cosine.
            let rho = Vec3::new(0.5, 0.25, 0.8);
            let l = map.radiance(x, Vec3::Y, &est, |_| rho / PI);
            assert!((l.value - rho / PI * e.value).abs().max_element() <= 1e-3 * e.value.max_element());
        }
    }

    #[test]
    fn k_nearest_irradiance_matches_the_analytic_value() {
        let le = Vec3::splat(8.0);
        let (scene, lights) = floor_under_light(le, None);
        let traced = trace_photons(
            &scene,
            &TraceParams {
                photons: 400_000,
                ..TraceParams::default()
            },
            4,
        );
        let map = PhotonMap::build(traced.global);
        let k = 400;
        let est = EstimateParams {
            nearest: k,
            ..EstimateParams::default()
        };
        for x in [Vec3::ZERO, Vec3::new(0.5, 0.0, 0.2)] {
            let e = map.irradiance(x, Vec3::Y, &est);
            assert_eq!(e.photons, k);
            let want = polygon_irradiance(&lights[0], le, x, Vec3::Y);
            // Relative σ of an N-nearest estimate ≈ 1/√N.
            let tol = 4.0 / (k as f32).sqrt();
            assert!(
                ((e.value / want) - Vec3::ONE).abs().max_element() < tol,
                "at {x}: {} vs {want}",
                e.value
            );
        }
    }

    /// mitsuba#145: photons on the back of a two-sided sheet must neither count nor shrink the
    /// search radius. A sheet lit from above and (4× brighter) from below: each side's estimate
    /// must match its own light.
    #[test]
    fn back_side_photons_neither_count_nor_shrink_the_radius() {
        let (le_top, le_bottom) = (Vec3::splat(5.0), Vec3::splat(20.0));
        let (scene, lights) = floor_under_light(le_top, Some(le_bottom));
        let traced = trace_photons(
            &scene,
            &TraceParams {
                photons: 500_000,
                ..TraceParams::default()
            },
            5,
        );
        let map = PhotonMap::build(traced.global);
        let k = 200;
        let est = EstimateParams {
            nearest: k,
            ..EstimateParams::default()
        };
        let tol = 4.0 / (k as f32).sqrt();
        for x in [Vec3::ZERO, Vec3::new(0.3, 0.0, -0.2)] {
            let top = map.irradiance(x, Vec3::Y, &est);
            let bottom = map.irradiance(x, -Vec3::Y, &est);
            let want_top = polygon_irradiance(&lights[0], le_top, x, Vec3::Y);
            let want_bottom = polygon_irradiance(&lights[1], le_bottom, x, -Vec3::Y);
            assert!(
                (top.value.x / want_top.x - 1.0).abs() < tol,
                "top {} vs {want_top}",
                top.value
            );
            assert!(
                (bottom.value.x / want_bottom.x - 1.0).abs() < tol,
                "bottom {} vs {want_bottom}",
                bottom.value
            );
            // The bottom side is 4× as dense: its radius is about half the top one.
            assert!(
                (top.radius / bottom.radius - 2.0).abs() < 0.4,
                "{} {}",
                top.radius,
                bottom.radius
            );
        }
    }

    #[test]
    fn empty_map_and_fewer_photons_than_requested() {
        let empty = PhotonMap::build(Vec::new());
        let e = empty.irradiance(Vec3::ZERO, Vec3::Y, &EstimateParams::default());
        assert_eq!((e.value, e.photons, e.radius), (Vec3::ZERO, 0, 0.0));
        // Three photons of power 1 in a disc of radius 2 searched for 50: r = max_radius.
        let photons: Vec<Photon> = [0.0f32, 0.5, 1.0]
            .iter()
            .map(|&x| Photon::new(Vec3::new(x, 0.0, 0.0), Vec3::ONE, Vec3::Y, Vec3::Y, 0))
            .collect();
        let map = PhotonMap::build(photons);
        let est = EstimateParams {
            max_radius: 2.0,
            ..EstimateParams::default()
        };
        let e = map.irradiance(Vec3::ZERO, Vec3::Y, &est);
        assert_eq!((e.photons, e.radius), (3, 2.0));
        assert!((e.value.x - 3.0 / (PI * 4.0)).abs() < 1e-6);
        // With N = 2 the radius is the second photon's distance.
        let e = map.irradiance(
            Vec3::ZERO,
            Vec3::Y,
            &EstimateParams {
                nearest: 2,
                ..est.clone()
            },
        );
        assert_eq!((e.photons, e.radius), (2, 0.5));
        // Photons arriving from below the query normal or with a disagreeing normal are skipped.
        assert_eq!(map.irradiance(Vec3::ZERO, -Vec3::Y, &est).photons, 0);
        assert_eq!(map.irradiance(Vec3::ZERO, Vec3::X, &est).photons, 0);
    }

    #[test]
    fn cone_filter_integrates_to_one_over_the_disc() {
        // Photons of equal power on a fine jittered grid: the cone-filtered density must equal
        // the box-filtered one (the normalisation 1 − 2/(3k) makes the kernel integrate to 1).
        let mut rng = Rng::for_task(11, [0, 0, 0]);
        let m = 400;
        let photons: Vec<Photon> = (0..m * m)
            .map(|i| {
                let (a, b) = ((i % m) as f32, (i / m) as f32);
                let p = (Vec2::new(a, b) + rng.uniform2()) / m as f32 * 2.0 - Vec2::ONE;
                Photon::new(Vec3::new(p.x, 0.0, p.y), Vec3::ONE, Vec3::Y, Vec3::Y, 0)
            })
            .collect();
        let map = PhotonMap::build(photons);
        let density = (m * m) as f32 / 4.0;
        for k in [1.0f32, 1.1, 2.0] {
            let est = EstimateParams {
                nearest: usize::MAX,
                max_radius: 0.3,
                filter: Filter::Cone { k },
                ..EstimateParams::default()
            };
            let e = map.irradiance(Vec3::ZERO, Vec3::Y, &est);
            assert!(
                (e.value.x / density - 1.0).abs() < 0.01,
                "k {k}: {}",
                e.value.x / density
            );
        }
    }

    #[test]
    fn estimate_params_validate_and_parse() {
        assert!(EstimateParams::default().validate().is_ok());
        for bad in [
            EstimateParams {
                nearest: 0,
                ..EstimateParams::default()
            },
            EstimateParams {
                max_radius: 0.0,
                ..EstimateParams::default()
            },
            EstimateParams {
                max_radius: f32::NAN,
                ..EstimateParams::default()
            },
            EstimateParams {
                normal_dot: 1.5,
                ..EstimateParams::default()
            },
            EstimateParams {
                filter: Filter::Cone { k: 0.5 },
                ..EstimateParams::default()
            },
        ] {
            assert!(bad.validate().is_err(), "{bad:?}");
        }
        let p: EstimateParams = toml::from_str("nearest = 80\nfilter = { kind = \"cone\", k = 1.1 }").unwrap();
        assert_eq!((p.nearest, p.filter), (80, Filter::Cone { k: 1.1 }));
        assert!(toml::from_str::<EstimateParams>("neighbours = 80").is_err());
    }
}
