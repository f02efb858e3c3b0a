//! The compact photon record: 24 bytes with the precomputed irradiance and the surface normal
//! (Christensen 1999 §2.1 packs the same information into 23 bytes, pbrt-v2 uses 49).
//!
//! | bytes | field | encoding |
//! |---|---|---|
//! | 0..12 | position | 3 × `f32` |
//! | 12..16 | power ΔΦ | [`Rgbe`], Ward's shared exponent [Ward 1991] |
//! | 16..20 | precomputed irradiance E | [`Rgbe`] [Christensen 1999, §2.1] |
//! | 20..22 | incoming direction ω_p | 16-bit octahedral map (8 + 8 bits) |
//! | 22..24 | surface normal and flags | 12-bit octahedral map (6 + 6 bits) + 4 flag bits |
//!
//! Christensen spends 1 byte on the direction and 1 on the normal. We spend 2 and 1.5: the
//! direction drives Jensen 1995's guided pdf, whose 4 × 16 grid needs better than the ~10°
//! a byte gives, and the normal test (dot > 0.9, i.e. 25.8°) wants an error well below that.
//!
//! Error bounds (each tested in this file):
//! - RGBE: every channel is off by at most max(r, g, b) / 256 (half a quantum of the shared
//!   exponent), so the largest channel has relative error ≤ 1/256 ≈ 0.39 %; zero stays zero.
//! - direction (16-bit octahedral, best of the 4 neighbouring codes): ≤ 0.7° (measured
//!   maximum over 10⁶ random directions: 0.64°); axis directions are exact.
//! - normal (12-bit octahedral, same scheme): ≤ 3° (measured maximum 2.6°); axis normals are
//!   exact, so the walls of box scenes pass any normal test exactly.

use glam::{Vec2, Vec3};

/// An RGB triple packed as Ward's RGBE: three 8-bit mantissas sharing one 8-bit exponent
/// [Ward 1991, "Real Pixels", Graphics Gems II].
///
/// Unlike Ward's original (truncate on encode, add ½ on decode) this version rounds to the
/// nearest quantum on encode and decodes without offset: the error bound is the same
/// (half a quantum), but a zero channel decodes to exactly zero, so a pure-red photon never
/// carries green power. Values are clamped to [0, 2¹²⁷); non-finite or negative channels
/// encode as 0.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(transparent)]
pub struct Rgbe(pub [u8; 4]);

impl Rgbe {
    /// Exponent bias of the fourth byte; the byte 0 encodes black.
    const BIAS: i32 = 128;

    /// Packs `c`, each channel to within max(c) / 256 (see the type's doc).
    pub fn encode(c: Vec3) -> Self {
        let clean = |x: f32| if x.is_finite() && x > 0.0 { x } else { 0.0 };
        let c = Vec3::new(clean(c.x), clean(c.y), clean(c.z));
        let m = c.max_element();
        // Below 2⁻¹²⁶ nothing is representable with the biased exponent ≥ 1 at 8-bit precision.
        if m < f32::MIN_POSITIVE {
            return Self([0; 4]);
        }
        // m = f · 2^e with f ∈ [0.5, 1): the quantum is 2^(e − 8), so m maps to [128, 256).
        let mut e = frexp_exponent(m).min(127);
        let mut q = quantise(c, e);
        if q.max_element() > 255.0 {
            // Rounding pushed the largest channel to 256: one exponent step up, now ≥ 128.
            e += 1;
            if e > 127 {
                return Self([255, 255, 255, 255]);
            }
            q = quantise(c, e);
        }
        let q = q.min(Vec3::splat(255.0));
        Self([q.x as u8, q.y as u8, q.z as u8, (e + Self::BIAS) as u8])
    }

    /// Unpacks the colour.
    pub fn decode(self) -> Vec3 {
        let [r, g, b, e] = self.0;
        if e == 0 {
            return Vec3::ZERO;
        }
        let quantum = exp2i(e as i32 - Self::BIAS - 8);
        Vec3::new(r as f32, g as f32, b as f32) * quantum
    }
}

/// The exponent e with x = f · 2^e, f ∈ [0.5, 1), for finite positive normal x.
#[inline]
fn frexp_exponent(x: f32) -> i32 {
    ((x.to_bits() >> 23) & 0xff) as i32 - 126
}

/// 2^k as an f32 for k in [−149, 127] (subnormals included), exactly.
#[inline]
fn exp2i(k: i32) -> f32 {
    if k >= -126 {
        f32::from_bits(((k + 127) as u32) << 23)
    } else {
        f32::from_bits(1u32 << (k + 149).max(0))
    }
}

#[inline]
fn quantise(c: Vec3, e: i32) -> Vec3 {
    // Scale by 2^(8 − e) in two steps so that neither factor overflows or underflows.
    let k = 8 - e;
    let (k1, k2) = (k / 2, k - k / 2);
    (c * exp2i(k1) * exp2i(k2)).round()
}

/// Maps a unit vector to the octahedron's square [−1, 1]² [Meyer et al. 2010; Cigolle et al.
/// 2014, "A Survey of Efficient Representations for Independent Unit Vectors"].
#[inline]
fn oct_project(v: Vec3) -> Vec2 {
    let l1 = v.x.abs() + v.y.abs() + v.z.abs();
    let p = Vec2::new(v.x, v.y) / l1;
    if v.z >= 0.0 {
        p
    } else {
        // Fold the lower half over the diagonals.
        let sign = Vec2::new(1.0f32.copysign(p.x), 1.0f32.copysign(p.y));
        (Vec2::ONE - Vec2::new(p.y.abs(), p.x.abs())) * sign
    }
}

/// Inverse of [`oct_project`]; the result is normalised.
#[inline]
fn oct_unproject(p: Vec2) -> Vec3 {
    let z = 1.0 - p.x.abs() - p.y.abs();
    let (x, y) = if z >= 0.0 {
        (p.x, p.y)
    } else {
        (
            (1.0 - p.y.abs()) * 1.0f32.copysign(p.x),
            (1.0 - p.x.abs()) * 1.0f32.copysign(p.y),
        )
    };
    Vec3::new(x, y, z).normalize()
}

/// Decodes an octahedral code of `bits` bits per axis. Each axis uses the codes 0..=2^bits − 2
/// (one code unused), so that 0 is exactly representable: axis-aligned directions and normals
/// (the walls of every box scene) round-trip exactly.
#[inline]
fn oct_decode(code: u32, bits: u32) -> Vec3 {
    let max = ((1u32 << bits) - 2) as f32;
    let mask = (1u32 << bits) - 1;
    let u = (code & mask) as f32 / max * 2.0 - 1.0;
    let v = ((code >> bits) & mask) as f32 / max * 2.0 - 1.0;
    oct_unproject(Vec2::new(u, v))
}

/// Encodes unit `v` with `bits` bits per axis, choosing among the four codes around the
/// projection the one whose decoded direction is closest to `v` ("precise" octahedral
/// encoding, Cigolle et al. 2014 §3): it roughly halves the worst error of plain rounding.
/// Zero or non-finite vectors encode +z.
fn oct_encode(v: Vec3, bits: u32) -> u32 {
    let v = v.normalize_or_zero();
    let v = if v == Vec3::ZERO { Vec3::Z } else { v };
    let max = ((1u32 << bits) - 2) as f32;
    let p = (oct_project(v) * 0.5 + Vec2::splat(0.5)) * max;
    let (fx, fy) = (p.x.floor().clamp(0.0, max), p.y.floor().clamp(0.0, max));
    let mut best = (f32::NEG_INFINITY, 0u32);
    for (dx, dy) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
        let (cx, cy) = ((fx + dx).min(max) as u32, (fy + dy).min(max) as u32);
        let code = cx | (cy << bits);
        let cos = oct_decode(code, bits).dot(v);
        if cos > best.0 {
            best = (cos, code);
        }
    }
    best.1
}

/// Flag bits of a [`Photon`] (the top 4 bits of its normal word).
pub mod flags {
    /// The photon's path is L S+ D: it is (also) a caustic photon [Jensen 1996].
    pub const CAUSTIC: u8 = 1;
    /// The photon scattered at least once before landing here (bounce count ≥ 1): Jensen 1995
    /// stores only these.
    pub const INDIRECT: u8 = 2;
    /// The record holds a precomputed irradiance [Christensen 1999, §2.1].
    pub const IRRADIANCE: u8 = 4;
}

const NORMAL_BITS: u32 = 6;

/// Every direction and normal code decoded once (768 kB and 48 kB, built on first use):
/// [`Photon::direction`] and [`Photon::normal`] are read for every candidate of every density
/// estimate, irradiance lookup and guiding grid, and a table read costs a fraction of
/// [`oct_decode`]'s two divisions and normalisation (issue 21: Jensen's grid builds 1.19×,
/// precomputed final gathers 1.08×). Immutable, and the same values bit for bit: a memo of a
/// pure function, not state.
static DIRECTIONS: std::sync::LazyLock<Vec<Vec3>> =
    std::sync::LazyLock::new(|| (0..1u32 << 16).map(|c| oct_decode(c, 8)).collect());
static NORMALS: std::sync::LazyLock<Vec<Vec3>> = std::sync::LazyLock::new(|| {
    (0..1u32 << (2 * NORMAL_BITS))
        .map(|c| oct_decode(c, NORMAL_BITS))
        .collect()
});
const NORMAL_MASK: u16 = (1 << (2 * NORMAL_BITS)) - 1;
const FLAG_SHIFT: u32 = 2 * NORMAL_BITS;

/// One stored photon; see the module doc for the layout and error bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Photon {
    /// Where the photon landed.
    pub position: [f32; 3],
    power: Rgbe,
    irradiance: Rgbe,
    direction: u16,
    normal_flags: u16,
}

impl Photon {
    /// Size of one record in bytes (asserted in the tests).
    pub const BYTES: usize = 24;

    /// A photon at `position` carrying `power` (ΔΦ, per channel), which arrived from unit
    /// direction `wi` (pointing away from the surface, toward where the photon came from) onto
    /// a surface with unit normal `n` (on the side the photon arrived from). `flags` is a
    /// combination of [`flags`] bits.
    pub fn new(position: Vec3, power: Vec3, wi: Vec3, n: Vec3, flags: u8) -> Self {
        Self {
            position: position.to_array(),
            power: Rgbe::encode(power),
            irradiance: Rgbe::default(),
            direction: oct_encode(wi, 8) as u16,
            normal_flags: oct_encode(n, NORMAL_BITS) as u16 | ((flags as u16 & 0xf) << FLAG_SHIFT),
        }
    }

    #[inline]
    pub fn position(&self) -> Vec3 {
        Vec3::from_array(self.position)
    }

    /// The photon's power ΔΦ_p.
    #[inline]
    pub fn power(&self) -> Vec3 {
        self.power.decode()
    }

    /// Unit direction the photon came from (pointing away from the surface).
    #[inline]
    pub fn direction(&self) -> Vec3 {
        DIRECTIONS[self.direction as usize]
    }

    /// Unit surface normal on the side the photon arrived from.
    #[inline]
    pub fn normal(&self) -> Vec3 {
        NORMALS[(self.normal_flags & NORMAL_MASK) as usize]
    }

    #[inline]
    pub fn flags(&self) -> u8 {
        (self.normal_flags >> FLAG_SHIFT) as u8
    }

    #[inline]
    pub fn is_caustic(&self) -> bool {
        self.flags() & flags::CAUSTIC != 0
    }

    #[inline]
    pub fn is_indirect(&self) -> bool {
        self.flags() & flags::INDIRECT != 0
    }

    /// The precomputed irradiance, if [`Photon::set_irradiance`] stored one.
    #[inline]
    pub fn irradiance(&self) -> Option<Vec3> {
        (self.flags() & flags::IRRADIANCE != 0).then(|| self.irradiance.decode())
    }

    /// The precomputed irradiance as stored (its RGBE code), black when there is none:
    /// `irradiance_code().decode()` is `irradiance().unwrap_or(Vec3::ZERO)` bit for bit.
    pub fn irradiance_code(&self) -> Rgbe {
        if self.flags() & flags::IRRADIANCE != 0 {
            self.irradiance
        } else {
            Rgbe::default()
        }
    }

    /// Stores a precomputed irradiance and sets [`flags::IRRADIANCE`].
    pub fn set_irradiance(&mut self, e: Vec3) {
        self.irradiance = Rgbe::encode(e);
        self.normal_flags |= (flags::IRRADIANCE as u16) << FLAG_SHIFT;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{Rng, sample_uniform_sphere};

    #[test]
    fn photon_record_is_24_bytes() {
        assert_eq!(std::mem::size_of::<Photon>(), Photon::BYTES);
        assert_eq!(Photon::BYTES, 24);
        assert_eq!(std::mem::align_of::<Photon>(), 4);
    }

    #[test]
    fn rgbe_error_is_at_most_half_a_quantum_of_the_largest_channel() {
        let mut rng = Rng::for_task(1, [0, 0, 0]);
        let mut worst = 0.0f32;
        for i in 0..200_000 {
            // Log-uniform magnitudes over 60 decades, random chroma, some zero channels.
            let scale = 10f32.powf(rng.uniform() * 60.0 - 30.0);
            let mut c = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * scale;
            if i % 7 == 0 {
                c.y = 0.0;
            }
            let d = Rgbe::encode(c).decode();
            let m = c.max_element();
            let err = (d - c).abs().max_element() / m;
            worst = worst.max(err);
            assert!(err <= 1.0 / 256.0 + 1e-6, "{c} -> {d}: {err}");
            if c.y == 0.0 {
                assert_eq!(d.y, 0.0, "zero stays zero");
            }
        }
        assert!(worst > 1.0 / 300.0, "the bound is tight: {worst}");
    }

    #[test]
    fn rgbe_handles_zero_exact_powers_and_rounding_carry() {
        assert_eq!(Rgbe::encode(Vec3::ZERO).decode(), Vec3::ZERO);
        assert_eq!(Rgbe::encode(Vec3::new(-1.0, f32::NAN, 0.0)).decode(), Vec3::ZERO);
        for k in -100..100 {
            let c = Vec3::new(1.0, 0.5, 0.25) * 2f32.powi(k);
            assert_eq!(Rgbe::encode(c).decode(), c, "powers of two are exact");
        }
        // 255.9 / 256 rounds up to the next exponent.
        let c = Vec3::splat(0.99999);
        assert!((Rgbe::encode(c).decode() - c).abs().max_element() <= 1.0 / 256.0);
        assert!(Rgbe::encode(Vec3::splat(f32::INFINITY)).decode() == Vec3::ZERO);
        assert!(Rgbe::encode(Vec3::splat(f32::MAX)).decode().x > 1e38);
    }

    fn angle_deg(a: Vec3, b: Vec3) -> f32 {
        a.dot(b).clamp(-1.0, 1.0).acos().to_degrees()
    }

    #[test]
    fn direction_and_normal_round_trip_within_their_angular_bounds() {
        let mut rng = Rng::for_task(2, [0, 0, 0]);
        let (mut worst_dir, mut worst_n) = (0.0f32, 0.0f32);
        let mut dirs: Vec<Vec3> = (0..1_000_000).map(|_| sample_uniform_sphere(rng.uniform2())).collect();
        // Axes and octant diagonals sit on the folds of the octahedral map.
        for x in [-1.0, 0.0, 1.0] {
            for y in [-1.0, 0.0, 1.0] {
                for z in [-1.0, 0.0, 1.0] {
                    let v = Vec3::new(x, y, z);
                    if v != Vec3::ZERO {
                        dirs.push(v.normalize());
                    }
                }
            }
        }
        for (i, &w) in dirs.iter().enumerate() {
            let n = dirs[(i * 7919) % dirs.len()];
            let p = Photon::new(Vec3::ZERO, Vec3::ONE, w, n, 0);
            worst_dir = worst_dir.max(angle_deg(p.direction(), w));
            worst_n = worst_n.max(angle_deg(p.normal(), n));
            assert!((p.direction().length() - 1.0).abs() < 1e-5);
        }
        assert!(worst_dir <= 0.7, "direction error {worst_dir}°");
        assert!(worst_n <= 3.0, "normal error {worst_n}°");
    }

    #[test]
    fn fields_and_flags_are_independent() {
        let pos = Vec3::new(0.1, -2.0, 3.5);
        let power = Vec3::new(0.2, 0.0, 1e-4);
        let wi = Vec3::new(0.3, 0.9, -0.1).normalize();
        let n = Vec3::new(0.0, 1.0, 0.0);
        for f in 0..8u8 {
            let mut p = Photon::new(pos, power, wi, n, f & (flags::CAUSTIC | flags::INDIRECT));
            assert_eq!(p.position(), pos);
            assert_eq!(p.is_caustic(), f & flags::CAUSTIC != 0);
            assert_eq!(p.is_indirect(), f & flags::INDIRECT != 0);
            assert_eq!(p.irradiance(), None);
            let before = (p.power(), p.direction(), p.normal());
            p.set_irradiance(Vec3::new(3.0, 2.0, 1.0));
            assert_eq!(p.irradiance(), Some(Vec3::new(3.0, 2.0, 1.0)));
            assert_eq!((p.power(), p.direction(), p.normal()), before);
            assert_eq!(p.is_caustic(), f & flags::CAUSTIC != 0);
            assert_eq!(p.normal(), n, "axis normals are exact");
            let q = Photon::new(pos, power, -Vec3::Z, Vec3::X, 0);
            assert_eq!((q.direction(), q.normal()), (-Vec3::Z, Vec3::X));
        }
    }
}
