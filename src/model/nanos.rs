//! The emulated time of the acoustic channel and the discrete-event engine:
//! integer nanoseconds.

/// Emulated time in integer nanoseconds since the start of the run: the one
/// time of the medium, and of the discrete-event engine's queue (a
/// `Duration` there), so that two instants compare exactly.
pub type Nanos = u64;

/// `secs` seconds as [`Nanos`], rounded to the nearest nanosecond (0 for
/// negative or NaN input, saturating above about 584 years).
pub fn nanos(secs: f64) -> Nanos {
    let ns = (secs * 1e9).round();
    if ns.is_nan() || ns <= 0.0 {
        0
    } else if ns >= u64::MAX as f64 {
        u64::MAX
    } else {
        ns as u64
    }
}

/// [`Nanos`] as seconds (for the records and the CSVs).
pub fn seconds(ns: Nanos) -> f64 {
    ns as f64 / 1e9
}
