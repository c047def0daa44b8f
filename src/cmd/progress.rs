//! Progress of long library calls on stderr: one updating line on a terminal, a line every
//! 10% otherwise; silent for small jobs. The library reports through an
//! [`isokit_field::Job`]; [`job`] makes one that prints.

use isokit_field::Job;
use std::io::{IsTerminal, Write};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Stages smaller than this report nothing.
const MIN_TOTAL: u64 = 200_000;

struct Printer {
    tty: bool,
    /// Stage, when it started, when it last printed, and what.
    last: Mutex<Option<(String, Instant, Instant, u64)>>,
}

impl Printer {
    fn report(&self, stage: &str, done: u64, total: u64) {
        if total < MIN_TOTAL {
            return;
        }
        let Ok(mut last) = self.last.try_lock() else {
            return;
        };
        let now = Instant::now();
        let (start, printed, before) = match &*last {
            Some((s, start, printed, before)) if s == stage => (*start, *printed, *before),
            _ => (now, now - Duration::from_secs(1), 0),
        };
        let due = if self.tty {
            now.duration_since(printed) >= Duration::from_millis(200) || done == total
        } else {
            done * 10 / total > before * 10 / total || (done == total && before < total)
        };
        if due && done > 0 {
            let secs = now.duration_since(start).as_secs_f64().max(1e-9);
            let pct = 100.0 * done as f64 / total as f64;
            let rate = done as f64 / secs;
            let mut e = std::io::stderr().lock();
            let end = if self.tty && done < total { "\r" } else { "\n" };
            let _ = write!(e, "{stage}: {pct:5.1}% ({done}/{total}) {rate:.3e}/s{end}");
            *last = Some((stage.to_owned(), start, now, done));
        } else if last.as_ref().is_none_or(|(s, ..)| s != stage) {
            *last = Some((stage.to_owned(), start, printed, before));
        }
    }
}

/// A job whose progress is printed on stderr.
pub fn job() -> Job {
    let p = Printer {
        tty: std::io::stderr().is_terminal(),
        last: Mutex::new(None),
    };
    Job::new().with_progress(move |stage, done, total| p.report(stage, done, total))
}
