//! Long work off the interpreter: the library runs on a worker thread with the GIL released, while
//! the calling thread wakes every few tens of milliseconds to check for Ctrl-C (Python runs its
//! signal handlers only on the main thread) and to hand the latest progress to a Python callback.
//!
//! An interrupt is delivered to the library through its own observer: the next time the library
//! reports progress, the observer unwinds with an [`Interrupted`] payload (`resume_unwind`, so no
//! panic message is printed), which the worker catches. Nothing the library built is kept.

use std::panic::{catch_unwind, resume_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::Duration;

use pyo3::prelude::*;
use spincal::progress::{Observer, Progress};

use crate::errors::Error;

/// The unwind payload that stops library work after Ctrl-C (or a failing progress callback).
struct Interrupted;

/// A progress report as the Python callback receives it: stage, done, total.
type Snapshot = (String, usize, Option<usize>);

/// How often the calling thread looks at signals and progress.
const POLL: Duration = Duration::from_millis(40);

/// Runs `work` on a worker thread with the GIL released; `progress(stage, done, total)` is called
/// on the calling thread with the latest report. Ctrl-C raises `KeyboardInterrupt` once the library
/// next reports progress.
pub fn run<T: Send>(
    py: Python<'_>,
    progress: Option<&Bound<'_, PyAny>>,
    work: impl FnOnce(&Observer) -> T + Send,
) -> PyResult<T> {
    let cancel = AtomicBool::new(false);
    // Reports not yet handed over: the latest of each stage, in order (a stage that came and went
    // between two polls is still shown).
    let pending: Mutex<Vec<Snapshot>> = Mutex::new(Vec::new());
    let done = (Mutex::new(false), Condvar::new());
    let want_progress = progress.is_some();
    let observer = |p: Progress<'_>| {
        if cancel.load(Ordering::Relaxed) {
            resume_unwind(Box::new(Interrupted));
        }
        if want_progress {
            if let Ok(mut queue) = pending.lock() {
                match queue.last_mut() {
                    Some(last) if last.0 == p.stage => {
                        last.1 = p.done;
                        last.2 = p.total;
                    }
                    _ => queue.push((p.stage.to_string(), p.done, p.total)),
                }
            }
        }
    };
    std::thread::scope(|scope| {
        let worker = scope.spawn(|| {
            let outcome = catch_unwind(AssertUnwindSafe(|| work(&observer)));
            let (lock, signal) = &done;
            if let Ok(mut finished) = lock.lock() {
                *finished = true;
            }
            signal.notify_all();
            outcome
        });
        let mut failure: Option<PyErr> = None;
        loop {
            let finished = py.detach(|| {
                let (lock, signal) = &done;
                let Ok(guard) = lock.lock() else { return true };
                match signal.wait_timeout_while(guard, POLL, |finished| !*finished) {
                    Ok((guard, _)) => *guard,
                    Err(_) => true,
                }
            });
            if failure.is_none() {
                if let Err(e) = py.check_signals() {
                    failure = Some(e);
                    cancel.store(true, Ordering::Relaxed);
                }
            }
            if let (Some(callback), None) = (progress, &failure) {
                let reports = pending
                    .lock()
                    .map(|mut queue| std::mem::take(&mut *queue))
                    .unwrap_or_default();
                for (stage, n, total) in reports {
                    if let Err(e) = callback.call1((stage, n, total)) {
                        failure = Some(e);
                        cancel.store(true, Ordering::Relaxed);
                        break;
                    }
                }
            }
            if finished {
                break;
            }
        }
        let outcome = match worker.join() {
            Ok(outcome) => outcome,
            Err(payload) => Err(payload),
        };
        match (outcome, failure) {
            (_, Some(e)) => Err(e),
            (Ok(value), None) => Ok(value),
            (Err(payload), None) => {
                let text = payload
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_else(|| "unknown".to_string());
                Err(Error::new_err(format!(
                    "internal error in the spincal library (please report it): {text}"
                )))
            }
        }
    })
}
