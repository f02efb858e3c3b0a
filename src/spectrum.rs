//! Spectra to RGB as Mitsuba 3's RGB variants convert them, so that a Mitsuba scene written
//! with spectra renders the colours Mitsuba renders.
//!
//! A spectrum given as wavelength:value pairs is the piecewise-linear function through them,
//! zero outside its first and last wavelength. Its colour is the CIE 1931 XYZ integral by
//! Mitsuba's quadrature — 1000 equally spaced wavelengths from 360 to 830 nm, both included,
//! each weighted (830 − 360) / 1000 — of the spectrum times the colour-matching functions
//! (times the D65 illuminant for reflectances), scaled by 1 / 106.7502594 (Mitsuba's
//! `MI_CIE_Y_NORMALIZATION`), and turned into linear sRGB by the sRGB matrix (IEC 61966-2-1
//! as Mitsuba writes it). Mitsuba then clamps reflectances to [0, 1] (`bounded`); emitted
//! spectra are neither weighted by D65 nor clamped.
//!
//! **Data.** [`CIE_TABLE`] holds the CIE 1931 2° standard observer x̄, ȳ, z̄ and the CIE
//! standard illuminant D65 (relative spectral power, 100 at 560 nm) at 5 nm from 360 to
//! 830 nm (CIE 015:2018, Tables; the values Mitsuba 3 tabulates), read between samples by
//! linear interpolation as Mitsuba does. D65 enters scaled by 1 / 98.99741752 (Mitsuba's
//! `MI_CIE_D65_NORMALIZATION`).
//!
//! **Blackbody.** Mitsuba's RGB variants refuse to render a `blackbody` spectrum ("not
//! implemented for non-spectral modes"). We take the colour its spectral variants converge to
//! for an emitter seen directly: Planck's law in W·m⁻²·sr⁻¹·nm⁻¹ (Mitsuba's units, constants
//! of CODATA 2014 as Mitsuba uses them) converted as an emitted spectrum above.

use glam::DVec3;

/// First and last wavelength of the tables and of the quadrature, nm.
pub const CIE_MIN: f64 = 360.0;
pub const CIE_MAX: f64 = 830.0;
/// Points of the quadrature.
const STEPS: usize = 1000;
/// Mitsuba's `MI_CIE_Y_NORMALIZATION` = 1 / 106.7502594.
const Y_NORMALIZATION: f64 = 1.0 / 106.750_259_399_414_06;
/// Mitsuba's `MI_CIE_D65_NORMALIZATION` = 1 / 98.99741752.
const D65_NORMALIZATION: f64 = 1.0 / 98.997_417_518_762_55;

/// x̄, ȳ, z̄, D65 at 360, 365, …, 830 nm (see the module doc for the source).
#[rustfmt::skip]
pub const CIE_TABLE: [[f64; 4]; 95] = [
    [0.0001299, 3.917e-06, 0.0006061, 46.6383],
    [0.0002321, 6.965e-06, 0.001086, 49.3637],
    [0.0004149, 1.239e-05, 0.001946, 52.0891],
    [0.0007416, 2.202e-05, 0.003486, 51.0323],
    [0.001368, 3.9e-05, 0.006450001, 49.9755],
    [0.002236, 6.4e-05, 0.01054999, 52.3118],
    [0.004243, 0.00012, 0.02005001, 54.6482],
    [0.00765, 0.000217, 0.03621, 68.7015],
    [0.01431, 0.000396, 0.06785001, 82.7549],
    [0.02319, 0.00064, 0.1102, 87.1204],
    [0.04351, 0.00121, 0.2074, 91.486],
    [0.07763, 0.00218, 0.3713, 92.4589],
    [0.13438, 0.004, 0.6456, 93.4318],
    [0.21477, 0.0073, 1.03905, 90.057],
    [0.2839, 0.0116, 1.3856, 86.6823],
    [0.3285, 0.01684, 1.62296, 95.7736],
    [0.34828, 0.023, 1.74706, 104.865],
    [0.34806, 0.0298, 1.7826, 110.936],
    [0.3362, 0.038, 1.77211, 117.008],
    [0.3187, 0.048, 1.7441, 117.41],
    [0.2908, 0.06, 1.6692, 117.812],
    [0.2511, 0.0739, 1.5281, 116.336],
    [0.19536, 0.09098, 1.28764, 114.861],
    [0.1421, 0.1126, 1.0419, 115.392],
    [0.09564, 0.13902, 0.8129501, 115.923],
    [0.05795001, 0.1693, 0.6162, 112.367],
    [0.03201, 0.20802, 0.46518, 108.811],
    [0.0147, 0.2586, 0.3533, 109.082],
    [0.0049, 0.323, 0.272, 109.354],
    [0.0024, 0.4073, 0.2123, 108.578],
    [0.0093, 0.503, 0.1582, 107.802],
    [0.0291, 0.6082, 0.1117, 106.296],
    [0.06327, 0.71, 0.07824999, 104.79],
    [0.1096, 0.7932, 0.05725001, 106.239],
    [0.1655, 0.862, 0.04216, 107.689],
    [0.2257499, 0.9148501, 0.02984, 106.047],
    [0.2904, 0.954, 0.0203, 104.405],
    [0.3597, 0.9803, 0.0134, 104.225],
    [0.4334499, 0.9949501, 0.008749999, 104.046],
    [0.5120501, 1.0, 0.005749999, 102.023],
    [0.5945, 0.995, 0.0039, 100.0],
    [0.6784, 0.9786, 0.002749999, 98.1671],
    [0.7621, 0.952, 0.0021, 96.3342],
    [0.8425, 0.9154, 0.0018, 96.0611],
    [0.9163, 0.87, 0.001650001, 95.788],
    [0.9786, 0.8163, 0.0014, 92.2368],
    [1.0263, 0.757, 0.0011, 88.6856],
    [1.0567, 0.6949, 0.001, 89.3459],
    [1.0622, 0.631, 0.0008, 90.0062],
    [1.0456, 0.5668, 0.0006, 89.8026],
    [1.0026, 0.503, 0.00034, 89.5991],
    [0.9384, 0.4412, 0.00024, 88.6489],
    [0.8544499, 0.381, 0.00019, 87.6987],
    [0.7514, 0.321, 0.0001, 85.4936],
    [0.6424, 0.265, 4.999999e-05, 83.2886],
    [0.5419, 0.217, 3e-05, 83.4939],
    [0.4479, 0.175, 2e-05, 83.6992],
    [0.3608, 0.1382, 1e-05, 81.863],
    [0.2835, 0.107, 0.0, 80.0268],
    [0.2187, 0.0816, 0.0, 80.1207],
    [0.1649, 0.061, 0.0, 80.2146],
    [0.1212, 0.04458, 0.0, 81.2462],
    [0.0874, 0.032, 0.0, 82.2778],
    [0.0636, 0.0232, 0.0, 80.281],
    [0.04677, 0.017, 0.0, 78.2842],
    [0.0329, 0.01192, 0.0, 74.0027],
    [0.0227, 0.00821, 0.0, 69.7213],
    [0.01584, 0.005723, 0.0, 70.6652],
    [0.01135916, 0.004102, 0.0, 71.6091],
    [0.008110916, 0.002929, 0.0, 72.979],
    [0.005790346, 0.002091, 0.0, 74.349],
    [0.004109457, 0.001484, 0.0, 67.9765],
    [0.002899327, 0.001047, 0.0, 61.604],
    [0.00204919, 0.00074, 0.0, 65.7448],
    [0.001439971, 0.00052, 0.0, 69.8856],
    [0.0009999493, 0.0003611, 0.0, 72.4863],
    [0.0006900786, 0.0002492, 0.0, 75.087],
    [0.0004760213, 0.0001719, 0.0, 69.3398],
    [0.0003323011, 0.00012, 0.0, 63.5927],
    [0.0002348261, 8.48e-05, 0.0, 55.0054],
    [0.0001661505, 6e-05, 0.0, 46.4182],
    [0.000117413, 4.24e-05, 0.0, 56.6118],
    [8.307527e-05, 3e-05, 0.0, 66.8054],
    [5.870652e-05, 2.12e-05, 0.0, 65.0941],
    [4.150994e-05, 1.499e-05, 0.0, 63.3828],
    [2.935326e-05, 1.06e-05, 0.0, 63.8434],
    [2.067383e-05, 7.4657e-06, 0.0, 64.304],
    [1.455977e-05, 5.2578e-06, 0.0, 61.8779],
    [1.025398e-05, 3.7029e-06, 0.0, 59.4519],
    [7.221456e-06, 2.6078e-06, 0.0, 55.7054],
    [5.085868e-06, 1.8366e-06, 0.0, 51.959],
    [3.581652e-06, 1.2934e-06, 0.0, 54.6998],
    [2.522525e-06, 9.1093e-07, 0.0, 57.4406],
    [1.776509e-06, 6.4153e-07, 0.0, 58.8765],
    [1.251141e-06, 4.5181e-07, 0.0, 60.3125]
];

/// x̄ȳz̄ and D65 at `lambda` nm, linearly interpolated; zero outside [360, 830].
fn cie_at(lambda: f64) -> (DVec3, f64) {
    if !(CIE_MIN..=CIE_MAX).contains(&lambda) {
        return (DVec3::ZERO, 0.0);
    }
    let x = (lambda - CIE_MIN) / 5.0;
    let i = (x as usize).min(CIE_TABLE.len() - 2);
    let t = x - i as f64;
    let lerp = |k: usize| CIE_TABLE[i][k] * (1.0 - t) + CIE_TABLE[i + 1][k] * t;
    (DVec3::new(lerp(0), lerp(1), lerp(2)), lerp(3))
}

/// CIE XYZ to linear sRGB (D65 white), the matrix of IEC 61966-2-1 with Mitsuba's digits.
pub fn xyz_to_srgb(xyz: DVec3) -> DVec3 {
    DVec3::new(
        3.240479 * xyz.x - 1.537150 * xyz.y - 0.498535 * xyz.z,
        -0.969256 * xyz.x + 1.875991 * xyz.y + 0.041556 * xyz.z,
        0.055648 * xyz.x - 0.204043 * xyz.y + 1.057311 * xyz.z,
    )
}

/// The XYZ integral of `spectrum(λ)` by Mitsuba's quadrature (D65-weighted when `d65`),
/// normalised so that ȳ integrates to 1.
fn integrate_xyz(spectrum: impl Fn(f64) -> Option<f64>, d65: bool) -> DVec3 {
    let mut xyz = DVec3::ZERO;
    for i in 0..STEPS {
        let lambda = CIE_MIN + (i as f64 / (STEPS - 1) as f64) * (CIE_MAX - CIE_MIN);
        let Some(v) = spectrum(lambda) else { continue };
        let (cmf, illuminant) = cie_at(lambda);
        xyz += cmf * v * if d65 { illuminant * D65_NORMALIZATION } else { 1.0 };
    }
    xyz * ((CIE_MAX - CIE_MIN) / STEPS as f64) * Y_NORMALIZATION
}

/// Linear sRGB of the piecewise-linear spectrum through `(wavelength nm, value)` pairs
/// (wavelengths strictly increasing, at least two): a reflectance (`reflectance`: D65-weighted,
/// clamped to [0, 1]) or an emitted spectrum (neither). Negative channels are clamped to 0 in
/// both cases, as Mitsuba does. Also returns whether a reflectance was clamped above 1.
pub fn list_to_srgb(points: &[(f64, f64)], reflectance: bool) -> (DVec3, bool) {
    let interpolate = |lambda: f64| {
        let (first, last) = (points[0].0, points[points.len() - 1].0);
        if lambda < first || lambda > last {
            return None;
        }
        let i = points.partition_point(|p| p.0 <= lambda).clamp(1, points.len() - 1) - 1;
        let ((w0, v0), (w1, v1)) = (points[i], points[i + 1]);
        Some(v0 + (v1 - v0) * (lambda - w0) / (w1 - w0))
    };
    let rgb = xyz_to_srgb(integrate_xyz(interpolate, reflectance)).max(DVec3::ZERO);
    if reflectance && rgb.max_element() > 1.0 {
        (rgb.min(DVec3::ONE), true)
    } else {
        (rgb, false)
    }
}

/// Planck's spectral radiance at `lambda` nm and `kelvin`, W·m⁻²·sr⁻¹·nm⁻¹.
pub fn planck(lambda: f64, kelvin: f64) -> f64 {
    const C: f64 = 299_792_458.0;
    const H: f64 = 6.626_070_04e-34;
    const K: f64 = 1.380_648_52e-23;
    let l = lambda * 1e-9;
    2.0 * H * C * C / l.powi(5) / ((H * C / (l * K * kelvin)).exp() - 1.0) * 1e-9
}

/// Linear sRGB radiance of a blackbody at `kelvin` (see the module doc).
pub fn blackbody_to_srgb(kelvin: f64) -> DVec3 {
    xyz_to_srgb(integrate_xyz(|l| Some(planck(l, kelvin)), false)).max(DVec3::ZERO)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tables are what the CIE defines: ȳ peaks at 1 at 555 nm, D65 is 100 at 560 nm, and
    /// under Mitsuba's quadrature ȳ integrates to Mitsuba's normalisation.
    #[test]
    fn tables_are_the_cie_tables() {
        let at = |nm: usize| CIE_TABLE[(nm - 360) / 5];
        assert_eq!(at(555)[1], 1.0);
        assert!((at(560)[3] - 100.0).abs() < 1e-9);
        let y = integrate_xyz(|_| Some(1.0), false).y;
        assert!((y - 1.0).abs() < 1e-6, "{y}");
    }

    /// An equal-energy emitter is the sRGB colour of illuminant E; a constant reflectance is
    /// grey under D65 (the sRGB white); a reflectance above 1 is clamped and reported.
    #[test]
    fn flat_spectra_give_the_expected_colours() {
        let (e, _) = list_to_srgb(&[(360.0, 1.0), (830.0, 1.0)], false);
        // Illuminant E in linear sRGB: r > g > b, with Y = 1 (the middle row of the inverse).
        assert!(e.x > e.y && e.y > e.z, "{e}");
        let y = 0.212671 * e.x + 0.715160 * e.y + 0.072169 * e.z;
        assert!((y - 1.0).abs() < 1e-4, "Y = {y}");
        let (grey, clamped) = list_to_srgb(&[(360.0, 0.5), (830.0, 0.5)], true);
        assert!(!clamped);
        assert!((grey - DVec3::splat(0.5)).abs().max_element() < 2e-3, "{grey}");
        assert!(
            (grey.x - grey.y).abs() < 1e-3 && (grey.y - grey.z).abs() < 1e-3,
            "{grey}"
        );
        let (white, clamped) = list_to_srgb(&[(360.0, 1.5), (830.0, 1.5)], true);
        assert!(clamped && white == DVec3::ONE, "{white}");
    }

    /// Values Mitsuba 3.9.1 (`scalar_rgb`) gives for the same spectra, read with
    /// `mi.spectrum_list_to_srgb(wavelengths, values, bounded, d65)` (reflectance: both true;
    /// emitter: both false) and, for the emitter, `mi.traverse` of an `area` emitter — an
    /// independent implementation the conversion must match to its f32 precision.
    #[test]
    fn conversions_match_mitsuba() {
        type Case<'a> = (&'a [(f64, f64)], bool, [f64; 3]);
        let cases: [Case; 3] = [
            (
                &[(400.0, 0.5), (500.0, 0.5), (600.0, 0.5), (700.0, 0.5)],
                true,
                [0.497671, 0.499878, 0.497455],
            ),
            (&[(360.0, 1.0), (830.0, 1.0)], false, [1.20488, 0.948229, 0.909267]),
            (
                &[(400.0, 0.1), (450.0, 0.9), (520.0, 0.3), (610.0, 0.7), (700.0, 0.2)],
                true,
                [0.681578, 0.412557, 0.730574],
            ),
        ];
        for (points, reflectance, expected) in cases {
            let (rgb, _) = list_to_srgb(points, reflectance);
            let expected = DVec3::from_array(expected);
            assert!(
                (rgb - expected).abs().max_element() < 2e-5 * expected.max_element(),
                "{points:?}: {rgb} vs Mitsuba {expected}"
            );
        }
        // Mitsuba's `blackbody` (scalar_spectral) at 3000 K: 72.1974, 260.268, 517.502, 750.596 at
        // 400, 500, 600, 700 nm.
        for (nm, expected) in [(400.0, 72.1974), (500.0, 260.268), (600.0, 517.502), (700.0, 750.596)] {
            let b = planck(nm, 3000.0);
            assert!((b - expected).abs() < 1e-5 * expected, "{nm} nm: {b} vs {expected}");
        }
    }
}
