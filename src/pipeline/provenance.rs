//! Where and when a run was made, recorded in `run.json`: the UTC start
//! time, the host name, the sonarnet version and git commit (embedded by
//! `build.rs` when built from a git checkout), and absolute input paths.

use crate::scenario::{DataSource, Scenario};
use std::collections::BTreeMap;
use std::path::Path;
use std::time::{SystemTime, UNIX_EPOCH};

/// The git commit this binary was built from, if it was built from a git
/// checkout (`build.rs`).
pub const GIT_COMMIT: Option<&str> = option_env!("SONARNET_GIT_COMMIT");

/// `t` as an ISO 8601 UTC time with seconds, `2026-12-03T01:02:03Z`.
pub fn utc_iso(t: SystemTime) -> String {
    let secs = t
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs() as i64);
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    let (y, m, d) = civil_from_days(days);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// Proleptic Gregorian date of day `z` since 1970-01-01 (H. Hinnant's
/// `civil_from_days`).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (if m <= 2 { y + 1 } else { y }, m, d)
}

/// This machine's host name.
pub fn host_name() -> Option<String> {
    let mut buf = [0u8; 256];
    // SAFETY: the buffer is valid for its length; gethostname writes at most
    // that many bytes.
    let rc = unsafe { libc::gethostname(buf.as_mut_ptr().cast(), buf.len()) };
    if rc != 0 {
        return None;
    }
    let end = buf.iter().position(|&b| b == 0).unwrap_or(buf.len());
    let s = String::from_utf8_lossy(&buf[..end]).trim().to_string();
    (!s.is_empty()).then_some(s)
}

fn absolute(p: &Path) -> String {
    std::fs::canonicalize(p)
        .or_else(|_| std::path::absolute(p))
        .unwrap_or_else(|_| p.to_path_buf())
        .display()
        .to_string()
}

/// Absolute paths of a scenario's input files: `scenario`, and `trace`,
/// `truth`, `schedule` when it names them.
pub fn input_paths<const D: usize>(sc: &Scenario<D>) -> BTreeMap<String, String> {
    let mut m = BTreeMap::new();
    m.insert("scenario".to_string(), absolute(&sc.path));
    let base = sc.path.parent().unwrap_or(Path::new("."));
    if let DataSource::Trace { path, .. } = &sc.source {
        m.insert("trace".into(), absolute(path));
    }
    if let Some(t) = &sc.file.measurements.truth {
        m.insert("truth".into(), absolute(&base.join(t)));
    }
    if let Some((p, _)) = &sc.algorithm.schedule {
        m.insert("schedule".into(), absolute(p));
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn utc_times_match_known_dates() {
        let at = |s: u64| utc_iso(UNIX_EPOCH + Duration::from_secs(s));
        assert_eq!(at(0), "1970-01-01T00:00:00Z");
        // 2000-02-29 (a leap day of a century leap year) 12:34:56.
        assert_eq!(at(951_827_696), "2000-02-29T12:34:56Z");
        // 2026-12-03 00:39:34 (the `date` of this session).
        assert_eq!(at(1_796_258_374), "2026-12-03T00:39:34Z");
        // 2100-03-01, after a non-leap century February.
        assert_eq!(at(4_107_542_400), "2100-03-01T00:00:00Z");
    }

    #[test]
    fn civil_dates_walk_day_by_day_through_every_month_length() {
        let mut prev = civil_from_days(-1);
        for z in 0..(400 * 366) {
            let (y, m, d) = civil_from_days(z);
            let py = prev.0;
            let leap = (py % 4 == 0 && py % 100 != 0) || py % 400 == 0;
            let len = [
                31,
                if leap { 29 } else { 28 },
                31,
                30,
                31,
                30,
                31,
                31,
                30,
                31,
                30,
                31,
            ];
            if d == 1 {
                // The previous day was the last of its month.
                assert_eq!(prev.2, len[(prev.1 - 1) as usize], "{prev:?}");
                assert_eq!(
                    (y, m),
                    if prev.1 == 12 {
                        (py + 1, 1)
                    } else {
                        (py, prev.1 + 1)
                    }
                );
            } else {
                assert_eq!((y, m, d - 1), prev);
            }
            prev = (y, m, d);
        }
    }

    #[test]
    fn the_host_name_is_this_machines() {
        let h = host_name().expect("a host name");
        let etc = std::fs::read_to_string("/proc/sys/kernel/hostname").unwrap_or_default();
        assert_eq!(h, etc.trim());
    }
}
