//! Long calls that Ctrl-C and progress callbacks can stop.
//!
//! Python runs signal handlers only when the main thread executes Python code, so a long Rust
//! call with the GIL released would ignore Ctrl-C until it ends. [`run_interruptible`] runs the
//! core on a worker thread with a [`Monitor`] and keeps the calling thread free: every
//! [`POLL_INTERVAL`] (and whenever the core reports progress) it takes the GIL briefly, runs
//! `PyErr_CheckSignals` and calls the user's progress callback. When either raises, the
//! worker's [`Cancel`] token is set, the worker stops at its next check (per chunk, candidate or
//! step in the core), and *that* exception — `KeyboardInterrupt`, or whatever the callback
//! raised — propagates to the caller. A panic of the core becomes `InternalError`, as in
//! [`crate::errors::run`].

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use pyo3::prelude::*;
use stiffness_core::{Cancel, Monitor, Progress};

use crate::errors::panic_error;

/// How often the calling thread checks Python's signals while the core works: short enough to
/// stop well within a second of Ctrl-C, long enough to cost nothing (one GIL round trip).
pub const POLL_INTERVAL: Duration = Duration::from_millis(50);

/// Runs `f` on a worker thread with the GIL released, polling Python signals and forwarding
/// progress to `progress(stage, done, total)`; see the module docs.
pub fn run_interruptible<T, F>(py: Python<'_>, progress: Option<&Py<PyAny>>, f: F) -> PyResult<T>
where
    F: FnOnce(&Monitor<'_>) -> T + Send,
    T: Send,
{
    let cancel = Cancel::new();
    let (outcome, failure) = py.detach(|| {
        let (tx, rx) = mpsc::channel::<Progress>();
        std::thread::scope(|s| {
            let worker_cancel = cancel.clone();
            let worker = s.spawn(move || {
                let sink = move |p: Progress| {
                    // The receiver lives until the worker is joined.
                    let _ = tx.send(p);
                };
                let monitor = Monitor::new(worker_cancel).with_progress(&sink);
                catch_unwind(AssertUnwindSafe(|| f(&monitor)))
                // `sink` (and with it the sender) is dropped here: the loop below ends.
            });
            let mut failure: Option<PyErr> = None;
            let mut fail = |e: PyErr| {
                if failure.is_none() {
                    cancel.cancel();
                    failure = Some(e);
                }
            };
            let mut last_check = Instant::now();
            loop {
                let received = rx.recv_timeout(POLL_INTERVAL);
                let disconnected = matches!(received, Err(mpsc::RecvTimeoutError::Disconnected));
                if let (Ok(p), Some(cb)) = (&received, progress) {
                    if !cancel.is_cancelled() {
                        if let Err(e) =
                            Python::attach(|py| cb.call1(py, (p.stage, p.done, p.total)))
                        {
                            fail(e);
                        }
                    }
                }
                if disconnected {
                    break;
                }
                if last_check.elapsed() >= POLL_INTERVAL || received.is_err() {
                    last_check = Instant::now();
                    if let Err(e) = Python::attach(|py| py.check_signals()) {
                        fail(e);
                    }
                }
            }
            (worker.join(), failure)
        })
    });
    if let Some(e) = failure {
        // The cause of the cancel wins over whatever the stopped core returned.
        return Err(e);
    }
    match outcome {
        Ok(Ok(value)) => Ok(value),
        Ok(Err(payload)) | Err(payload) => Err(panic_error(payload)),
    }
}
