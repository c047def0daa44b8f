//! The memory budget: one process-wide limit on the bytes a stage may hold, checked before
//! the stage allocates, so that an absurd request is refused with one line instead of
//! aborting the process when the allocator gives up.
//!
//! Every isokit stage that holds big buffers (dense grids, brick grids, meshes from marching
//! cubes, images and G-buffers, splat bins, molecule scenes, octrees, volumes read from
//! files) estimates what it will hold and calls [`check`] first. The budget is:
//! 1. what [`set_budget`] set (the command's `--max-memory`), else
//! 2. the environment variable [`ENV`] (`ISOKIT_MAX_MEMORY`, e.g. `8G`, `512M`), else
//! 3. [`default_budget`]: three quarters of the memory this process can have — the least
//!    of the machine's available memory (`/proc/meminfo`), its cgroup's limit and its
//!    address-space limit (`ulimit -v`), where those exist.
//!
//! Sizes accept a number of bytes with an optional suffix `K`, `M`, `G`, `T` (powers of
//! 1024, optionally followed by `B` or `iB`): [`parse_size`].
//!
//! ```
//! use isokit_field::memory;
//! assert_eq!(memory::parse_size("512M"), Ok(512 << 20));
//! assert_eq!(memory::parse_size("1.5G"), Ok(3 << 29));
//! let err = memory::check_within(1 << 30, "a dense grid", 3 << 30, "lower the resolution")
//!     .unwrap_err();
//! assert!(err.to_string().contains("3.0 GiB"));
//! ```

use crate::FieldError;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicU64, Ordering};

/// The environment variable that sets the budget when [`set_budget`] was not called.
pub const ENV: &str = "ISOKIT_MAX_MEMORY";

/// The budget used when the machine's memory cannot be read (8 GiB).
pub const FALLBACK: u64 = 8 << 30;

/// 0: not set by [`set_budget`].
static SET: AtomicU64 = AtomicU64::new(0);
static DEFAULT: OnceLock<u64> = OnceLock::new();

/// Sets the process-wide budget in bytes (at least 1). The command calls it once, from
/// `--max-memory` or [`ENV`].
pub fn set_budget(bytes: u64) {
    SET.store(bytes.max(1), Ordering::Relaxed);
}

/// The budget in force (see the module docs).
pub fn budget() -> u64 {
    match SET.load(Ordering::Relaxed) {
        0 => *DEFAULT.get_or_init(|| {
            std::env::var(ENV)
                .ok()
                .and_then(|v| parse_size(&v).ok())
                .unwrap_or_else(default_budget)
        }),
        b => b,
    }
}

/// Where the budget in force comes from, for messages: `--max-memory or ISOKIT_MAX_MEMORY`.
const HOW: &str = "set with --max-memory or ISOKIT_MAX_MEMORY";

/// The budget from [`ENV`] if set: `Ok(None)` when unset, an error naming the variable when
/// its value is not a size.
pub fn budget_from_env() -> Result<Option<u64>, String> {
    match std::env::var(ENV) {
        Ok(v) => parse_size(&v)
            .map(Some)
            .map_err(|e| format!("{ENV}={v:?}: {e}")),
        Err(_) => Ok(None),
    }
}

/// Three quarters of the least of: available memory (`MemAvailable` in `/proc/meminfo`), the
/// cgroup's `memory.max` and the address-space limit of `/proc/self/limits`; [`FALLBACK`]
/// when none can be read.
pub fn default_budget() -> u64 {
    let mut least: Option<u64> = None;
    let mut consider = |v: Option<u64>| {
        if let Some(v) = v.filter(|&v| v > 0) {
            least = Some(least.map_or(v, |l| l.min(v)));
        }
    };
    consider(read_meminfo());
    consider(read_first_number("/sys/fs/cgroup/memory.max"));
    consider(read_first_number(
        "/sys/fs/cgroup/memory/memory.limit_in_bytes",
    ));
    consider(read_address_limit());
    least.map_or(FALLBACK, |l| l / 4 * 3)
}

fn read_meminfo() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let field = |name: &str| {
        text.lines().find_map(|l| {
            let rest = l.strip_prefix(name)?.trim();
            let kb: u64 = rest.split_whitespace().next()?.parse().ok()?;
            kb.checked_mul(1024)
        })
    };
    field("MemAvailable:").or_else(|| field("MemTotal:"))
}

fn read_first_number(path: &str) -> Option<u64> {
    // "max" (no limit) does not parse and counts as absent; so do absurd values.
    let text = std::fs::read_to_string(path).ok()?;
    text.trim().parse::<u64>().ok().filter(|&v| v < 1 << 60)
}

fn read_address_limit() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = text.lines().find(|l| l.starts_with("Max address space"))?;
    // "Max address space   <soft>   <hard>   bytes"; "unlimited" does not parse.
    line.trim_start_matches("Max address space")
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// Parses a size: bytes with an optional suffix `K`, `M`, `G` or `T` (powers of 1024, `B` or
/// `iB` may follow; case-insensitive), e.g. `8G`, `512M`, `1.5GiB`, `100000`.
pub fn parse_size(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let lower = t.to_ascii_lowercase();
    let body = lower
        .strip_suffix("ib")
        .or_else(|| lower.strip_suffix('b'))
        .unwrap_or(&lower);
    let (num, shift) = match body.chars().last() {
        Some('k') => (&body[..body.len() - 1], 10),
        Some('m') => (&body[..body.len() - 1], 20),
        Some('g') => (&body[..body.len() - 1], 30),
        Some('t') => (&body[..body.len() - 1], 40),
        _ => (body, 0),
    };
    let bad = || format!("{t:?} is not a size (give bytes or a number with K, M, G or T, e.g. 8G)");
    let x: f64 = num.trim().parse().map_err(|_| bad())?;
    let bytes = x * (1u64 << shift) as f64;
    if !(1.0..1.8e19).contains(&bytes) {
        return Err(format!("{t:?} must be at least 1 byte and below 16 EiB"));
    }
    Ok(bytes as u64)
}

/// Bytes for people: `6.4 GiB`, `512 MiB`, `12 KiB`, `100 bytes`.
pub fn human(bytes: u128) -> String {
    const UNITS: [&str; 5] = ["KiB", "MiB", "GiB", "TiB", "PiB"];
    if bytes < 1024 {
        return format!("{bytes} bytes");
    }
    let mut v = bytes as f64 / 1024.0;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if v >= 100.0 {
        format!("{v:.0} {}", UNITS[u])
    } else {
        format!("{v:.1} {}", UNITS[u])
    }
}

/// Refuses `bytes` held by `what` when they exceed the [`budget`]; `fit` says how to make it
/// fit (a lower resolution, a band, …). See [`check_within`].
pub fn check(what: &str, bytes: u128, fit: &str) -> Result<(), FieldError> {
    check_within(budget(), what, bytes, fit)
}

/// [`check`] against an explicit budget.
pub fn check_within(budget: u64, what: &str, bytes: u128, fit: &str) -> Result<(), FieldError> {
    if bytes <= budget as u128 {
        return Ok(());
    }
    Err(FieldError::OverBudget {
        what: what.to_string(),
        bytes,
        budget,
        fit: fit.to_string(),
    })
}

/// The message of [`FieldError::OverBudget`].
pub(crate) fn refusal(what: &str, bytes: u128, budget: u64, fit: &str) -> String {
    format!(
        "{what} would hold {} ({bytes} bytes), over the memory budget of {} ({HOW}); {fit}",
        human(bytes),
        human(budget as u128)
    )
}

/// Bytes of a dense grid of f32 samples with these dimensions (saturating).
pub fn grid_bytes(dims: [usize; 3]) -> u128 {
    dims.iter()
        .fold(4u128, |acc, &d| acc.saturating_mul(d as u128))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse() {
        assert_eq!(parse_size("8G"), Ok(8 << 30));
        assert_eq!(parse_size("8g"), Ok(8 << 30));
        assert_eq!(parse_size("8GiB"), Ok(8 << 30));
        assert_eq!(parse_size("8GB"), Ok(8 << 30));
        assert_eq!(parse_size("512M"), Ok(512 << 20));
        assert_eq!(parse_size("64k"), Ok(64 << 10));
        assert_eq!(parse_size("2T"), Ok(2 << 40));
        assert_eq!(parse_size(" 1000 "), Ok(1000));
        assert_eq!(parse_size("1000B"), Ok(1000));
        for bad in ["", "G", "-1G", "0", "nanG", "infM", "1e30T", "eight", "8X"] {
            assert!(parse_size(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn refusal_is_one_line_naming_what_and_how() {
        let e = check_within(
            1 << 30,
            "a dense grid of 1200 x 1200 x 1200 samples",
            6_912_000_000,
            "lower the resolution",
        )
        .unwrap_err();
        let m = e.to_string();
        assert!(!m.contains('\n'));
        assert!(
            m.contains("a dense grid of 1200 x 1200 x 1200 samples"),
            "{m}"
        );
        assert!(
            m.contains("6.4 GiB") && m.contains("6912000000 bytes"),
            "{m}"
        );
        assert!(m.contains("1.0 GiB") && m.contains("--max-memory"), "{m}");
        assert!(m.ends_with("lower the resolution"), "{m}");
        assert!(check_within(1 << 30, "x", 1 << 30, "").is_ok());
    }

    #[test]
    fn the_default_is_a_share_of_this_machine() {
        let d = default_budget();
        assert!(d >= 1 << 20, "{d}");
        if let Some(avail) = read_meminfo() {
            assert!(d <= avail, "{d} > {avail}");
        }
        assert_eq!(human(1023), "1023 bytes");
        assert_eq!(human(1536), "1.5 KiB");
        assert_eq!(grid_bytes([1200, 1200, 1200]), 6_912_000_000);
    }
}
