//! A light progress reporter for long parallel jobs (stderr; a single updating line on a
//! terminal, a line every 10% otherwise; silent for small jobs).

use std::io::{IsTerminal, Write};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Jobs smaller than this report nothing.
const MIN_TOTAL: u64 = 200_000;

/// Shared progress counter; `advance` from any thread.
pub struct Progress {
    label: &'static str,
    total: u64,
    done: AtomicU64,
    start: Instant,
    last: Mutex<(Instant, u64)>,
    tty: bool,
    enabled: bool,
}

impl Progress {
    /// A reporter for `total` units of work.
    pub fn new(label: &'static str, total: u64) -> Self {
        let now = Instant::now();
        Self {
            label,
            total,
            done: AtomicU64::new(0),
            start: now,
            last: Mutex::new((now, 0)),
            tty: std::io::stderr().is_terminal(),
            enabled: total >= MIN_TOTAL,
        }
    }

    /// Records `n` more units done and prints when due.
    pub fn advance(&self, n: u64) {
        let done = self.done.fetch_add(n, Ordering::Relaxed) + n;
        if !self.enabled {
            return;
        }
        let Ok(mut last) = self.last.try_lock() else {
            return;
        };
        let now = Instant::now();
        let due = if self.tty {
            now.duration_since(last.0) >= Duration::from_millis(200)
        } else {
            done * 10 / self.total.max(1) > last.1 * 10 / self.total.max(1)
        };
        if due {
            *last = (now, done);
            let secs = self.start.elapsed().as_secs_f64().max(1e-9);
            let pct = 100.0 * done as f64 / self.total.max(1) as f64;
            let rate = done as f64 / secs;
            let mut e = std::io::stderr().lock();
            let end = if self.tty { "\r" } else { "\n" };
            let _ = write!(
                e,
                "{}: {pct:5.1}% ({done}/{}) {rate:.3e}/s{end}",
                self.label, self.total
            );
        }
    }

    /// Ends the line on a terminal.
    pub fn finish(&self) {
        if self.enabled && self.tty {
            eprintln!();
        }
    }
}
