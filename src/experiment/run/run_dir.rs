//! Run directories: ids from the UTC time, created atomically with their owner (host and
//! process) in the name, so that leftovers of a killed run are recognised and removed and
//! nothing half-written is ever taken for a result.

use crate::error::{Context, Result};
use std::path::{Path, PathBuf};

/// The file in a run's temporary directories that names their writer: `<host> <pid>`.
pub const OWNER: &str = ".owner";

/// This machine's name, as the kernel reports it (`unknown` where it cannot be read).
pub(super) fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_string())
        .or_else(|_| std::env::var("HOSTNAME"))
        .unwrap_or_else(|_| "unknown".to_string())
}

/// Creates the temporary directory `dir` (and `dir/sub`) with its [`OWNER`] file.
pub(super) fn create_owned_dir(dir: &Path, sub: &str) -> Result<()> {
    std::fs::create_dir_all(dir.join(sub)).context(dir.display())?;
    let owner = format!("{} {}\n", host_name(), std::process::id());
    std::fs::write(dir.join(OWNER), owner).context(dir.join(OWNER).display())
}

/// The writer `<host> <pid>` a cell temporary's name `.tmp-<hash>-<pid>@<host>` gives.
pub(super) fn owner_in_name(dir: &Path) -> Option<String> {
    let name = dir.file_name()?.to_str()?.strip_prefix(".tmp-")?;
    let (left, host) = name.split_once('@')?;
    let (_, pid) = left.rsplit_once('-')?;
    Some(format!("{host} {pid}"))
}

/// Is the temporary directory `dir` an orphan: written by a process of this host that no longer
/// runs? The writer is the one its owner file names, else (no file, or an empty one) the one
/// its name names (cell temporaries); with neither (a run directory killed between its creation and its owner
/// file) it is one once a day old. Where processes cannot be looked up (no `/proc`), nothing
/// is.
pub(super) fn is_orphan(dir: &Path, host: &str) -> bool {
    if !Path::new("/proc/self").exists() {
        return false;
    }
    // An owner file killed while being written is empty: the name decides then.
    let written = std::fs::read_to_string(dir.join(OWNER))
        .ok()
        .filter(|o| !o.trim().is_empty());
    match written.or_else(|| owner_in_name(dir)) {
        Some(owner) => match owner.trim().rsplit_once(' ') {
            Some((h, pid)) => {
                h == host
                    && pid
                        .parse::<u32>()
                        .is_ok_and(|pid| pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists())
            }
            None => false,
        },
        None => std::fs::metadata(dir)
            .and_then(|m| m.modified())
            .is_ok_and(|t| t.elapsed().is_ok_and(|age| age.as_secs() > 24 * 3600)),
    }
}

/// Removes the orphaned temporaries of killed runs under `base` (`.<run-id>.partial/` and
/// `cells/.tmp-*/`, see the module doc); returns how many.
pub fn remove_leftovers(base: &Path) -> usize {
    let host = host_name();
    let mut removed = 0;
    let candidates = |dir: &Path, keep: &dyn Fn(&str) -> bool| -> Vec<PathBuf> {
        std::fs::read_dir(dir)
            .map(|d| {
                d.filter_map(|e| e.ok())
                    .filter(|e| e.file_type().is_ok_and(|t| t.is_dir()))
                    .filter(|e| keep(&e.file_name().to_string_lossy()))
                    .map(|e| e.path())
                    .collect()
            })
            .unwrap_or_default()
    };
    let partial = |n: &str| n.starts_with('.') && n.ends_with(".partial");
    let tmp = |n: &str| n.starts_with(".tmp-");
    for dir in candidates(base, &partial)
        .into_iter()
        .chain(candidates(&base.join("cells"), &tmp))
    {
        if is_orphan(&dir, &host) && std::fs::remove_dir_all(&dir).is_ok() {
            removed += 1;
        }
    }
    removed
}

/// A run id that sorts by time and never collides with an earlier run in `base`.
pub(super) fn new_run_id(base: &Path) -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let stamp = utc_stamp(secs);
    let mut id = stamp.clone();
    let mut n = 2;
    while base.join(&id).exists() || base.join(format!(".{id}.partial")).exists() {
        id = format!("{stamp}-{n}");
        n += 1;
    }
    id
}

/// `YYYY-MM-DDTHH-MM-SSZ` for seconds since the Unix epoch (civil-from-days, Hinnant 2013).
pub(super) fn utc_stamp(secs: u64) -> String {
    let days = (secs / 86_400) as i64;
    let rem = secs % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}-{:02}-{:02}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}
