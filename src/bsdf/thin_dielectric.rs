//! A thin dielectric sheet (a window pane, a soap film): two parallel interfaces so close that
//! light leaves where it entered, as Mitsuba 3's `thindielectric` models it. With R the Fresnel
//! reflectance of one interface at the incident angle, the light bouncing between the two
//! interfaces sums to the sheet's reflectance R' = R + (1 − R)² R / (1 − R²) = 2R / (1 + R),
//! and the rest, 1 − R', passes straight through without bending (wi = −wo).
//!
//! Both lobes are delta distributions: `sample` picks reflection with probability R' and
//! transmission otherwise, so the weight is the lobe's filter alone (`reflectance`,
//! `transmittance`, Mitsuba's `specular_reflectance` and `specular_transmittance`). Nothing
//! refracts, so importance and radiance are transported alike. The sheet is symmetric: the
//! same for `wo` on either side.

use super::{BsdfSample, fresnel_dielectric};
use glam::Vec3;

#[derive(Clone, Debug, PartialEq)]
pub struct ThinDielectric {
    /// Relative index of refraction of the sheet, > 0.
    pub ior: f32,
    /// Filter on reflected light per channel, in [0, 1].
    pub reflectance: Vec3,
    /// Filter on transmitted light per channel, in [0, 1].
    pub transmittance: Vec3,
}

impl ThinDielectric {
    /// The sheet's reflectance R' = 2R / (1 + R) at |cos θ| = `cos_theta`.
    pub fn sheet_reflectance(&self, cos_theta: f32) -> f32 {
        let r = fresnel_dielectric(cos_theta.abs(), self.ior);
        if r < 1.0 { 2.0 * r / (1.0 + r) } else { 1.0 }
    }

    /// Reflection with probability R', else straight transmission; f / pdf is the lobe's
    /// filter divided by |cos θi| (the delta convention of [`super::Bsdf::sample`]).
    pub fn sample(&self, wo: Vec3, u_lobe: f32) -> Option<BsdfSample> {
        let cos = wo.z.abs();
        if cos == 0.0 {
            return None;
        }
        let r = self.sheet_reflectance(cos);
        let (wi, filter, p) = if u_lobe < r {
            (Vec3::new(-wo.x, -wo.y, wo.z), self.reflectance, r)
        } else {
            (-wo, self.transmittance, 1.0 - r)
        };
        (p > 0.0).then(|| BsdfSample {
            wi,
            f: filter * p / cos,
            pdf_w: p,
            delta: true,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn pane(ior: f32) -> ThinDielectric {
        ThinDielectric {
            ior,
            reflectance: Vec3::new(0.9, 0.8, 0.7),
            transmittance: Vec3::new(0.6, 0.5, 0.4),
        }
    }

    /// The sheet reflectance is Mitsuba 3.9.1's: its `thindielectric` (int_ior 1.5, ext_ior 1)
    /// reflects with probability 0.1212277 at cos θ = 0.6 (`bsdf.sample`, `bs.pdf`); it is
    /// 2R/(1+R) of the single-interface Fresnel term, grows to 1 at grazing angles, and is the
    /// same from either side.
    #[test]
    fn sheet_reflectance_is_mitsubas() {
        let p = pane(1.5);
        assert!(
            (p.sheet_reflectance(0.6) - 0.121_227_7).abs() < 1e-6,
            "{}",
            p.sheet_reflectance(0.6)
        );
        let r = fresnel_dielectric(0.6, 1.5);
        assert!((p.sheet_reflectance(0.6) - 2.0 * r / (1.0 + r)).abs() < 1e-7);
        assert!(p.sheet_reflectance(1e-4) > 0.99);
        assert_eq!(p.sheet_reflectance(-0.6), p.sheet_reflectance(0.6));
    }

    /// Sampling: reflection about the normal with probability R', otherwise straight through,
    /// on both sides; the weight f |cos θi| / pdf is the lobe's filter.
    #[test]
    fn sampling_reflects_or_passes_straight_through_with_the_right_weights() {
        let p = pane(1.5);
        let mut rng = Rng::for_task(3, [0, 0, 0]);
        for wo in [Vec3::new(0.8, 0.0, 0.6), Vec3::new(-0.3, 0.4, -0.866_025_4).normalize()] {
            let r = p.sheet_reflectance(wo.z);
            let n = 100_000;
            let mut reflected = 0;
            for _ in 0..n {
                let s = p.sample(wo, rng.uniform()).unwrap();
                assert!(s.delta);
                let weight = s.f * s.wi.z.abs() / s.pdf_w;
                if s.wi == Vec3::new(-wo.x, -wo.y, wo.z) {
                    reflected += 1;
                    assert!((weight - p.reflectance).abs().max_element() < 1e-6, "{weight}");
                    assert_eq!(s.pdf_w, r);
                } else {
                    assert_eq!(s.wi, -wo);
                    assert!((weight - p.transmittance).abs().max_element() < 1e-6, "{weight}");
                    assert_eq!(s.pdf_w, 1.0 - r);
                }
            }
            let f = reflected as f64 / n as f64;
            let se = (r as f64 * (1.0 - r as f64) / n as f64).sqrt();
            assert!((f - r as f64).abs() < 5.0 * se, "wo {wo}: {f} vs {r}");
        }
        let bsdf = super::super::Bsdf::ThinDielectric(p);
        assert_eq!(
            bsdf.eval(Vec3::Z, -Vec3::Z, super::super::TransportMode::Radiance),
            Vec3::ZERO
        );
        assert_eq!(bsdf.pdf(Vec3::Z, -Vec3::Z), 0.0);
    }
}
