//! `sonarnet describe FILE`: what a scenario runs, in words.

use crate::estimators::gossip::Mode;
use crate::estimators::prox::LocalSolver;
use crate::scenario::DataSource;
use crate::scenario::Scenario;
use crate::scenario::expect;
use serde::Serialize;

/// A serialisable value in words: `gaussian (sigma 5)` for
/// `{ model = "gaussian", sigma = 5.0 }`; tags (`model`, `kind`) lead.
pub fn in_words(v: &impl Serialize) -> String {
    in_words_with(v, "")
}

/// The unit of a number under `key` in a description (` m`, ` s`, ...), or
/// `level` for a noise level (`sigma`, `mean`: ` m` for ranges, ` rad` for
/// directions of arrival).
fn unit_of(key: &str, level: &'static str) -> &'static str {
    match key {
        "sigma" | "mean" | "los_mean" | "nlos_mean" | "nlos_std" => level,
        "bit_rate" => " bit/s",
        "sound_speed" => " m/s",
        "time_scale" => "x",
        "header_bits" | "value_bits" => " bits",
        "sample_period_ms" => " ms",
        "wake_rate_hz" => " Hz",
        "carrier_khz" | "bandwidth_khz" => " kHz",
        "source_level_db" | "noise_level_db" => " dB",
        "at_s" | "for_s" | "interval_s" | "delay_s" | "jitter_s" => " s",
        "dr" | "r0" | "radius" | "half_width" | "center" | "position" | "start" | "min" | "max"
        | "velocity" | "points" => " m",
        "dt" | "t0" => " rad",
        _ => "",
    }
}

/// [`in_words`] with `level` as the unit of noise levels.
pub fn in_words_with(v: &impl Serialize, level: &'static str) -> String {
    fn go(v: &serde_json::Value, level: &'static str) -> String {
        use serde_json::Value;
        match v {
            Value::Object(m) => {
                let tag = ["model", "kind"]
                    .iter()
                    .find_map(|t| m.get(*t).and_then(Value::as_str));
                let rest: Vec<String> = m
                    .iter()
                    .filter(|(k, x)| !matches!(k.as_str(), "model" | "kind") && !x.is_null())
                    // A noise schedule that does not vary says nothing.
                    .filter(|(k, x)| !(k.as_str() == "schedule" && x.as_str() == Some("constant")))
                    .map(|(k, x)| {
                        let u = if x.is_number() || x.is_array() {
                            unit_of(k, level)
                        } else {
                            ""
                        };
                        format!("{k} {}{u}", go(x, level))
                    })
                    .collect();
                match (tag, rest.is_empty()) {
                    (Some(t), true) => t.to_string(),
                    (Some(t), false) => format!("{t} ({})", rest.join(", ")),
                    (None, _) => rest.join(", "),
                }
            }
            Value::Array(a) => format!(
                "[{}]",
                a.iter()
                    .map(|x| go(x, level))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            Value::String(s) => s.clone(),
            other => other.to_string(),
        }
    }
    serde_json::to_value(v).map_or_else(|e| format!("({e})"), |v| go(&v, level))
}

fn metres(x: f64) -> String {
    if x >= 10_000.0 {
        format!("{:.1} km", x / 1000.0)
    } else {
        format!("{x:.0} m")
    }
}

impl<const D: usize> Scenario<D> {
    /// What this scenario runs, one `(topic, text)` per line.
    pub fn describe(&self) -> Vec<(String, String)> {
        let mut out: Vec<(String, String)> = Vec::new();
        let mut put = |k: &str, v: String| out.push((k.to_string(), v));
        let f = &self.file;
        put(
            "scenario",
            format!(
                "{}{} — {}",
                self.name,
                self.variant
                    .as_ref()
                    .map_or(String::new(), |v| format!(" [{v}]")),
                if f.description.is_empty() {
                    "(no description)"
                } else {
                    &f.description
                }
            ),
        );
        put("seed", self.seed.to_string());
        let g = &self.geometry;
        put(
            "nodes",
            format!(
                "{}{} receivers (one node process each), {} transmitters",
                if D == 3 { "3-D (x, y, z; z up): " } else { "" },
                g.receivers.len(),
                g.transmitters.len()
            ),
        );
        if g.drifts() {
            let moving: Vec<String> = g
                .drift
                .iter()
                .enumerate()
                .filter_map(|(n, d)| {
                    d.as_ref().map(|d| match d {
                        crate::model::drift::Drift::Velocity { velocity } => {
                            format!("R{n} at {:?} m/sample", velocity.coords())
                        }
                        crate::model::drift::Drift::Waypoints { points, speed } => {
                            format!(
                                "R{n} through {} waypoints at {speed} m/sample",
                                points.len()
                            )
                        }
                    })
                })
                .collect();
            put(
                "drift",
                format!(
                    "{} (each node solves at its own position of every sample; receivers.csv)",
                    moving.join(", ")
                ),
            );
        }
        put("links", self.links_in_words());
        put("samples", self.samples_in_words());
        put("measurements", self.measurements_in_words());
        put("noise", self.noise_in_words());
        put("mode", self.mode_in_words());
        put("solver", self.solver_in_words());
        put("baselines", self.baselines_in_words());
        put(
            "bounds",
            self.bounds.as_ref().map_or("none".into(), in_words),
        );
        put("channel", in_words(&self.channel));
        put("faults", self.faults_in_words());
        put(
            "realtime",
            self.realtime
                .as_ref()
                .map_or("no [realtime] table (logical clock only)".into(), in_words),
        );
        if let Some(t) = self.trials {
            put(
                "monte carlo",
                format!(
                    "{t} trials, seeds {} to {}",
                    self.seed,
                    self.seed.wrapping_add(t as u64 - 1)
                ),
            );
        }
        let rel = expect::relations(&self.expect);
        put(
            "expect",
            if rel.is_empty() {
                "nothing (no [expect] block)".into()
            } else {
                rel.join("; ")
            },
        );
        out
    }

    /// The gossip graph's links: how many, how long, the node degrees (and
    /// each link when there are at most twelve).
    fn links_in_words(&self) -> String {
        let g = &self.geometry;
        let lens: Vec<(usize, usize, f64)> = self
            .graph
            .edges()
            .iter()
            .map(|&(a, b)| {
                let (p, q) = (g.receivers[a], g.receivers[b]);
                (a, b, (p - q).norm())
            })
            .collect();
        let mut sorted: Vec<f64> = lens.iter().map(|l| l.2).collect();
        sorted.sort_by(f64::total_cmp);
        let degree = (0..self.graph.len()).map(|v| self.graph.degree(v));
        let (dmin, dmax) = degree.fold((usize::MAX, 0), |(a, b), d| (a.min(d), b.max(d)));
        if sorted.is_empty() {
            return "none".into();
        }
        format!(
            "{} links, {} to {} long (median {}); node degree {dmin} to {dmax}{}",
            lens.len(),
            metres(sorted[0]),
            metres(sorted[sorted.len() - 1]),
            metres(sorted[sorted.len() / 2]),
            if lens.len() <= 12 {
                format!(
                    ": {}",
                    lens.iter()
                        .map(|(a, b, l)| format!("{a}-{b} {}", metres(*l)))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            } else {
                String::new()
            }
        )
    }

    /// Where the samples come from: the synthetic target's motion or a trace.
    fn samples_in_words(&self) -> String {
        match &self.source {
            DataSource::Synthetic { motion } => {
                format!(
                    "{} samples of a target moving as {}",
                    self.samples,
                    in_words(motion)
                )
            }
            DataSource::Trace { path, truth, .. } => format!(
                "{} samples read from the trace {}{}",
                self.samples,
                path.display(),
                if truth.is_some() {
                    " (with its true track)"
                } else {
                    " (no true track)"
                }
            ),
        }
    }

    /// What each sample measures.
    fn measurements_in_words(&self) -> String {
        let (m, g) = (&self.measurements, &self.geometry);
        let mut what = Vec::new();
        if m.bistatic {
            what.push(format!(
                "{} bistatic ranges",
                g.receivers.len() * g.transmitters.len()
            ));
        }
        if m.doa {
            what.push(format!(
                "{} directions of arrival{} (weight omega {})",
                g.receivers.len(),
                if D == 3 {
                    " as azimuth and elevation"
                } else {
                    ""
                },
                m.omega
            ));
        }
        if m.range {
            what.push(format!("{} one-way ranges", g.receivers.len()));
        }
        format!("per sample: {}", what.join(", "))
    }

    /// The noise of the ranges and directions, and the NLOS links.
    fn noise_in_words(&self) -> String {
        let m = &self.measurements;
        format!(
            "ranges: {}; directions: {}{}{}",
            m.range_noise
                .as_ref()
                .map_or("none".into(), |n| in_words_with(n, " m")),
            m.doa_noise
                .as_ref()
                .map_or("none".into(), |n| in_words_with(n, " rad")),
            match &m.elevation_noise {
                Some(n) => format!("; elevation: {}", in_words_with(n, " rad")),
                None if D == 3 && m.doa => "; elevation: as the azimuth".into(),
                None => String::new(),
            },
            if m.nlos_links == Default::default() {
                String::new()
            } else {
                format!("; NLOS links: {}", in_words(&m.nlos_links))
            }
        )
    }

    /// The gossip mode, its clock, step and iterations.
    fn mode_in_words(&self) -> String {
        let a = &self.algorithm;
        format!(
            "{} Douglas-Rachford gossip{}, gamma {:e}, {} iterations per sample, burn-in {} samples",
            match a.mode {
                Mode::Sync => "synchronous",
                Mode::Async => "asynchronous randomized",
            },
            a.clock
                .map_or(String::new(), |c| format!(" on the {} clock", in_words(&c))),
            a.gamma,
            a.iterations_per_sample,
            a.burn_in
        )
    }

    /// The local solver and its options.
    fn solver_in_words(&self) -> String {
        let a = &self.algorithm;
        format!(
            "{}{}, prox scaling {}, start {}, row weights {}",
            a.local_solver.as_str(),
            if a.local_solver == LocalSolver::GtrsL0 {
                format!(" (kappa {})", a.kappa)
            } else {
                String::new()
            },
            in_words(&a.prox_scaling),
            in_words(&a.init),
            in_words(&a.row_weights)
        )
    }

    /// The baselines by name (and kind, where the name differs).
    fn baselines_in_words(&self) -> String {
        if self.baselines.is_empty() {
            return "none (theta_bar and the centralised ML only)".into();
        }
        self.baselines
            .iter()
            .map(|b| {
                if b.name() == b.kind() {
                    b.name()
                } else {
                    format!("{} ({})", b.name(), b.kind())
                }
            })
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The fault schedule and the nemesis.
    fn faults_in_words(&self) -> String {
        let f = &self.file;
        if f.faults.is_empty() && self.nemesis.is_none() {
            return "none".into();
        }
        let mut v: Vec<String> = f.faults.iter().map(in_words).collect();
        if let Some(n) = &self.nemesis {
            v.push(format!("nemesis: {}", in_words(n)));
        }
        v.join("; ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_noise_model_reads_as_words() {
        let n: crate::model::noise::NoiseModel = toml::from_str::<toml::Table>(
            "v = { model = \"gaussian\", sigma = 5.0 }",
        )
        .unwrap()["v"]
            .clone()
            .try_into()
            .unwrap();
        assert_eq!(in_words(&n), "gaussian (sigma 5.0)");
    }
}
