//! The limits every scene reader enforces (our TOML and the Mitsuba importer alike), so that
//! absurd input is refused with a one-line error before anything is allocated.

/// Largest magnitude accepted for any coordinate, size or translation, before and after
/// transforming. f32 keeps about 7 significant digits, so beyond this a scene of ordinary
/// detail loses its geometry to rounding.
pub const MAX_COORD: f64 = 1e7;
/// Largest image side, in pixels.
pub const MAX_RESOLUTION_SIDE: u32 = 16384;
/// Largest image, in pixels (64 Mpixel): refused before any film is allocated.
pub const MAX_PIXELS: u64 = 64 << 20;
/// Largest emitted radiance per channel; keeps light powers finite in f32.
pub const MAX_RADIANCE: f64 = 1e10;
/// Largest Phong exponent; beyond it the lobe is a mirror for any practical purpose.
pub const MAX_PHONG_EXPONENT: f64 = 1e6;
/// Largest `subdivide` of a quad or box: 2 · 1024² ≈ 2 M triangles per face.
pub const MAX_SUBDIVIDE: i64 = 1024;
