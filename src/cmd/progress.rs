//! Progress of long library calls on stderr, one style for every stage: on a terminal an
//! updating bar with the rate and the time left, otherwise a line every 10%; nothing for a
//! stage that ends within half a second, and nothing at all with `-q`. The library reports
//! through an [`isokit_field::Job`]; [`job`] makes one that prints.

use isokit_field::Job;
use std::io::{IsTerminal, Write};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

static QUIET: AtomicBool = AtomicBool::new(false);

/// Silences progress (the global `-q`/`--quiet`).
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

/// How long a stage runs before its progress shows: 500 ms, or `ISOKIT_PROGRESS_AFTER_MS`.
fn delay() -> Duration {
    let ms = std::env::var("ISOKIT_PROGRESS_AFTER_MS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(500);
    Duration::from_millis(ms)
}

/// One stage's state: its name, start, last print and the count printed then.
struct Stage {
    name: String,
    start: Instant,
    printed: Option<Instant>,
    done: u64,
}

struct Printer {
    tty: bool,
    delay: Duration,
    last: Mutex<Option<Stage>>,
}

/// `12.3 s`, `4 min 05 s`.
fn duration(s: f64) -> String {
    if s < 60.0 {
        format!("{s:.1} s")
    } else {
        format!("{} min {:02} s", (s / 60.0) as u64, (s % 60.0) as u64)
    }
}

/// The progress line: bar (on a terminal), share, counts, rate and time left.
pub fn line(stage: &str, done: u64, total: u64, secs: f64, bar: bool) -> String {
    let frac = (done as f64 / total.max(1) as f64).clamp(0.0, 1.0);
    let rate = done as f64 / secs.max(1e-9);
    let left = if done >= total {
        format!("done in {}", duration(secs))
    } else if done > 0 {
        format!("ETA {}", duration((total - done) as f64 / rate))
    } else {
        String::new()
    };
    let bar = if bar {
        let n = (frac * 24.0).round() as usize;
        format!("[{}{}] ", "#".repeat(n), ".".repeat(24 - n))
    } else {
        String::new()
    };
    format!(
        "{stage}: {bar}{:5.1}% ({done}/{total}) {rate:.3e}/s {left}",
        100.0 * frac
    )
}

impl Printer {
    fn report(&self, stage: &str, done: u64, total: u64) {
        if QUIET.load(Ordering::Relaxed) || total == 0 {
            return;
        }
        // A report that arrives while another thread prints is dropped, except a stage's
        // first (0 done, which starts it) and last, which wait: the line with the total time
        // must not be lost.
        let mut last = if done == 0 || done >= total {
            self.last.lock().unwrap_or_else(|e| e.into_inner())
        } else {
            match self.last.try_lock() {
                Ok(g) => g,
                Err(_) => return,
            }
        };
        let now = Instant::now();
        if done == 0 || last.as_ref().is_none_or(|s| s.name != stage) {
            *last = Some(Stage {
                name: stage.to_owned(),
                start: now,
                printed: None,
                done: 0,
            });
        }
        let Some(s) = last.as_mut() else { return };
        // Reports from parallel workers can arrive out of order: never step back, and say
        // nothing more once the stage's end is printed.
        if done < s.done || (s.printed.is_some() && s.done >= total) {
            return;
        }
        let elapsed = now.duration_since(s.start);
        let finished = done >= total;
        // A short stage says nothing; a stage that printed also prints its end.
        if elapsed < self.delay && s.printed.is_none() {
            return;
        }
        let due = match s.printed {
            None => true,
            Some(_) if finished => s.done < total,
            Some(p) if self.tty => now.duration_since(p) >= Duration::from_millis(200),
            Some(_) => done * 10 / total > s.done * 10 / total,
        };
        // Nothing done yet has no rate or time left to show.
        if !due || done == 0 {
            return;
        }
        let text = line(stage, done, total, elapsed.as_secs_f64(), self.tty);
        let mut e = std::io::stderr().lock();
        let _ = if self.tty {
            // Padded so a shorter line covers a longer one.
            write!(e, "\r{text:<100}{}", if finished { "\n" } else { "" })
        } else {
            writeln!(e, "{text}")
        };
        s.printed = Some(now);
        s.done = done;
    }
}

/// A job whose progress is printed on stderr.
pub fn job() -> Job {
    let p = Printer {
        tty: std::io::stderr().is_terminal(),
        delay: delay(),
        last: Mutex::new(None),
    };
    Job::new().with_progress(move |stage, done, total| p.report(stage, done, total))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_line_has_a_bar_the_share_the_rate_and_the_time_left() {
        let l = line("sampling bricks", 250, 1000, 2.0, true);
        assert!(
            l.starts_with("sampling bricks: [######..................]  25.0%"),
            "{l}"
        );
        assert!(l.contains("(250/1000)") && l.contains("1.250e2/s"), "{l}");
        assert!(l.ends_with("ETA 6.0 s"), "{l}");
        let done = line("x", 10, 10, 125.0, false);
        assert!(
            done.ends_with("done in 2 min 05 s") && !done.contains('['),
            "{done}"
        );
    }
}
