//! Ctrl-C and SIGTERM: an orderly stop of a run, whatever its engine.
//!
//! [`flag`] registers, once per process, handlers for SIGINT and SIGTERM that
//! set a shared flag. Every engine's [`Network`](super::Network) looks at it
//! while it waits (the processes engine in its receive loop, the in-process
//! and threads engines before every batch of node work) and turns it into
//! [`Event::Interrupted`](super::Event::Interrupted): the coordinator ends the
//! run with [`EngineError::Interrupted`](super::EngineError::Interrupted), and
//! what was completed is written and marked `interrupted`. A second signal
//! while the flag is set takes the signal's default action (the process
//! ends at once), so a run that does not stop can always be killed.
//!
//! A host that owns the process's signals (the Python interpreter, which
//! turns SIGINT into `KeyboardInterrupt`) calls [`embedded`] before any run:
//! the flag is then the host's to [`request`] and [`clear`], and no handler
//! is installed.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();

/// Take the flag without installing signal handlers: the embedding host
/// watches its own signals and sets the flag with [`request`]. Returns
/// false when the handlers were already installed (the flag is shared all
/// the same).
pub fn embedded() -> bool {
    let mut fresh = false;
    FLAG.get_or_init(|| {
        fresh = true;
        Arc::new(AtomicBool::new(false))
    });
    fresh
}

/// Ask every running engine to stop, as SIGINT does.
pub fn request() {
    flag().store(true, Ordering::SeqCst);
}

/// Forget a stop request once the interrupted run has ended, so that the
/// next run of a long-lived host starts afresh (the command line never
/// clears it: it exits).
pub fn clear() {
    flag().store(false, Ordering::SeqCst);
}

/// The process's interrupt flag, set by SIGINT or SIGTERM (handlers
/// registered on first use, unless [`embedded`] came first).
pub fn flag() -> Arc<AtomicBool> {
    FLAG.get_or_init(|| {
        let f = Arc::new(AtomicBool::new(false));
        for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
            // Registration only fails for forbidden signals; these are
            // allowed. The conditional default goes first, so that it sees
            // the flag as it was before this signal.
            let _ = signal_hook::flag::register_conditional_default(sig, Arc::clone(&f));
            let _ = signal_hook::flag::register(sig, Arc::clone(&f));
        }
        f
    })
    .clone()
}

/// Whether the process has been asked to stop.
pub fn requested() -> bool {
    flag().load(Ordering::SeqCst)
}
