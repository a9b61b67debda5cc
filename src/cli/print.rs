//! Terminal output: progress bars and run summaries.

use crate::pipeline;
use crate::pipeline::RunOptions;
use crate::scenario::Scenario;
use std::io::IsTerminal;

/// Progress of a run on standard error: a bar redrawn in place on a
/// terminal, else one plain line every [`Progress::LINE_EVERY`] (a log or a
/// CI job sees the run advance, not a wall of redraws); nothing when quiet.
pub(super) enum Progress {
    /// Nothing is shown.
    Off,
    /// indicatif's bar (standard error is a terminal).
    Bar(indicatif::ProgressBar),
    /// Plain lines: what is counted, the total, and when the last line went.
    Lines {
        unit: &'static str,
        total: u64,
        start: std::time::Instant,
        last: std::sync::Mutex<std::time::Instant>,
    },
}

impl Progress {
    /// How often a plain progress line is written.
    pub const LINE_EVERY: std::time::Duration = std::time::Duration::from_secs(5);

    /// Progress over `total` items called `unit` (`samples`, `trials`);
    /// `template` is the bar's indicatif template.
    pub fn new(show: bool, total: u64, unit: &'static str, template: &str) -> Progress {
        if !show {
            return Progress::Off;
        }
        if !std::io::stderr().is_terminal() {
            let now = std::time::Instant::now();
            return Progress::Lines {
                unit,
                total,
                start: now,
                last: std::sync::Mutex::new(now),
            };
        }
        let b = indicatif::ProgressBar::new(total);
        if let Ok(style) = indicatif::ProgressStyle::with_template(template) {
            b.set_style(style);
        }
        Progress::Bar(b)
    }

    /// `done` of the total are finished; `msg` adds to the line.
    pub fn set(&self, done: u64, msg: impl FnOnce() -> String) {
        match self {
            Progress::Off => {}
            Progress::Bar(b) => {
                b.set_position(done);
                b.set_message(msg());
            }
            Progress::Lines {
                unit,
                total,
                start,
                last,
            } => {
                let Ok(mut last) = last.lock() else { return };
                if last.elapsed() < Self::LINE_EVERY {
                    return;
                }
                *last = std::time::Instant::now();
                let line = progress_line(done, *total, unit, start.elapsed().as_secs_f64(), &msg());
                eprintln!("{line}");
            }
        }
    }

    /// Seconds since the progress began (for rates).
    pub fn elapsed_s(&self) -> f64 {
        match self {
            Progress::Off => 0.0,
            Progress::Bar(b) => b.elapsed().as_secs_f64(),
            Progress::Lines { start, .. } => start.elapsed().as_secs_f64(),
        }
    }

    /// Remove the bar (lines stay as written).
    pub fn finish(self) {
        if let Progress::Bar(b) = self {
            b.finish_and_clear();
        }
    }
}

/// One plain progress line: `progress: 30/100 samples, 12 s elapsed, about
/// 28 s left, MSG`.
pub(super) fn progress_line(
    done: u64,
    total: u64,
    unit: &str,
    elapsed_s: f64,
    msg: &str,
) -> String {
    let left = if done > 0 && done < total {
        format!(
            ", about {} left",
            duration_words(elapsed_s * (total - done) as f64 / done as f64)
        )
    } else {
        String::new()
    };
    let m = if msg.is_empty() {
        String::new()
    } else {
        format!(", {msg}")
    };
    format!(
        "progress: {done}/{total} {unit}, {} elapsed{left}{m}",
        duration_words(elapsed_s)
    )
}

/// The progress of one run over `samples` samples.
pub(super) fn progress_bar(opts: &RunOptions, samples: u64) -> Progress {
    Progress::new(
        opts.progress,
        samples,
        "samples",
        "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} samples, {msg}",
    )
}

/// A duration for a person: `45 s`, `12 min`, `1.7 h`.
pub fn duration_words(s: f64) -> String {
    if s < 90.0 {
        format!("{s:.0} s")
    } else if s < 5400.0 {
        format!("{:.0} min", s / 60.0)
    } else {
        format!("{:.1} h", s / 3600.0)
    }
}

fn fmt_opt(x: Option<f64>) -> String {
    x.map_or("-".into(), eng)
}

/// A number for the terminal: five significant digits between 1e-3 and
/// 1e6, engineering notation (an exponent that is a multiple of 3) outside,
/// never `-0`. `1.34e89` prints as `134.00e87`, `-0.0000123` as `-12.300e-6`.
pub fn eng(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if a == 0.0 {
        return "0".into();
    }
    let s = if (1e-3..1e6).contains(&a) {
        let decimals = (4 - a.log10().floor() as i32).clamp(0, 9) as usize;
        format!("{v:.decimals$}")
    } else {
        let e3 = (a.log10() / 3.0).floor() as i32 * 3;
        let m = v / 10f64.powi(e3);
        // Rounding can carry the mantissa to 1000: renormalise.
        let (m, e3) = if format!("{:.2}", m.abs()).starts_with("1000") {
            (m / 1000.0, e3 + 3)
        } else {
            (m, e3)
        };
        format!("{m:.2}e{e3}")
    };
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        "0".into()
    } else {
        s
    }
}

pub(super) fn print_summary<const D: usize>(o: &pipeline::Outcome<D>, dir: &std::path::Path) {
    let m = &o.metrics;
    let driver = match o.run.driver {
        Some(crate::protocol::Driver::LockStep) => " (lock-step)",
        Some(crate::protocol::Driver::DiscreteEvent) => " (discrete-event, virtual time)",
        _ => "",
    };
    println!(
        "sonarnet run: {}{}{driver} / {} / {} clock, seed {}",
        if D == 3 { "3-D, " } else { "" },
        m.engine,
        m.mode,
        m.clock,
        m.seed
    );
    println!("  samples            {}/{}", m.samples_completed, m.samples);
    if m.samples <= 1 {
        // One snapshot: rmse, median, final error and ctte are one number.
        println!("  error              {} m", fmt_opt(m.final_error));
    } else {
        println!("  rmse               {} m", fmt_opt(m.rmse));
        println!("  rmse_after_burn_in {} m", fmt_opt(m.rmse_after_burn_in));
        println!("  median_error       {} m", fmt_opt(m.median_error));
        println!("  final_error        {} m", fmt_opt(m.final_error));
        println!("  ctte               {} m", fmt_opt(m.ctte));
    }
    println!("  max_disagreement   {} m", eng(m.max_disagreement));
    println!("  ml_rmse            {} m", fmt_opt(m.ml_rmse));
    println!("  crlb_rms           {} m", fmt_opt(m.crlb_rms));
    println!("  iterations         {}", m.iterations);
    println!("  prox_solves        {}", m.prox_solves);
    println!("  wall_seconds       {} s", eng(m.wall_seconds));
    if let Some(c) = &m.channel {
        println!(
            "  channel            {} of {} frames delivered ({}), mean delay {}",
            c.delivered,
            c.frames,
            eng(c.delivery_ratio),
            c.delay_mean_s
                .map_or("-".into(), |d| format!("{} s", eng(d)))
        );
        if !c.lost.is_empty() {
            let lost: Vec<String> = c.lost.iter().map(|(k, n)| format!("{k} {n}")).collect();
            println!("  lost               {}", lost.join(", "));
        }
        if c.exchanges_attempted > 0 {
            println!(
                "  exchanges          {} of {} completed, {} timed out",
                c.exchanges_completed, c.exchanges_attempted, c.exchanges_timed_out
            );
        }
    }
    if let Some(n) = &m.note {
        println!("  note: {n}");
    }
    print_tracks(&o.scored);
    print_expect(&m.expect);
    println!("  results in {}", dir.display());
}

fn print_tracks<const D: usize>(s: &crate::pipeline::score::Scored<D>) {
    if s.tracks.len() <= 2 && s.tracks.iter().all(|t| t.bounds.is_empty()) {
        return;
    }
    println!(
        "  {:<14} {:>12} {:>12} {:>12} {:>12} {:>10}",
        "track", "rmse", "median", "ctte", "regret", "failures"
    );
    for t in &s.tracks {
        let m = &t.metrics;
        println!(
            "  {:<14} {:>12} {:>12} {:>12} {:>12} {:>10}",
            t.name,
            fmt_opt(m.rmse),
            fmt_opt(m.median_error),
            fmt_opt(m.ctte),
            fmt_opt(m.regret),
            m.failures
        );
        for (b, bm) in &m.bounds {
            println!(
                "    bound {b:<12} coverage {:.3}, empty {:.3}, mean tightness {} m",
                bm.coverage,
                bm.empty_fraction,
                fmt_opt(bm.mean_tightness)
            );
        }
    }
}

fn print_expect(checks: &[pipeline::ExpectResult]) {
    if checks.is_empty() {
        return;
    }
    let ok = checks.iter().filter(|c| c.holds).count();
    println!("  expect             {ok}/{} hold", checks.len());
    for c in checks.iter().filter(|c| !c.holds) {
        println!(
            "    FAILS: {} ({} vs {})",
            c.expect,
            fmt_opt(c.lhs),
            fmt_opt(c.rhs)
        );
    }
}

pub(super) fn print_mc_summary<const D: usize>(
    sc: &Scenario<D>,
    mc: &crate::pipeline::montecarlo::MonteCarloOutcome,
) {
    println!(
        "sonarnet run: Monte Carlo, {} (seeds {}..{}), in-process / {}{}, {:.2} s",
        if mc.interrupted {
            format!(
                "{} of {} trials (interrupted)",
                mc.trials.len(),
                mc.requested
            )
        } else {
            format!("{} trials", mc.trials.len())
        },
        sc.seed,
        // Inclusive, as `sweep --seeds A..B` reads: 100 trials are 0..99.
        sc.seed.wrapping_add(mc.requested as u64).wrapping_sub(1),
        sc.algorithm.mode.as_str(),
        sc.variant
            .as_ref()
            .map_or(String::new(), |v| format!(", variant {v}")),
        mc.wall_seconds
    );
    if mc.failed > 0 {
        println!("  failed trials      {}", mc.failed);
    }
    let mean = |k: &str| mc.stats.get(k).and_then(|s| s.get("mean").copied());
    let mut names: Vec<String> = vec!["theta_bar".into(), "ml".into()];
    names.extend(sc.baselines.iter().map(|b| b.name()));
    // The finite values of metric `k` across the trials.
    let values = |k: &str| -> Vec<f64> {
        mc.trials
            .iter()
            .filter_map(|t| t.flat.get(k).copied())
            .filter(|x| x.is_finite())
            .collect()
    };
    // RMS over trials: sqrt(mean of the per-trial RMSE^2), every sample of
    // every trial pooled (what the book quotes); next to the mean RMSE.
    let rms = |k: &str| {
        let v = values(k);
        (!v.is_empty()).then(|| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt())
    };
    // One snapshot per trial: rmse, median and ctte of a trial are its one
    // error, so show that error's distribution across the trials instead.
    let snapshot = sc.samples <= 1;
    let across = |k: &str, q: f64| crate::model::metrics::quantile(&values(k), q);
    if snapshot {
        println!(
            "  {:<14} {:>12} {:>12} {:>12} {:>12}",
            "track", "error (mean)", "error (rms)", "median", "90th pct"
        );
        println!("  (the one error of each trial, across the trials; metres)");
    } else {
        println!(
            "  {:<14} {:>12} {:>12} {:>12} {:>12} {:>12}",
            "track", "rmse (mean)", "rmse (rms)", "median", "ctte", "regret"
        );
        println!("  (means over the trials; rms = sqrt(mean of the per-trial rmse^2))");
    }
    for n in &names {
        if snapshot {
            let k = format!("{n}.rmse");
            println!(
                "  {:<14} {:>12} {:>12} {:>12} {:>12}",
                n,
                fmt_opt(mean(&k)),
                fmt_opt(rms(&k)),
                fmt_opt(across(&k, 0.5)),
                fmt_opt(across(&k, 0.9)),
            );
        } else {
            println!(
                "  {:<14} {:>12} {:>12} {:>12} {:>12} {:>12}",
                n,
                fmt_opt(mean(&format!("{n}.rmse"))),
                fmt_opt(rms(&format!("{n}.rmse"))),
                fmt_opt(mean(&format!("{n}.median_error"))),
                fmt_opt(mean(&format!("{n}.ctte"))),
                fmt_opt(mean(&format!("{n}.regret")))
            );
        }
        if let Some(b) = &sc.bounds {
            for k in &b.all_kinds() {
                let p = format!("{n}.bounds.{}", k.as_str());
                if let Some(c) = mean(&format!("{p}.coverage")) {
                    println!(
                        "    bound {:<12} coverage {:.3}, empty {:.3}, rel. tightness median {}",
                        k.as_str(),
                        c,
                        mean(&format!("{p}.empty_fraction")).unwrap_or(0.0),
                        fmt_opt(
                            mc.stats
                                .get(&format!("{p}.rel_tightness_median"))
                                .and_then(|s| s.get("median").copied())
                        )
                    );
                }
            }
        }
    }
    print_expect(&mc.expect);
    println!("  results in {}", mc.out_dir.display());
}

#[cfg(test)]
mod tests {
    use super::{duration_words, eng, progress_line};

    #[test]
    fn a_plain_progress_line_says_done_total_elapsed_and_what_is_left() {
        assert_eq!(
            progress_line(30, 100, "samples", 12.0, "40 iterations"),
            "progress: 30/100 samples, 12 s elapsed, about 28 s left, 40 iterations"
        );
        assert_eq!(
            progress_line(0, 5, "trials", 3.0, ""),
            "progress: 0/5 trials, 3 s elapsed"
        );
        assert_eq!(duration_words(6000.0), "1.7 h");
        assert_eq!(duration_words(600.0), "10 min");
    }

    #[test]
    fn terminal_numbers_keep_five_significant_digits_and_large_ones_go_engineering() {
        for (v, s) in [
            (283.507, "283.51"),
            (1.0, "1.0000"),
            (0.00123456, "0.0012346"),
            (123456.7, "123457"),
            (1.34e89, "134.00e87"),
            (-1.23e-5, "-12.30e-6"),
            (999_999.9, "1000000"),
            (2.5e6, "2.50e6"),
            (-0.0, "0"),
            (1e-300, "1.00e-300"),
            (f64::NAN, "NaN"),
        ] {
            assert_eq!(eng(v), s, "{v:e}");
        }
    }
}
