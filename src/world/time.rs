//! Emulated time as every engine orders it: a [`Duration`] since the start of
//! the run (integer nanoseconds), converted from the `f64` seconds of the
//! models in one place.

use std::time::Duration;

/// An absolute emulated time in seconds as a virtual time (nanoseconds, as
/// the discrete-event engine's queue orders events; saturating).
pub fn at(secs: f64) -> Duration {
    Duration::try_from_secs_f64(secs).unwrap_or(Duration::MAX)
}

/// A drawn wait or delay in seconds as a virtual duration, clamped to
/// `[0, 1 day]` (a wait that is not a number of seconds, negative or
/// NaN, is a day too: it never comes within a run).
pub fn wait(secs: f64) -> Duration {
    const DAY: Duration = Duration::from_secs(86_400);
    Duration::try_from_secs_f64(secs).map_or(DAY, |d| d.min(DAY))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_saturate_and_waits_are_clamped_to_a_day() {
        assert_eq!(at(1.5), Duration::from_millis(1500));
        assert_eq!(at(f64::INFINITY), Duration::MAX);
        assert_eq!(wait(2.0), Duration::from_secs(2));
        assert_eq!(wait(1e9), Duration::from_secs(86_400));
        assert_eq!(wait(f64::INFINITY), Duration::from_secs(86_400));
        assert_eq!(wait(-1.0), Duration::from_secs(86_400));
    }
}
