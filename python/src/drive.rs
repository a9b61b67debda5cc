//! Run the library's work on a worker thread with the GIL released, while
//! the calling thread relays progress to Python and watches its signals.

use crossbeam::channel::{self, RecvTimeoutError};
use pyo3::prelude::*;
use sonarnet::engine::interrupt;
use std::time::Duration;

/// How often the waiting thread wakes to let Python run its signal
/// handlers (Ctrl-C) and draw progress.
const POLL: Duration = Duration::from_millis(100);

/// What the worker tells the waiting thread.
enum Msg {
    /// `done` units of work completed; `text` for the bar's postfix.
    Progress(u64, String),
}

/// Progress as the worker reports it: units completed and a short text.
pub type Tick<'a> = &'a (dyn Fn(u64, String) + Sync);

/// What [`drive`] returns: the work's result and whether Ctrl-C asked it
/// to stop.
pub struct Driven<T> {
    /// The work's result.
    pub value: T,
    /// Ctrl-C (or another exception from a signal handler) came while it
    /// ran: the engines were asked to stop, and the exception is here.
    pub interrupted: Option<PyErr>,
}

/// Run `work` on a worker thread. `progress` (a Python callable taking
/// `(done, text)`) hears of its ticks; every [`POLL`] the calling thread
/// checks Python's signals, and an exception there (KeyboardInterrupt)
/// asks the engines to stop ([`interrupt::request`]) and is kept for the
/// caller, who raises it once the work has ended in order.
pub fn drive<T: Send>(
    py: Python<'_>,
    progress: Option<&Bound<'_, PyAny>>,
    work: impl FnOnce(Tick<'_>) -> T + Send,
) -> PyResult<Driven<T>> {
    interrupt::clear();
    let (tx, rx) = channel::unbounded::<Msg>();
    let mut interrupted: Option<PyErr> = None;
    let value = std::thread::scope(|s| -> PyResult<T> {
        let worker = s.spawn(move || {
            let tick = move |done: u64, text: String| {
                let _ = tx.send(Msg::Progress(done, text));
            };
            work(&tick)
        });
        loop {
            let msg = py.detach(|| rx.recv_timeout(POLL));
            match msg {
                Ok(Msg::Progress(done, text)) => {
                    if let Some(cb) = progress
                        && let Err(e) = cb.call1((done, text))
                    {
                        if e.is_instance_of::<pyo3::exceptions::PyKeyboardInterrupt>(py) {
                            // Python ran its SIGINT handler inside the
                            // callback: Ctrl-C.
                            if interrupted.is_none() {
                                interrupt::request();
                                interrupted = Some(e);
                            }
                        } else {
                            // A broken progress callback must not lose the run.
                            e.print(py);
                        }
                    }
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
            if interrupted.is_none()
                && let Err(e) = py.check_signals()
            {
                interrupt::request();
                interrupted = Some(e);
            }
        }
        py.detach(|| worker.join()).map_err(|p| {
            let what = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            pyo3::exceptions::PyRuntimeError::new_err(format!(
                "sonarnet: internal error (a panic in the run): {what}"
            ))
        })
    });
    interrupt::clear();
    Ok(Driven {
        value: value?,
        interrupted,
    })
}
