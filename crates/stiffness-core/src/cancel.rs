//! Cooperative cancellation and progress reporting: one mechanism for every long loop.
//!
//! A long computation receives a [`Monitor`] and calls [`Monitor::check`] at natural
//! boundaries (per chunk of rows, per candidate, per simulated pose, per solver step) and
//! [`Monitor::report`] when a stage advances. Whoever started the computation keeps a clone of
//! the [`Cancel`] token and calls [`Cancel::cancel`] from any thread (a Ctrl-C handler, a
//! Python binding that saw `KeyboardInterrupt`, a progress sink whose callback failed); the
//! computation then returns [`Cancelled`] at its next check.
//!
//! Why polling rather than killing a thread: the computation unwinds through its own `?`s, so
//! nothing is left half-written and every buffer is dropped normally.
//!
//! Cost: a check is one relaxed atomic load (≈1 ns); checking once per chunk of a few
//! thousand rows is free next to the work. [`Monitor`] is `Sync`, so rayon workers may share
//! one `&Monitor` and poll it per chunk (the sufficient-statistics diagnose engine does so).

use std::fmt;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use thiserror::Error;

/// The computation was cancelled through its [`Cancel`] token (or its progress sink asked to
/// stop). It carries nothing: the caller knows why it cancelled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
#[error("cancelled")]
pub struct Cancelled;

/// A shared cancellation flag: cheap to clone, cheap to poll, settable from any thread.
///
/// Clones share the flag. Once cancelled a token stays cancelled; start a new computation
/// with a new token.
#[derive(Clone, Default)]
pub struct Cancel(Arc<AtomicBool>);

impl fmt::Debug for Cancel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Cancel")
            .field("cancelled", &self.is_cancelled())
            .finish()
    }
}

impl Cancel {
    /// A token that is not cancelled.
    pub fn new() -> Self {
        Self::default()
    }

    /// Asks every computation polling this token (or a clone) to stop.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// Whether [`cancel`](Self::cancel) has been called on this token or a clone.
    #[inline]
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }

    /// `Err(Cancelled)` once the token is cancelled, for use with `?` in a loop.
    #[inline]
    pub fn check(&self) -> Result<(), Cancelled> {
        if self.is_cancelled() {
            Err(Cancelled)
        } else {
            Ok(())
        }
    }
}

/// Where a long computation stands: `done` of `total` steps of `stage`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Progress {
    /// What is being done (a short lower-case word: "kinematics", "selection", "simulate"…).
    pub stage: &'static str,
    /// Steps done in this stage.
    pub done: usize,
    /// Steps in this stage (an upper bound where the count is not known in advance).
    pub total: usize,
}

/// What a long computation is handed: the cancellation token it polls and, optionally, a sink
/// for its progress.
///
/// The sink is `Fn + Sync` so that parallel workers may report through a shared `&Monitor`;
/// a sink that must mutate state uses interior mutability (a `Mutex`, an atomic, a channel).
/// A sink that wants the computation to stop (its callback failed) cancels the token it was
/// built with; [`Monitor::report`] returns [`Cancelled`] right after the call.
pub struct Monitor<'a> {
    cancel: Cancel,
    sink: Option<&'a (dyn Fn(Progress) + Sync)>,
}

impl fmt::Debug for Monitor<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Monitor")
            .field("cancel", &self.cancel)
            .field("sink", &self.sink.is_some())
            .finish()
    }
}

impl Default for Monitor<'_> {
    fn default() -> Self {
        Self::none()
    }
}

impl<'a> Monitor<'a> {
    /// A monitor nobody cancels and nobody listens to (the plain, blocking calls use it).
    pub fn none() -> Self {
        Self::new(Cancel::new())
    }

    /// A monitor polling `cancel`, without progress reporting.
    pub fn new(cancel: Cancel) -> Self {
        Self { cancel, sink: None }
    }

    /// The same monitor, reporting progress to `sink`.
    pub fn with_progress(mut self, sink: &'a (dyn Fn(Progress) + Sync)) -> Self {
        self.sink = Some(sink);
        self
    }

    /// The token this monitor polls (clone it to cancel from elsewhere).
    pub fn cancel_token(&self) -> &Cancel {
        &self.cancel
    }

    /// `Err(Cancelled)` once the token is cancelled.
    #[inline]
    pub fn check(&self) -> Result<(), Cancelled> {
        self.cancel.check()
    }

    /// Reports `progress` to the sink (if any), then checks the token, so that a sink which
    /// cancels stops the computation at once.
    pub fn report(&self, progress: Progress) -> Result<(), Cancelled> {
        if let Some(sink) = self.sink {
            sink(progress);
        }
        self.check()
    }
}
