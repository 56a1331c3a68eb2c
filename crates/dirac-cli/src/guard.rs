//! What keeps `dirac run` from hurting the machine it runs on: a bound on the steps and on the
//! output's size that asks for `--max-steps`/`--force` before a run starts, Ctrl-C that leaves no
//! partial output file, and the peak memory a run used.

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

/// Most steps a run takes unless `--max-steps` raises the bound or `--force` lifts it. At the
/// 0.2–20 µs a step costs on the bundled models, 10⁹ steps are minutes to hours of computing
/// and, streamed as CSV, some 50–100 GB: a run this long is more likely a mistyped `h` or `t_end`
/// than intended.
pub const DEFAULT_MAX_STEPS: u64 = 1_000_000_000;

/// Bytes a CSV value takes at most: a sign, 17 significant digits, a point, an exponent such as
/// `e-308` and the separator (values print in their shortest round-trip form, usually fewer).
pub const CSV_BYTES_PER_VALUE: u64 = 25;

/// Exit code of a run stopped by SIGINT or SIGTERM (128 + SIGINT, as shells report it).
pub const INTERRUPTED_EXIT: u8 = 130;

/// Set by the first Ctrl-C (or SIGTERM); the run loop stops at the next row.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// The partial output file of the run in progress, removed by a second Ctrl-C that cannot wait
/// for the run loop.
static PARTIAL: Mutex<Option<PathBuf>> = Mutex::new(None);

/// Installs the SIGINT/SIGTERM handler: the first signal asks the run to stop at its next row
/// (which then removes its partial file and exits 130); a second one removes the partial file
/// and exits at once.
pub fn install_interrupt_handler() {
    let _ = ctrlc::set_handler(|| {
        if INTERRUPTED.swap(true, Ordering::SeqCst) {
            if let Ok(guard) = PARTIAL.lock()
                && let Some(path) = guard.as_ref()
            {
                let _ = std::fs::remove_file(path);
            }
            std::process::exit(i32::from(INTERRUPTED_EXIT));
        }
    });
}

/// Whether a SIGINT or SIGTERM arrived.
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}

/// Records the partial output file a second Ctrl-C must remove (`None` once it is gone).
pub fn set_partial(path: Option<PathBuf>) {
    if let Ok(mut guard) = PARTIAL.lock() {
        *guard = path;
    }
}

/// Refuses a run of more than `max` steps.
pub fn check_steps(steps: u64, max: u64) -> Result<(), String> {
    if steps <= max {
        return Ok(());
    }
    Err(format!(
        "this run would take {steps} steps (t_end / h), more than the limit of {max}; check h and t_end, or pass --max-steps {steps} (or --force) to run it anyway"
    ))
}

/// Refuses a CSV of `rows` rows of `columns` values (plus `t`) that could be larger than the
/// free space where `out` is written.
pub fn check_disk(out: &Path, rows: u64, columns: usize) -> Result<(), String> {
    let dir = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let Some(free) = available_space(&dir) else {
        return Ok(());
    };
    let bytes = rows
        .saturating_mul(columns as u64 + 1)
        .saturating_mul(CSV_BYTES_PER_VALUE);
    if bytes <= free {
        return Ok(());
    }
    Err(format!(
        "{}: the CSV of {rows} rows × {} columns could take up to {} while {} is free on {}; record fewer signals (--signals), use a larger h or a shorter t_end, or pass --force",
        out.display(),
        columns + 1,
        human(bytes),
        human(free),
        dir.display()
    ))
}

/// Free bytes for an unprivileged writer on the file system holding `dir`.
#[cfg(unix)]
pub fn available_space(dir: &Path) -> Option<u64> {
    let stat = rustix::fs::statvfs(dir).ok()?;
    Some(stat.f_bavail.saturating_mul(stat.f_frsize))
}

/// Free bytes for an unprivileged writer on the file system holding `dir` (not known here).
#[cfg(not(unix))]
pub fn available_space(_dir: &Path) -> Option<u64> {
    None
}

/// The process's peak resident memory in KiB (`VmHWM` of `/proc/self/status`, Linux only).
pub fn peak_rss_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
}

/// Memory available to new allocations in bytes (`MemAvailable` of `/proc/meminfo`, Linux only).
pub fn available_memory() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    info.lines()
        .find_map(|l| l.strip_prefix("MemAvailable:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        .map(|kib| kib.saturating_mul(1024))
}

/// `bytes` in B, kB, MB, GB or TB (powers of 1000).
fn human(bytes: u64) -> String {
    let units = ["B", "kB", "MB", "GB", "TB", "PB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1000.0 && unit + 1 < units.len() {
        value /= 1000.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{bytes} B")
    } else {
        format!("{value:.1} {}", units[unit])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The step bound: exactly `max` passes, one more is refused with the flags to use.
    /// Mutation: `steps < max` refuses the boundary case (fails).
    #[test]
    fn step_bound_is_inclusive_and_names_the_flags() {
        assert!(check_steps(1000, 1000).is_ok());
        let message = check_steps(1001, 1000).unwrap_err();
        assert!(message.contains("--max-steps 1001") && message.contains("--force"));
    }

    /// Sizes print with one decimal in powers of 1000.
    #[test]
    fn sizes_are_human() {
        assert_eq!(human(999), "999 B");
        assert_eq!(human(1_234_567), "1.2 MB");
        assert_eq!(human(52_000_000_000), "52.0 GB");
    }
}
