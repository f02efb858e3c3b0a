//! Colour helpers below every other module: the luminance of linear RGB, the sRGB transfer
//! function, and the viridis colormap of error maps and photon pictures. Nothing here knows
//! about scenes, films or reports; everything that weighs or displays colour imports it.

use glam::Vec3;

/// Relative luminance of linear Rec. 709 RGB.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// The sRGB opto-electronic transfer function (IEC 61966-2-1): linear `[0, 1]` to encoded
/// `[0, 1]`; input outside `[0, 1]` is clamped first and NaN maps to 0.
pub fn srgb_encode(linear: f32) -> f32 {
    let v = if linear.is_nan() { 0.0 } else { linear.clamp(0.0, 1.0) };
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Linear `[0, 1]` to an 8-bit sRGB code value, rounded to nearest.
#[inline]
pub fn srgb8(linear: f32) -> u8 {
    (srgb_encode(linear) * 255.0 + 0.5) as u8
}

/// Viridis (van der Walt & Smith, matplotlib's default colormap; perceptually uniform and
/// readable in greyscale and by colour-blind viewers) sampled at 9 evenly spaced stops, in
/// 8-bit sRGB.
pub const VIRIDIS_STOPS: [[u8; 3]; 9] = [
    [0x44, 0x01, 0x54],
    [0x47, 0x2d, 0x7b],
    [0x3b, 0x52, 0x8b],
    [0x2c, 0x72, 0x8e],
    [0x21, 0x90, 0x8c],
    [0x27, 0xad, 0x81],
    [0x5d, 0xc8, 0x63],
    [0xaa, 0xdc, 0x32],
    [0xfd, 0xe7, 0x25],
];

/// Viridis at `t ∈ [0, 1]` (clamped), linearly interpolated between the 9 stops.
pub fn viridis(t: f64) -> [u8; 3] {
    let x = t.clamp(0.0, 1.0) * (VIRIDIS_STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(VIRIDIS_STOPS.len() - 2);
    let f = x - i as f64;
    let (a, b) = (VIRIDIS_STOPS[i], VIRIDIS_STOPS[i + 1]);
    std::array::from_fn(|c| (a[c] as f64 + f * (b[c] as f64 - a[c] as f64)).round() as u8)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_encoding_is_continuous_at_the_linear_segment() {
        let knee = 0.003_130_8f32;
        let below = srgb_encode(knee);
        let above = srgb_encode(knee * (1.0 + 1e-6));
        assert!((above - below).abs() < 1e-5, "{below} vs {above}");
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-6);
        assert_eq!(srgb8(1.0), 255);
    }

    #[test]
    fn viridis_endpoints_and_midpoint_are_the_stops() {
        assert_eq!(viridis(0.0), [0x44, 0x01, 0x54]);
        assert_eq!(viridis(0.5), [0x21, 0x90, 0x8c]);
        assert_eq!(viridis(1.0), [0xfd, 0xe7, 0x25]);
        assert_eq!(viridis(-3.0), viridis(0.0));
        assert_eq!(viridis(7.0), viridis(1.0));
    }
}
