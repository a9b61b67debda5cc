//! The worker pool of Monte Carlo trials and sweep runs: independent,
//! indexed jobs on scoped threads, taken in index order, stopping at Ctrl-C.

use std::ops::Range;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Runs `work(i)` for every `i` in `jobs` on up to `threads` scoped threads
/// (at least one, at most one per job), each taking the next index in order,
/// and calls `on_done(n)` after each, `n` the number finished so far
/// (counted from `jobs.start`, so that a caller that ran the first jobs
/// itself counts on). Once Ctrl-C or SIGTERM was requested
/// ([`crate::engine::interrupt::requested`]) no new job starts. Returns the
/// results by index (`result[i - jobs.start]`), `None` for a job not run.
/// Each result depends only on its index, so the outputs do not depend on
/// the thread count.
pub(crate) fn run_indexed<T: Send>(
    jobs: Range<usize>,
    threads: usize,
    work: impl Fn(usize) -> T + Sync,
    on_done: &(dyn Fn(usize) + Sync),
) -> Vec<Option<T>> {
    let n = jobs.len();
    let results: Mutex<Vec<Option<T>>> = Mutex::new((0..n).map(|_| None).collect());
    let next = AtomicUsize::new(jobs.start);
    let done = AtomicUsize::new(jobs.start);
    let stop = crate::engine::interrupt::requested;
    std::thread::scope(|s| {
        for _ in 0..threads.clamp(1, n.max(1)) {
            s.spawn(|| {
                while !stop() {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    if i >= jobs.end {
                        break;
                    }
                    let r = work(i);
                    if let Ok(mut v) = results.lock() {
                        v[i - jobs.start] = Some(r);
                    }
                    on_done(done.fetch_add(1, Ordering::Relaxed) + 1);
                }
            });
        }
    });
    results
        .into_inner()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_job_runs_once_and_its_result_lands_at_its_index() {
        for threads in [0, 1, 3, 16] {
            let count = AtomicUsize::new(0);
            let last = AtomicUsize::new(0);
            let r = run_indexed(
                5..12,
                threads,
                |i| {
                    count.fetch_add(1, Ordering::Relaxed);
                    i * i
                },
                &|n| {
                    last.fetch_max(n, Ordering::Relaxed);
                },
            );
            let want: Vec<Option<usize>> = (5..12).map(|i| Some(i * i)).collect();
            assert_eq!(r, want, "{threads} threads");
            assert_eq!(count.load(Ordering::Relaxed), 7);
            assert_eq!(
                last.load(Ordering::Relaxed),
                12,
                "counted on from the start"
            );
        }
    }

    #[test]
    fn no_jobs_give_no_results() {
        let r: Vec<Option<u8>> = run_indexed(3..3, 4, |_| 1, &|_| {});
        assert!(r.is_empty());
    }
}
