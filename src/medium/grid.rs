//! A 3-D texture over world space: Mitsuba 3's `gridvolume` plugin, which we read for the albedo
//! of a homogeneous medium.
//!
//! **File format** (Mitsuba's binary `.vol`, version 3, little endian, as `VolumeGrid::read`
//! reads it): the bytes `V`, `O`, `L`; a version byte (3); an `i32` encoding (1 = float32, the
//! only one Mitsuba supports); `i32` resolutions x, y, z; an `i32` channel count (we take 1 or 3,
//! the counts an albedo can use); six `f32` for a bounding box (xmin, ymin, zmin, xmax, ymax,
//! zmax); then x·y·z·channels `f32`, value (x, y, z, c) at `((z*yres + y)*xres + x)*channels + c`.
//!
//! **Placement.** The grid fills the unit cube [0, 1]³ of its local space, which `to_world` places
//! in the scene; the file's bounding box is ignored unless `use_grid_bbox` is set, in which case it
//! is mapped to the unit cube *after* the inverse of `to_world` (`m_to_local = bbox_transform() *
//! m_to_local` in `grid.cpp`). Outside the cube the wrap mode decides (default clamp, as Mitsuba).
//!
//! **Texel centres** sit at (i + ½)/res, Dr.Jit's `dr::Texture` convention and that of our 2-D
//! [`crate::texture::Bitmap`]: trilinear filtering reads `x = u·res − ½` and blends texels
//! ⌊x⌋ and ⌊x⌋ + 1; nearest filtering reads texel ⌊u·res⌋.

use std::sync::Arc;

use glam::{Affine3A, Vec3};

use crate::texture::{Filter, Wrap, wrap_index};

/// Bytes before the voxel data: magic, version, encoding, resolution, channels, bounding box.
const HEADER_LEN: usize = 48;
/// The most voxels a grid may hold (1 GiB of float32 per channel): a larger count in a header is
/// far more likely a corrupt file than a real albedo grid.
const MAX_VOXELS: u64 = 1 << 28;

/// A grid of values on the unit cube (Mitsuba's `gridvolume`).
#[derive(Clone, Debug, PartialEq)]
pub struct GridVolume {
    res: [u32; 3],
    channels: u32,
    /// Laid out as in the file; shared, since a scene may clone its media per thread.
    data: Arc<[f32]>,
    /// How values are read between voxel centres, and outside the unit cube; free to change.
    pub filter: Filter,
    pub wrap: Wrap,
    /// World space to the grid's unit cube (the inverse of `to_world`, then the bbox map).
    world_to_local: Affine3A,
    /// The smallest and largest value of any channel, kept because loaders and reports ask often.
    min: f32,
    max: f32,
}

impl GridVolume {
    /// Parses a `.vol` file's bytes; Err(message) says what is wrong (the caller adds the file name).
    /// The size is checked exactly, so a truncated download is refused rather than read as zeros.
    pub fn from_vol_bytes(
        bytes: &[u8],
        filter: Filter,
        wrap: Wrap,
        to_world: Affine3A,
        use_grid_bbox: bool,
    ) -> Result<Self, String> {
        if bytes.len() < HEADER_LEN {
            return Err(format!("too short for a VOL header: {} bytes", bytes.len()));
        }
        if &bytes[..3] != b"VOL" {
            return Err("not a VOL file: it does not start with the bytes 'V', 'O', 'L'".into());
        }
        if bytes[3] != 3 {
            return Err(format!("unsupported VOL version {} (only 3)", bytes[3]));
        }
        let i32_at = |o: usize| i32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
        let f32_at = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
        let encoding = i32_at(4);
        if encoding != 1 {
            return Err(format!("unsupported VOL encoding {encoding} (only 1 = float32)"));
        }
        let (rx, ry, rz, channels) = (i32_at(8), i32_at(12), i32_at(16), i32_at(20));
        if rx <= 0 || ry <= 0 || rz <= 0 {
            return Err(format!("invalid resolution {rx}x{ry}x{rz}"));
        }
        check_channels(channels as i64)?;
        let res = [rx as u32, ry as u32, rz as u32];
        let count = voxel_count(res)? * channels as usize;
        let expected = HEADER_LEN + 4 * count;
        if bytes.len() != expected {
            let what = format!("size mismatch: {rx}x{ry}x{rz} voxels of {channels} float32 channel(s)");
            return Err(format!("{what} need {expected} bytes, the file has {}", bytes.len()));
        }
        let (lo, hi) = (
            Vec3::new(f32_at(24), f32_at(28), f32_at(32)),
            Vec3::new(f32_at(36), f32_at(40), f32_at(44)),
        );
        let bbox_map = if use_grid_bbox {
            let extent = hi - lo;
            if !(lo.is_finite() && extent.is_finite() && extent.min_element() > 0.0) {
                return Err(format!("use_grid_bbox: degenerate bounding box {lo} .. {hi}"));
            }
            Affine3A::from_scale(extent.recip()) * Affine3A::from_translation(-lo)
        } else {
            Affine3A::IDENTITY
        };
        let data = (HEADER_LEN..bytes.len()).step_by(4).map(f32_at).collect();
        let mut grid = Self::new(res, channels as u32, data, filter, wrap, to_world)?;
        grid.world_to_local = bbox_map * grid.world_to_local;
        Ok(grid)
    }

    /// Builds one from values directly (tests; data laid out as in the file).
    pub fn new(
        res: [u32; 3],
        channels: u32,
        data: Vec<f32>,
        filter: Filter,
        wrap: Wrap,
        to_world: Affine3A,
    ) -> Result<Self, String> {
        check_channels(channels as i64)?;
        let expected = voxel_count(res)? * channels as usize;
        if data.len() != expected {
            return Err(format!("expected {expected} values, got {}", data.len()));
        }
        if let Some(k) = data.iter().position(|v| !v.is_finite()) {
            let (v, c, [nx, ny, _]) = (k / channels as usize, k % channels as usize, res.map(|r| r as usize));
            let (x, y, z) = (v % nx, v / nx % ny, v / (nx * ny));
            return Err(format!("non-finite value at voxel ({x}, {y}, {z}) channel {c}"));
        }
        let det = to_world.matrix3.determinant();
        let world_to_local = to_world.inverse();
        if !(to_world.is_finite() && det.is_finite() && det != 0.0 && world_to_local.is_finite()) {
            return Err(format!("to_world is singular or not finite (determinant {det})"));
        }
        let min = data.iter().copied().fold(f32::INFINITY, f32::min);
        let max = data.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        Ok(Self {
            res,
            channels,
            data: data.into(),
            filter,
            wrap,
            world_to_local,
            min,
            max,
        })
    }

    /// Writes the grid as a version-3 float32 `.vol` with the unit bounding box, so that reading it
    /// back with the same `to_world` (and either `use_grid_bbox`) places it where it was.
    pub fn to_vol_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(HEADER_LEN + 4 * self.data.len());
        out.extend_from_slice(b"VOL\x03");
        for v in [1, self.res[0], self.res[1], self.res[2], self.channels] {
            out.extend_from_slice(&(v as i32).to_le_bytes());
        }
        for v in [0.0f32, 0.0, 0.0, 1.0, 1.0, 1.0].iter().chain(self.data.iter()) {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out
    }

    /// The value at world point `p` (RGB; a 1-channel grid splats its value). As Mitsuba's RGB
    /// variants do, a 3-channel grid is returned as stored (no spectral upsampling to undo).
    pub fn eval(&self, p: Vec3) -> Vec3 {
        let res = Vec3::new(self.res[0] as f32, self.res[1] as f32, self.res[2] as f32);
        let local = self.world_to_local.transform_point3(p);
        if self.filter == Filter::Nearest {
            return self.texel((local * res).floor());
        }
        // Decision: snap coordinates within two ulps of an integer onto it. (i + ½)/res · res − ½
        // misses i by an ulp for some i and res; snapping makes texel centres return the stored
        // value exactly, and moves the weights elsewhere by less than float round-off.
        let g = local * res - 0.5;
        let r = g.round();
        let g = Vec3::select((g - r).abs().cmple(2.0 * f32::EPSILON * (g.abs() + 1.0)), r, g);
        let g0 = g.floor();
        // A NaN point (degenerate ray) reads texel 0 with weight 0 rather than poisoning the path.
        let f = Vec3::select((g - g0).is_finite_mask(), g - g0, Vec3::ZERO);
        let t = |dx: f32, dy: f32, dz: f32| self.texel(g0 + Vec3::new(dx, dy, dz));
        let row = |y: f32, z: f32| t(0., y, z).lerp(t(1., y, z), f.x);
        let slice = |z: f32| row(0., z).lerp(row(1., z), f.y);
        slice(0.).lerp(slice(1.), f.z)
    }

    /// The voxel at integer coordinates `i` (as floats, possibly outside the grid), after wrapping.
    fn texel(&self, i: Vec3) -> Vec3 {
        let [nx, ny, nz] = self.res;
        let w = |v: f32, n: u32| wrap_index(v, n, self.wrap);
        let k = ((w(i.z, nz) * ny as usize + w(i.y, ny)) * nx as usize + w(i.x, nx)) * self.channels as usize;
        // Channels k, k + c/2, k + c with c = channels − 1: r, g, b, or one value splatted.
        let c = self.channels as usize - 1;
        Vec3::new(self.data[k], self.data[k + c / 2], self.data[k + c])
    }

    /// The largest value of any channel (Mitsuba's `max()`): filtering never exceeds it.
    pub fn max(&self) -> f32 {
        self.max
    }

    /// The smallest value of any channel: filtering never goes below it (an albedo check).
    pub fn min(&self) -> f32 {
        self.min
    }

    /// Resolution (x, y, z) in voxels.
    pub fn resolution(&self) -> [u32; 3] {
        self.res
    }

    pub fn channels(&self) -> u32 {
        self.channels
    }

    /// The map from the grid's unit cube to world space: what an exporter writes as `to_world`
    /// next to [`GridVolume::to_vol_bytes`] (which writes the unit bounding box).
    pub fn to_world(&self) -> Affine3A {
        self.world_to_local.inverse()
    }
}

/// x·y·z, refused when zero or above [`MAX_VOXELS`].
fn voxel_count(res: [u32; 3]) -> Result<usize, String> {
    let n = res.iter().map(|&r| r as u64).product::<u64>();
    if n == 0 || n > MAX_VOXELS {
        return Err(format!("resolution {res:?} is empty or exceeds {MAX_VOXELS} voxels"));
    }
    Ok(n as usize)
}

fn check_channels(c: i64) -> Result<(), String> {
    if c == 1 || c == 3 {
        Ok(())
    } else {
        Err(format!("unsupported channel count {c} (only 1 or 3)"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::texture::{Filter::*, Wrap::*};

    const I: Affine3A = Affine3A::IDENTITY;

    /// Deterministic, irregular values (a Weyl sequence), so tests need no RNG.
    fn seq(n: usize, k: f32) -> Vec<f32> {
        (1..=n).map(|i| (i as f32 * k * 0.618_034).fract()).collect()
    }

    /// Irregular points in [0, 1)³.
    fn points(n: usize) -> impl Iterator<Item = Vec3> {
        (1..=n).map(|i| (Vec3::new(0.618_034, 0.754_878, 0.569_840) * i as f32).fract())
    }

    fn grid(res: [u32; 3], ch: u32, filter: Filter, wrap: Wrap) -> GridVolume {
        let n = (res[0] * res[1] * res[2] * ch) as usize;
        GridVolume::new(res, ch, seq(n, 1.0), filter, wrap, I).unwrap()
    }

    /// Voxel indices in file order (x fastest).
    fn voxels([nx, ny, nz]: [u32; 3]) -> impl Iterator<Item = [u32; 3]> {
        (0..nz).flat_map(move |z| (0..ny).flat_map(move |y| (0..nx).map(move |x| [x, y, z])))
    }

    fn centre(res: [u32; 3], i: [u32; 3]) -> Vec3 {
        (Vec3::from_array(i.map(|v| v as f32)) + 0.5) / Vec3::from_array(res.map(|v| v as f32))
    }

    fn diff(a: Vec3, b: Vec3) -> f32 {
        (a - b).abs().max_element()
    }

    #[test]
    fn round_trip_through_vol_bytes() {
        let to_world = Affine3A::from_translation(Vec3::new(1.0, -2.0, 0.5)) * Affine3A::from_scale(Vec3::splat(3.0));
        for ch in [1, 3] {
            let data = seq(5 * 3 * 4 * ch as usize, 0.7);
            let g = GridVolume::new([5, 3, 4], ch, data, Nearest, Mirror, to_world).unwrap();
            let back = GridVolume::from_vol_bytes(&g.to_vol_bytes(), Nearest, Mirror, to_world, true);
            assert_eq!(back.unwrap(), g);
        }
    }

    #[test]
    fn texel_centres_return_stored_values() {
        let res = [7, 11, 13];
        for (ch, filter) in [1, 3].into_iter().flat_map(|ch| [(ch, Bilinear), (ch, Nearest)]) {
            let g = grid(res, ch, filter, Clamp);
            for (k, i) in voxels(res).enumerate() {
                let v = &g.data[k * ch as usize..];
                let want = if ch == 1 {
                    Vec3::splat(v[0])
                } else {
                    Vec3::from_slice(v)
                };
                assert_eq!(g.eval(centre(res, i)), want, "{filter:?} ch {ch} at {i:?}");
            }
        }
    }

    #[test]
    fn trilinear_averages_and_reproduces_linear_functions() {
        let res = [4, 5, 6];
        let g = grid(res, 3, Bilinear, Clamp);
        let (a, b) = (centre(res, [1, 2, 3]), centre(res, [1, 3, 3]));
        assert!(diff(g.eval(0.5 * (a + b)), 0.5 * (g.eval(a) + g.eval(b))) < 1e-6);
        let f = |p: Vec3| Vec3::new(0.2 + p.x - 0.5 * p.y, 0.3 * p.z, 1.0 + 0.7 * p.x - 0.4 * p.z);
        let data = voxels(res).flat_map(|i| f(centre(res, i)).to_array()).collect();
        let g = GridVolume::new(res, 3, data, Bilinear, Clamp, I).unwrap();
        let (lo, hi) = (centre(res, [0, 0, 0]), centre(res, [3, 4, 5]));
        for p in points(500).map(|q| lo + q * (hi - lo)) {
            assert!(diff(g.eval(p), f(p)) < 1e-5, "at {p}");
        }
    }

    #[test]
    fn wrap_modes() {
        let res = [3, 4, 5];
        for filter in [Bilinear, Nearest] {
            let g = grid(res, 3, filter, Repeat);
            for (p, axis) in points(300).zip([Vec3::X, Vec3::Y, Vec3::Z].into_iter().cycle()) {
                for shift in [-2.0, 1.0, 3.0] {
                    assert!(diff(g.eval(p + shift * axis), g.eval(p)) < 1e-4, "{filter:?} at {p}");
                }
            }
            // Clamp: beyond the low x face and the high z face, the edge voxels' values.
            let g = grid(res, 1, filter, Clamp);
            for p in points(100) {
                let (out_lo, edge_lo) = (Vec3::new(-0.8 - p.x, p.y, p.z), Vec3::new(0.5 / 3.0, p.y, p.z));
                let (out_hi, edge_hi) = (Vec3::new(p.x, p.y, 1.5 + p.z), Vec3::new(p.x, p.y, 0.95));
                assert!(diff(g.eval(out_lo), g.eval(edge_lo)) < 1e-6, "{filter:?} at {out_lo}");
                assert!(diff(g.eval(out_hi), g.eval(edge_hi)) < 1e-6, "{filter:?} at {out_hi}");
            }
        }
        let g = grid(res, 3, Nearest, Mirror);
        for p in points(300).map(|q| q * 3.0 - 1.0) {
            assert_eq!(g.eval(-p), g.eval(p), "at {p}");
        }
    }

    #[test]
    fn to_world_places_the_cube() {
        let to_world = Affine3A::from_translation(Vec3::new(3.0, -1.0, 0.25)) * Affine3A::from_scale(Vec3::splat(2.0));
        let unit = grid([4, 4, 3], 3, Bilinear, Clamp);
        let placed = GridVolume::new([4, 4, 3], 3, unit.data.to_vec(), Bilinear, Clamp, to_world).unwrap();
        for q in points(200).map(|q| q * 1.4 - 0.2) {
            let world = to_world.transform_point3(q);
            assert!(diff(placed.eval(world), unit.eval(q)) < 1e-5, "at {q}");
        }
        assert!(diff(placed.to_world().transform_point3(Vec3::ONE), Vec3::new(5.0, 1.0, 2.25)) < 1e-6);
        assert!(GridVolume::new([1, 1, 1], 1, vec![0.5], Nearest, Clamp, Affine3A::ZERO).is_err());
    }

    #[test]
    fn malformed_files_are_refused() {
        let good = grid([2, 3, 4], 3, Nearest, Clamp).to_vol_bytes();
        let parse = |b: &[u8]| GridVolume::from_vol_bytes(b, Nearest, Clamp, I, false);
        assert!(parse(&good).is_ok());
        let with = |o: usize, v: &[u8]| [&good[..o], v, &good[o + v.len()..]].concat();
        let expect = |b: &[u8], needle: &str| {
            let e = parse(b).unwrap_err();
            assert!(e.contains(needle), "{e:?} lacks {needle:?}");
        };
        expect(&with(0, b"VOX"), "not a VOL file");
        expect(&with(3, &[2]), "version 2");
        expect(&with(4, &2i32.to_le_bytes()), "encoding 2");
        expect(&with(20, &2i32.to_le_bytes()), "channel count 2");
        expect(&with(8, &0i32.to_le_bytes()), "resolution");
        expect(&with(8, &(1i32 << 27).to_le_bytes()), "exceeds");
        let n = good.len();
        expect(&good[..n - 4], &format!("need {n} bytes, the file has {}", n - 4));
        let long = [&good[..], &[0; 4]].concat();
        expect(&long, &format!("need {n} bytes, the file has {}", n + 4));
        expect(&good[..20], "too short");
        // Voxel (1, 2, 3) channel 2 of the 2x3x4 grid.
        let nan_at = HEADER_LEN + 4 * (((3 * 3 + 2) * 2 + 1) * 3 + 2);
        expect(&with(nan_at, &f32::NAN.to_le_bytes()), "(1, 2, 3) channel 2");
        let flat_box = GridVolume::from_vol_bytes(&with(36, &[0; 4]), Nearest, Clamp, I, true);
        assert!(flat_box.unwrap_err().contains("bounding box"));
    }

    #[test]
    fn use_grid_bbox_maps_the_box_to_the_unit_cube_after_to_local() {
        let g = grid([3, 2, 4], 3, Bilinear, Clamp);
        let mut bytes = g.to_vol_bytes();
        for (k, v) in [-1.0f32, 0.0, 2.0, 3.0, 0.5, 6.0].into_iter().enumerate() {
            bytes[24 + 4 * k..28 + 4 * k].copy_from_slice(&v.to_le_bytes());
        }
        let to_world = Affine3A::from_scale(Vec3::splat(10.0));
        let boxed = GridVolume::from_vol_bytes(&bytes, g.filter, g.wrap, to_world, true).unwrap();
        for q in points(100) {
            let in_box = Vec3::new(-1.0, 0.0, 2.0) + q * Vec3::new(4.0, 0.5, 4.0);
            assert!(diff(boxed.eval(10.0 * in_box), g.eval(q)) < 1e-5, "at {q}");
        }
    }

    #[test]
    fn mitsuba_albedo_file() {
        let Ok(bytes) = std::fs::read("/tmp/mdata/docs/scenes/textures/albedo.vol") else {
            return;
        };
        let g = GridVolume::from_vol_bytes(&bytes, Bilinear, Clamp, I, false).unwrap();
        assert_eq!((g.resolution(), g.channels()), ([16, 16, 16], 3));
        let raw: Vec<_> = bytes[HEADER_LEN..]
            .chunks(4)
            .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
            .collect();
        assert_eq!(g.max(), raw.iter().copied().fold(f32::NEG_INFINITY, f32::max));
        assert!(raw.iter().all(|v| (0.0..=1.0).contains(v)) && g.min() >= 0.0);
        for (p, v) in points(100).map(|p| (p, g.eval(p))) {
            assert!(v.min_element() >= g.min() && v.max_element() <= g.max(), "{v} at {p}");
        }
    }
}
