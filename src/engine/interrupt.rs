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

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, OnceLock};

/// The process's interrupt flag, set by SIGINT or SIGTERM (handlers
/// registered on first use).
pub fn flag() -> Arc<AtomicBool> {
    static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();
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
    flag().load(std::sync::atomic::Ordering::SeqCst)
}
