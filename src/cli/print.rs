//! Terminal output: progress bars and run summaries.

use super::*;

pub(super) fn progress_bar(opts: &RunOptions, samples: u64) -> Option<indicatif::ProgressBar> {
    if !opts.progress {
        return None;
    }
    let b = indicatif::ProgressBar::new(samples);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} samples, {msg}",
    ) {
        b.set_style(style);
    }
    Some(b)
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

pub(super) fn print_summary(o: &pipeline::Outcome, dir: &std::path::Path) {
    let m = &o.metrics;
    println!(
        "sonarnet run: {} / {} / {} clock, seed {}",
        m.engine, m.mode, m.clock, m.seed
    );
    println!("  samples            {}/{}", m.samples_completed, m.samples);
    println!("  rmse               {} m", fmt_opt(m.rmse));
    println!("  rmse_after_burn_in {} m", fmt_opt(m.rmse_after_burn_in));
    println!("  median_error       {} m", fmt_opt(m.median_error));
    println!("  final_error        {} m", fmt_opt(m.final_error));
    println!("  ctte               {} m", fmt_opt(m.ctte));
    println!("  max_disagreement   {:.3} m", m.max_disagreement);
    println!("  ml_rmse            {} m", fmt_opt(m.ml_rmse));
    println!("  crlb_rms           {} m", fmt_opt(m.crlb_rms));
    println!("  iterations         {}", m.iterations);
    println!("  prox_solves        {}", m.prox_solves);
    println!("  wall_seconds       {:.4}", m.wall_seconds);
    if let Some(n) = &m.note {
        println!("  note: {n}");
    }
    print_tracks(&o.scored);
    print_expect(&m.expect);
    println!("  results in {}", dir.display());
}

fn print_tracks(s: &crate::pipeline::score::Scored) {
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

pub(super) fn print_mc_summary(sc: &Scenario, mc: &crate::pipeline::montecarlo::MonteCarloOutcome) {
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
        sc.seed.wrapping_add(mc.requested as u64),
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
    // RMS over trials: sqrt(mean of the per-trial RMSE^2), every sample of
    // every trial pooled (what README quotes); next to the mean RMSE.
    let rms = |k: &str| {
        let v: Vec<f64> = mc
            .trials
            .iter()
            .filter_map(|t| t.flat.get(k).copied())
            .filter(|x| x.is_finite())
            .collect();
        (!v.is_empty()).then(|| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt())
    };
    println!(
        "  {:<14} {:>12} {:>12} {:>12} {:>12} {:>12}",
        "track", "rmse (mean)", "rmse (rms)", "median", "ctte", "regret"
    );
    println!("  (means over the trials; rms = sqrt(mean of the per-trial rmse^2))");
    for n in &names {
        println!(
            "  {:<14} {:>12} {:>12} {:>12} {:>12} {:>12}",
            n,
            fmt_opt(mean(&format!("{n}.rmse"))),
            fmt_opt(rms(&format!("{n}.rmse"))),
            fmt_opt(mean(&format!("{n}.median_error"))),
            fmt_opt(mean(&format!("{n}.ctte"))),
            fmt_opt(mean(&format!("{n}.regret")))
        );
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
    use super::eng;

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
