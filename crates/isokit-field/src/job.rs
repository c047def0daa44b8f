//! Progress reports and cancellation for long computations.
//!
//! Every long call of the isokit crates (sampling a scene, building a tree, ray casting a
//! frame) takes a [`Job`]: the caller keeps a clone, may [`Job::cancel`] it from any thread
//! (a newer edit arrived in a live viewer, Ctrl-C in a script) and receives
//! [`Job::report`]s of `(stage, done, total)` through the callback it installed (a progress
//! bar). The work checks [`Job::is_cancelled`] at coarse steps (a brick, a slab, a row of
//! tiles) and returns [`Cancelled`] as an error.
//!
//! ```
//! use isokit_field::Job;
//! use std::sync::{Arc, Mutex};
//! let seen = Arc::new(Mutex::new(Vec::new()));
//! let log = seen.clone();
//! let job = Job::new().with_progress(move |stage, done, total| {
//!     log.lock().unwrap().push(format!("{stage} {done}/{total}"));
//! });
//! let progress = job.counter("bricks", 4);
//! for _ in 0..4 {
//!     progress.advance(1);
//! }
//! assert_eq!(seen.lock().unwrap().last().unwrap(), "bricks 4/4");
//! job.cancel();
//! assert!(job.check().is_err());
//! ```

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// The callback of [`Job::with_progress`]: `(stage, done, total)`.
pub type ProgressFn = dyn Fn(&str, u64, u64) + Send + Sync;

/// A handle on one long computation: cancellation flag and progress callback, shared by
/// its clones.
#[derive(Clone, Default)]
pub struct Job {
    cancel: Arc<AtomicBool>,
    progress: Option<Arc<ProgressFn>>,
}

impl std::fmt::Debug for Job {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Job")
            .field("cancelled", &self.is_cancelled())
            .field("reports_progress", &self.progress.is_some())
            .finish()
    }
}

/// The error of a computation whose [`Job`] was cancelled.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("cancelled")]
pub struct Cancelled;

impl Job {
    /// A job that reports nothing and is not cancelled.
    pub fn new() -> Self {
        Self::default()
    }

    /// The same job with `f` receiving its progress reports.
    pub fn with_progress(mut self, f: impl Fn(&str, u64, u64) + Send + Sync + 'static) -> Self {
        self.progress = Some(Arc::new(f));
        self
    }

    /// A job sharing `flag` as its cancellation flag (e.g. one a signal handler sets).
    pub fn with_cancel_flag(mut self, flag: Arc<AtomicBool>) -> Self {
        self.cancel = flag;
        self
    }

    /// Asks the computation (and every clone's) to stop at its next check.
    pub fn cancel(&self) {
        self.cancel.store(true, Ordering::Relaxed);
    }

    /// True once [`Job::cancel`] was called on this job or a clone.
    pub fn is_cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }

    /// `Err(Cancelled)` once cancelled.
    pub fn check(&self) -> Result<(), Cancelled> {
        if self.is_cancelled() {
            Err(Cancelled)
        } else {
            Ok(())
        }
    }

    /// Reports `done` of `total` units of `stage`.
    pub fn report(&self, stage: &str, done: u64, total: u64) {
        if let Some(f) = &self.progress {
            f(stage, done, total);
        }
    }

    /// A counter for `total` units of `stage` that parallel workers advance; it reports at
    /// most about 200 times (and always at the end).
    pub fn counter(&self, stage: &str, total: u64) -> Counter<'_> {
        self.report(stage, 0, total);
        Counter {
            job: self,
            stage: stage.to_owned(),
            total,
            done: AtomicU64::new(0),
            step: (total / 200).max(1),
        }
    }
}

/// Progress of one stage of a [`Job`], advanced from any thread.
#[derive(Debug)]
pub struct Counter<'a> {
    job: &'a Job,
    stage: String,
    total: u64,
    done: AtomicU64,
    step: u64,
}

impl Counter<'_> {
    /// Records `n` more units done, reporting when a step boundary is crossed.
    pub fn advance(&self, n: u64) {
        if self.job.progress.is_none() {
            return;
        }
        let before = self.done.fetch_add(n, Ordering::Relaxed);
        let after = before + n;
        if after / self.step != before / self.step || after == self.total {
            self.job
                .report(&self.stage, after.min(self.total), self.total);
        }
    }

    /// The job, for cancellation checks.
    pub fn job(&self) -> &Job {
        self.job
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;
    use std::sync::Mutex;

    #[test]
    fn parallel_counter_reports_sparsely_and_ends_at_the_total() {
        let seen = Arc::new(Mutex::new(Vec::new()));
        let log = seen.clone();
        let job = Job::new().with_progress(move |_, d, t| log.lock().unwrap().push((d, t)));
        let c = job.counter("x", 10_000);
        (0..10_000).into_par_iter().for_each(|_| c.advance(1));
        let seen = seen.lock().unwrap();
        assert!(seen.len() <= 205, "{} reports", seen.len());
        assert!(seen.contains(&(10_000, 10_000)));
        assert_eq!(seen[0], (0, 10_000));
    }

    #[test]
    fn clones_share_the_cancellation() {
        let job = Job::new();
        let other = job.clone();
        assert!(job.check().is_ok());
        other.cancel();
        assert_eq!(job.check(), Err(Cancelled));
    }
}
