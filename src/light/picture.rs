//! Importance sampling of a picture over the unit square of (u, v): where a projector sends
//! its photons ([`super::projector`]).
//!
//! A bitmap read without a `to_uv` map is cut into cells on which it is bounded by a few texels,
//! and a cell is chosen in proportion to that bound × its area, then a point uniformly in it:
//! - nearest-texel lookup: the texels themselves, each constant;
//! - bilinear lookup: the cells between texel centres (the half cells along the border
//!   included), on which the interpolant lies between its four corner texels (after wrapping),
//!   so the largest channel of the largest corner bounds every channel there.
//!
//! Every point where the picture is non-zero has a positive density, so the estimates are
//! unbiased whatever the weights; the bound only decides how well they follow the picture.
//! Any other picture (a checkerboard, a bitmap behind a `to_uv` map) is sampled uniformly.

use crate::sampling::Distribution1D;
use crate::texture::{Bitmap, Filter, Texture, UvTransform};
use glam::Vec2;

/// A density over [0, 1]² that covers a picture (module doc).
#[derive(Clone, Debug)]
pub enum PictureSampler {
    Uniform,
    Cells(Cells),
}

/// Rectangular cells between `us` × `vs` edges, chosen by `cells` (row-major, u fastest).
#[derive(Clone, Debug)]
pub struct Cells {
    us: Vec<f32>,
    vs: Vec<f32>,
    cells: Distribution1D,
}

impl PictureSampler {
    /// The sampler for `picture` (uniform when there is none, when it is not a plain bitmap, or
    /// when it is black everywhere).
    pub fn new(picture: Option<&Texture>) -> Self {
        match picture {
            Some(Texture::Bitmap(b)) if b.to_uv == UvTransform::default() => {
                Cells::of_bitmap(b).map_or(Self::Uniform, Self::Cells)
            }
            _ => Self::Uniform,
        }
    }

    /// A point of [0, 1]² drawn with `u`, and its density per unit area.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec2, f32) {
        match self {
            Self::Uniform => (u, 1.0),
            Self::Cells(c) => c.sample(u),
        }
    }

    /// The density per unit area at `uv` of [0, 1]² (0 outside).
    #[inline]
    pub fn pdf(&self, uv: Vec2) -> f32 {
        if !(0.0..=1.0).contains(&uv.x) || !(0.0..=1.0).contains(&uv.y) {
            return 0.0;
        }
        match self {
            Self::Uniform => 1.0,
            Self::Cells(c) => c.pdf(uv),
        }
    }
}

impl Cells {
    /// `None` when the bitmap is black (no cell has weight).
    fn of_bitmap(b: &Bitmap) -> Option<Self> {
        let (w, h) = (b.width as usize, b.height as usize);
        let (us, vs, corners): (Vec<f32>, Vec<f32>, &[i64]) = match b.filter {
            Filter::Nearest => (
                (0..=w).map(|i| i as f32 / w as f32).collect(),
                (0..=h).map(|j| j as f32 / h as f32).collect(),
                &[0],
            ),
            Filter::Bilinear => (centre_edges(w), centre_edges(h), &[-1, 0]),
        };
        let (nu, nv) = (us.len() - 1, vs.len() - 1);
        let mut weights = Vec::with_capacity(nu * nv);
        for j in 0..nv {
            for i in 0..nu {
                let mut bound = 0.0f32;
                for &dy in corners {
                    for &dx in corners {
                        bound = bound.max(b.texel(i as f32 + dx as f32, j as f32 + dy as f32).max_element());
                    }
                }
                weights.push(bound * (us[i + 1] - us[i]) * (vs[j + 1] - vs[j]));
            }
        }
        let cells = Distribution1D::new(&weights)?;
        Some(Self { us, vs, cells })
    }

    #[inline]
    fn sample(&self, u: Vec2) -> (Vec2, f32) {
        let nu = self.us.len() - 1;
        let (cell, pmf, u_rest) = self.cells.sample(u.x);
        let (i, j) = (cell % nu, cell / nu);
        let (u0, u1, v0, v1) = (self.us[i], self.us[i + 1], self.vs[j], self.vs[j + 1]);
        let uv = Vec2::new(u0 + u_rest * (u1 - u0), v0 + u.y * (v1 - v0));
        (uv.clamp(Vec2::ZERO, Vec2::ONE), pmf / ((u1 - u0) * (v1 - v0)))
    }

    #[inline]
    fn pdf(&self, uv: Vec2) -> f32 {
        let cell_of = |edges: &[f32], x: f32| edges.partition_point(|&e| e <= x).clamp(1, edges.len() - 1) - 1;
        let (i, j) = (cell_of(&self.us, uv.x), cell_of(&self.vs, uv.y));
        let area = (self.us[i + 1] - self.us[i]) * (self.vs[j + 1] - self.vs[j]);
        self.cells.pmf(j * (self.us.len() - 1) + i) / area
    }
}

/// The edges of the cells between the centres of `n` texels on [0, 1]: 0, ½/n, 1½/n, …,
/// (n − ½)/n, 1 (n + 1 cells, the first and last half as wide).
fn centre_edges(n: usize) -> Vec<f32> {
    let mut edges = Vec::with_capacity(n + 2);
    edges.push(0.0);
    edges.extend((0..n).map(|i| (i as f32 + 0.5) / n as f32));
    edges.push(1.0);
    edges
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;
    use crate::sampling::chi2::{CHI2_ALPHA, chi2_statistic};
    use crate::texture::Wrap;
    use glam::Vec3;

    fn bitmap(filter: Filter, wrap: Wrap) -> Texture {
        // 5 × 3 texels, mostly dark, one bright texel on the border and a black row.
        let mut texels = vec![Vec3::splat(0.05); 15];
        texels[4] = Vec3::new(0.0, 3.0, 0.5);
        texels[7] = Vec3::splat(1.0);
        for t in &mut texels[10..] {
            *t = Vec3::ZERO;
        }
        Texture::Bitmap(Bitmap {
            width: 5,
            height: 3,
            texels: texels.into(),
            filter,
            wrap,
            to_uv: UvTransform::default(),
        })
    }

    /// The mass the sampler puts in [a, b] × [c, d], from its cells' overlaps (exact).
    fn mass(c: &Cells, (a, b): (f32, f32), (cl, d): (f32, f32)) -> f64 {
        let nu = c.us.len() - 1;
        let mut m = 0.0;
        for j in 0..c.vs.len() - 1 {
            for i in 0..nu {
                let ou = (b.min(c.us[i + 1]) - a.max(c.us[i])).max(0.0) as f64;
                let ov = (d.min(c.vs[j + 1]) - cl.max(c.vs[j])).max(0.0) as f64;
                let area = ((c.us[i + 1] - c.us[i]) * (c.vs[j + 1] - c.vs[j])) as f64;
                m += c.cells.pmf(j * nu + i) as f64 * ou * ov / area;
            }
        }
        m
    }

    /// χ² of the points drawn against the density, on a 20 × 12 grid that cuts across the
    /// cells; each point's reported density is the density at it, and the picture is non-zero
    /// only where the density is positive.
    #[test]
    fn picture_samples_follow_their_density_and_cover_the_picture() {
        for (filter, wrap) in [
            (Filter::Nearest, Wrap::Clamp),
            (Filter::Bilinear, Wrap::Clamp),
            (Filter::Bilinear, Wrap::Repeat),
        ] {
            let picture = bitmap(filter, wrap);
            let PictureSampler::Cells(cells) = PictureSampler::new(Some(&picture)) else {
                panic!("a plain bitmap gets cells");
            };
            let sampler = PictureSampler::Cells(cells.clone());
            let (gu, gv, n) = (20usize, 12usize, 200_000usize);
            let mut observed = vec![0.0f64; gu * gv];
            let mut rng = Rng::for_task(11, [1, 2, 3]);
            for _ in 0..n {
                let (uv, pdf) = sampler.sample(rng.uniform2());
                assert!((0.0..=1.0).contains(&uv.x) && (0.0..=1.0).contains(&uv.y), "{uv}");
                assert!(
                    (pdf / sampler.pdf(uv) - 1.0).abs() < 1e-4,
                    "{filter:?} {wrap:?} at {uv}"
                );
                let (i, j) = (
                    ((uv.x * gu as f32) as usize).min(gu - 1),
                    ((uv.y * gv as f32) as usize).min(gv - 1),
                );
                observed[j * gu + i] += 1.0;
            }
            let expected: Vec<f64> = (0..gu * gv)
                .map(|k| {
                    let (i, j) = ((k % gu) as f32, (k / gu) as f32);
                    let (du, dv) = (1.0 / gu as f32, 1.0 / gv as f32);
                    n as f64 * mass(&cells, (i * du, (i + 1.0) * du), (j * dv, (j + 1.0) * dv))
                })
                .collect();
            let chi2 = chi2_statistic(&observed, &expected, 5.0);
            assert!(chi2.p_value > CHI2_ALPHA, "{filter:?} {wrap:?}: {chi2:?}");
            // Support: on a fine grid, a non-zero picture value has a positive density.
            for j in 0..=300 {
                for i in 0..=300 {
                    let uv = Vec2::new(i as f32 / 300.0, j as f32 / 300.0);
                    if picture.eval(uv).max_element() > 0.0 {
                        assert!(sampler.pdf(uv) > 0.0, "{filter:?} {wrap:?}: zero density at {uv}");
                    }
                }
            }
        }
    }

    #[test]
    fn other_pictures_are_sampled_uniformly() {
        let scaled = match bitmap(Filter::Bilinear, Wrap::Repeat) {
            Texture::Bitmap(b) => Texture::Bitmap(Bitmap {
                to_uv: UvTransform::scale_offset(Vec2::splat(2.0), Vec2::ZERO),
                ..b
            }),
            _ => unreachable!(),
        };
        for p in [None, Some(&scaled)] {
            let s = PictureSampler::new(p);
            assert!(matches!(s, PictureSampler::Uniform));
            assert_eq!(s.sample(Vec2::new(0.25, 0.5)), (Vec2::new(0.25, 0.5), 1.0));
            assert_eq!(s.pdf(Vec2::new(1.5, 0.5)), 0.0);
        }
    }
}
