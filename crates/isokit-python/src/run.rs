//! Running library calls from Python: the GIL released, Ctrl-C and progress handled on the
//! calling thread, panics caught.
//!
//! The work runs on a scoped worker thread (its rayon tasks on the global pool) while the
//! calling thread, without the GIL, wakes every 50 ms, takes the GIL briefly, runs
//! `Python::check_signals` (Ctrl-C raises `KeyboardInterrupt` there) and forwards the latest
//! progress report to the Python reporter. An interrupt, an exception in the reporter or a
//! reporter returning `False` cancels the [`Job`]; the work stops at its next check and the
//! Python exception is raised once it has. A panic anywhere in the work becomes a
//! `RuntimeError`: nothing unwinds across the interpreter.

use crate::errors::Cancelled;
use isokit_field::Job;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// The latest progress report, written by the work and read by the calling thread.
type Latest = Arc<Mutex<Option<(String, u64, u64)>>>;

/// The message of a caught panic.
fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_owned()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "(no message)".to_owned()
    }
}

/// A panic turned into a Python exception.
pub fn panic_error(p: &(dyn std::any::Any + Send)) -> PyErr {
    PyRuntimeError::new_err(format!(
        "isokit internal error (a bug; please report it): {}",
        panic_message(p)
    ))
}

/// Runs `f` with a caught panic (for quick calls that keep the GIL).
pub fn guarded<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|p| Err(panic_error(&*p)))
}

/// True for Python's `False` (not for other false values such as `None` or 0).
fn is_false(v: &Bound<'_, PyAny>) -> bool {
    v.cast::<pyo3::types::PyBool>().is_ok_and(|b| !b.is_true())
}

/// The reporter for `progress` (`None`: tqdm when installed; `False`: none; a callable:
/// called as `progress(stage, done, total)`), made by `isokit._progress.reporter`.
fn reporter(
    py: Python<'_>,
    progress: Option<&Bound<'_, PyAny>>,
    desc: &str,
) -> PyResult<Option<Py<PyAny>>> {
    let module = py.import("isokit._progress")?;
    let none = py.None();
    let arg = progress.map_or_else(|| none.bind(py).clone(), |p| p.clone());
    let r = module.call_method1("reporter", (arg, desc))?;
    Ok(if r.is_none() { None } else { Some(r.unbind()) })
}

/// Runs `work` without the GIL (see the module docs); `desc` names the call in progress bars.
pub fn run<T, F>(
    py: Python<'_>,
    progress: Option<&Bound<'_, PyAny>>,
    desc: &str,
    work: F,
) -> PyResult<T>
where
    T: Send,
    F: FnOnce(&Job) -> PyResult<T> + Send,
{
    let reporter = reporter(py, progress, desc)?;
    let cancel = Arc::new(AtomicBool::new(false));
    let latest: Latest = Arc::new(Mutex::new(None));
    let mut job = Job::new().with_cancel_flag(cancel.clone());
    if reporter.is_some() {
        let l = latest.clone();
        job = job.with_progress(move |stage, done, total| {
            if let Ok(mut g) = l.lock() {
                *g = Some((stage.to_owned(), done, total));
            }
        });
    }
    let finished = AtomicBool::new(false);
    let (result, interrupt) = py.detach(|| {
        let caller = std::thread::current();
        std::thread::scope(|scope| {
            let worker = scope.spawn(|| {
                let r = catch_unwind(AssertUnwindSafe(|| work(&job)));
                finished.store(true, Ordering::Release);
                caller.unpark();
                r
            });
            let mut interrupt: Option<PyErr> = None;
            loop {
                let done = finished.load(Ordering::Acquire);
                Python::attach(|py| {
                    if interrupt.is_none()
                        && let Err(e) = py.check_signals()
                    {
                        interrupt = Some(e);
                        cancel.store(true, Ordering::Relaxed);
                    }
                    let report = latest.lock().ok().and_then(|mut g| g.take());
                    if let (Some(r), Some((stage, d, t)), None) = (&reporter, report, &interrupt) {
                        match r.call_method1(py, "update", (stage, d, t)) {
                            Ok(v) if is_false(v.bind(py)) => {
                                interrupt = Some(Cancelled::new_err(
                                    "cancelled: the progress callback returned False",
                                ));
                                cancel.store(true, Ordering::Relaxed);
                            }
                            Ok(_) => {}
                            Err(e) => {
                                interrupt = Some(e);
                                cancel.store(true, Ordering::Relaxed);
                            }
                        }
                    }
                });
                if done {
                    break;
                }
                std::thread::park_timeout(Duration::from_millis(50));
            }
            let result = worker.join().unwrap_or_else(|p| {
                let msg: Box<dyn std::any::Any + Send> = Box::new(panic_message(&*p));
                Err(msg)
            });
            (result, interrupt)
        })
    });
    if let Some(r) = &reporter {
        let closed = r.call_method0(py, "close");
        if interrupt.is_none() && result.as_ref().is_ok_and(|r| r.is_ok()) {
            closed?;
        }
    }
    if let Some(e) = interrupt {
        return Err(e);
    }
    match result {
        Ok(r) => r,
        Err(p) => Err(panic_error(&*p)),
    }
}
