//! Memory estimates, checked before anything large is allocated.
//!
//! An absurd input (a 16384 × 16384 film on a laptop, a billion photons) must be refused with
//! a one-line error naming what and how much, not end in an out-of-memory kill halfway through
//! a run. Each large buffer has an estimator here (`*_bytes`); the code about to allocate it
//! calls [`check_memory`] with the estimate and [`memory_limit`].
//!
//! The limit is 75 % of the machine's memory (`MemTotal` in `/proc/meminfo`; 8 GiB where that
//! cannot be read), or the number of bytes in the environment variable
//! `PHOTON_BENCH_MEMORY_LIMIT` (a plain integer, or with a `K`, `M`, `G` or `T` suffix for
//! powers of 1024), which lets a shared machine or a test set it lower.

use crate::error::{Error, Result};
use crate::film::PixelAccumulator;
use glam::Vec3;

/// The environment variable that overrides [`default_memory_limit`].
pub const MEMORY_LIMIT_VAR: &str = "PHOTON_BENCH_MEMORY_LIMIT";
/// The limit where the machine's memory cannot be read.
pub const FALLBACK_MEMORY_LIMIT: u64 = 8 << 30;

/// Bytes of a `width × height` film: its pixel accumulators plus the image made from them.
pub fn film_bytes(width: u32, height: u32) -> u64 {
    let per_pixel = (std::mem::size_of::<PixelAccumulator>() + std::mem::size_of::<Vec3>()) as u64;
    (width as u64).saturating_mul(height as u64).saturating_mul(per_pixel)
}

/// Bytes of `n` photon records of `record_bytes` each (the photon map's record size is the
/// caller's: this module does not know the layout).
pub fn photon_bytes(n: u64, record_bytes: u64) -> u64 {
    n.saturating_mul(record_bytes)
}

/// Refuses `bytes` of `what` above `limit`, with a one-line error naming both numbers.
pub fn check_memory(what: &str, bytes: u64, limit: u64) -> Result<()> {
    if bytes <= limit {
        return Ok(());
    }
    Err(Error::new(format!(
        "{what} needs about {}, more than the memory limit of {} (set {MEMORY_LIMIT_VAR} to change it)",
        human_bytes(bytes),
        human_bytes(limit)
    )))
}

/// 75 % of the machine's memory (`MemTotal` of `/proc/meminfo`), or [`FALLBACK_MEMORY_LIMIT`]
/// where that cannot be read.
pub fn default_memory_limit() -> u64 {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| mem_total_bytes(&text))
        .map_or(FALLBACK_MEMORY_LIMIT, |total| total / 4 * 3)
}

/// The limit in force: [`MEMORY_LIMIT_VAR`] when set, else [`default_memory_limit`]. A set but
/// unreadable variable is an error rather than silently ignored.
pub fn memory_limit() -> Result<u64> {
    match std::env::var(MEMORY_LIMIT_VAR) {
        Err(std::env::VarError::NotPresent) => Ok(default_memory_limit()),
        Ok(v) => parse_bytes(&v).ok_or_else(|| {
            Error::new(format!(
                "{MEMORY_LIMIT_VAR}: expected a number of bytes such as 4000000000 or 4G, got {v:?}"
            ))
        }),
        Err(e) => Err(Error::new(format!("{MEMORY_LIMIT_VAR}: {e}"))),
    }
}

/// `MemTotal` of a `/proc/meminfo` text, in bytes.
fn mem_total_bytes(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemTotal:"))?;
    let mut parts = line["MemTotal:".len()..].split_whitespace();
    let kib: u64 = parts.next()?.parse().ok()?;
    (parts.next() == Some("kB")).then(|| kib.saturating_mul(1024))
}

/// A byte count: an integer with an optional binary suffix `K`, `M`, `G`, `T` (`KiB` … too).
fn parse_bytes(s: &str) -> Option<u64> {
    let s = s.trim();
    let digits = s.find(|c: char| !c.is_ascii_digit()).unwrap_or(s.len());
    let (n, suffix) = s.split_at(digits);
    let n: u64 = n.parse().ok()?;
    let shift = match suffix
        .trim()
        .to_ascii_uppercase()
        .trim_end_matches("IB")
        .trim_end_matches('B')
    {
        "" => 0,
        "K" => 10,
        "M" => 20,
        "G" => 30,
        "T" => 40,
        _ => return None,
    };
    n.checked_mul(1 << shift)
}

/// Bytes for a reader: `512 B`, `1.5 KiB`, `2.75 GiB`, `16.0 EiB`.
pub fn human_bytes(bytes: u64) -> String {
    const UNITS: [&str; 6] = ["KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    if bytes < 1024 {
        return format!("{bytes} B");
    }
    let mut v = bytes as f64 / 1024.0;
    let mut unit = 0;
    while v >= 1024.0 && unit + 1 < UNITS.len() {
        v /= 1024.0;
        unit += 1;
    }
    let decimals = if v < 10.0 { 2 } else { 1 };
    format!("{v:.decimals$} {}", UNITS[unit])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn film_bytes_counts_accumulators_and_image() {
        assert_eq!(film_bytes(0, 100), 0);
        assert_eq!(film_bytes(2, 3), 6 * (32 + 12));
        assert_eq!(film_bytes(16384, 16384), 16384 * 16384 * 44);
        // Beyond u64 it saturates rather than wrapping to a small, acceptable number.
        assert_eq!(film_bytes(u32::MAX, u32::MAX), u64::MAX);
    }

    #[test]
    fn check_memory_passes_at_the_limit_and_names_both_numbers_above_it() {
        assert!(check_memory("x", 100, 100).is_ok());
        let e = check_memory("a 8192 × 8192 film", film_bytes(8192, 8192), 1 << 30)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "a 8192 × 8192 film needs about 2.75 GiB, more than the memory limit of 1.00 GiB \
             (set PHOTON_BENCH_MEMORY_LIMIT to change it)"
        );
    }

    #[test]
    fn photon_bytes_saturates() {
        assert_eq!(photon_bytes(1000, 24), 24_000);
        assert_eq!(photon_bytes(u64::MAX, 24), u64::MAX);
    }

    #[test]
    fn meminfo_and_byte_counts_parse() {
        let meminfo = "MemFree:  100 kB\nMemTotal:       24576000 kB\n";
        assert_eq!(mem_total_bytes(meminfo), Some(24_576_000 * 1024));
        assert_eq!(mem_total_bytes("MemTotal: lots\n"), None);
        assert_eq!(mem_total_bytes(""), None);
        assert!(default_memory_limit() > 0);
        assert_eq!(parse_bytes("4096"), Some(4096));
        assert_eq!(parse_bytes("4G"), Some(4 << 30));
        assert_eq!(parse_bytes("512 MiB"), Some(512 << 20));
        assert_eq!(parse_bytes("1k"), Some(1024));
        assert_eq!(parse_bytes("-1"), None);
        assert_eq!(parse_bytes("4X"), None);
        assert_eq!(parse_bytes(""), None);
        assert_eq!(parse_bytes("99999999999T"), None);
    }

    #[test]
    fn human_bytes_picks_a_readable_unit() {
        assert_eq!(human_bytes(512), "512 B");
        assert_eq!(human_bytes(1536), "1.50 KiB");
        assert_eq!(human_bytes(300 << 20), "300.0 MiB");
        assert_eq!(human_bytes(u64::MAX), "16.0 EiB");
    }
}
