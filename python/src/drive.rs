//! Run the library's work on a worker thread with the GIL released, while
//! the calling thread relays progress to Python and watches its signals.
//!
//! The workers live as long as the interpreter and are reused: a thread
//! made for one run would pay the page faults of a fresh malloc arena (half
//! a millisecond for the spiral, 7 % of its run), and node processes die
//! with the thread that started them (`PR_SET_PDEATHSIG`), which a
//! long-lived thread makes the interpreter's own lifetime.

use crossbeam::channel::{self, Receiver, RecvTimeoutError, Sender};
use pyo3::prelude::*;
use sonarnet::engine::interrupt;
use std::sync::Mutex;
use std::time::Duration;

/// How often the waiting thread wakes to let Python run its signal
/// handlers (Ctrl-C) and draw progress.
const POLL: Duration = Duration::from_millis(100);

/// What the worker tells the waiting thread.
enum Msg<T> {
    /// `done` units of work completed; `text` for the bar's postfix.
    Progress(u64, String),
    /// The work's result, or the text of its panic.
    Done(Result<T, String>),
}

/// Progress as the worker reports it: units completed and a short text.
pub type Tick<'a> = &'a (dyn Fn(u64, String) + Sync);

type Job = Box<dyn FnOnce() + Send + 'static>;

/// Workers waiting for a job.
static IDLE: Mutex<Vec<Sender<Job>>> = Mutex::new(Vec::new());

/// An idle worker, or a new one.
fn worker() -> PyResult<Sender<Job>> {
    if let Some(w) = IDLE.lock().ok().and_then(|mut idle| idle.pop()) {
        return Ok(w);
    }
    let (tx, rx): (Sender<Job>, Receiver<Job>) = channel::unbounded();
    std::thread::Builder::new()
        .name("sonarnet-run".into())
        .spawn(move || {
            for job in rx {
                job();
            }
        })
        .map_err(|e| {
            pyo3::exceptions::PyRuntimeError::new_err(format!("cannot start a worker thread: {e}"))
        })?;
    Ok(tx)
}

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
pub fn drive<T: Send + 'static>(
    py: Python<'_>,
    progress: Option<&Bound<'_, PyAny>>,
    work: impl FnOnce(Tick<'_>) -> T + Send + 'static,
) -> PyResult<Driven<T>> {
    interrupt::clear();
    let (tx, rx) = channel::unbounded::<Msg<T>>();
    let wants_progress = progress.is_some();
    let w = worker()?;
    let job: Job = Box::new(move || {
        let ticks = tx.clone();
        let tick = move |done: u64, text: String| {
            // Without a bar, the waiting thread is not woken per tick.
            if wants_progress {
                let _ = ticks.send(Msg::Progress(done, text));
            }
        };
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| work(&tick)));
        let r = r.map_err(|p| {
            p.downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default()
        });
        let _ = tx.send(Msg::Done(r));
    });
    if w.send(job).is_err() {
        return Err(pyo3::exceptions::PyRuntimeError::new_err(
            "sonarnet: a worker thread is gone",
        ));
    }
    let mut interrupted: Option<PyErr> = None;
    let result = loop {
        let mut msg = py.detach(|| rx.recv_timeout(POLL));
        // Draw only the latest of the ticks that came meanwhile.
        while let Ok(Msg::Progress(..)) = msg {
            match rx.try_recv() {
                Ok(next) => msg = Ok(next),
                Err(_) => break,
            }
        }
        match msg {
            Ok(Msg::Done(r)) => break r,
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
            Err(RecvTimeoutError::Disconnected) => {
                break Err("the worker thread ended without a result".into());
            }
        }
        if interrupted.is_none()
            && let Err(e) = py.check_signals()
        {
            interrupt::request();
            interrupted = Some(e);
        }
    };
    if let Ok(mut idle) = IDLE.lock() {
        idle.push(w);
    }
    interrupt::clear();
    let value = result.map_err(|what| {
        pyo3::exceptions::PyRuntimeError::new_err(format!(
            "sonarnet: internal error (a panic in the run): {what}"
        ))
    })?;
    Ok(Driven { value, interrupted })
}
