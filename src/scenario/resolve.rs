//! The fully resolved scenario of a run (`scenario.toml` in its results
//! directory): the file with every override applied, so that
//! `sonarnet run DIR/scenario.toml` reproduces the run.

use super::InitU;
use super::MonteCarloCfg;
use super::ScenarioFile;
use super::VariantCfg;
use crate::model::xy::Pt;
use crate::scenario::DataSource;
use crate::scenario::Scenario;
use std::path::Path;

impl<const D: usize> Scenario<D> {
    /// The scenario file this run amounts to: the file as loaded (with
    /// `--set` and a variant's keys already in it), plus the command-line
    /// shorthands (`--seed`, `--mode`, `--local-solver`, `--kappa`,
    /// `--prox-scaling`, `--iterations-per-sample`, `--samples`,
    /// `--baselines`, `--trials`, `--fault`, `--nemesis`), the receivers
    /// where a generator placed them, and input paths made absolute.
    pub fn resolved_file(&self) -> ScenarioFile {
        let mut f = self.file.clone();
        f.seed = self.seed;
        f.variants.clear();
        let a = &mut f.algorithm;
        a.mode = self.algorithm.mode;
        a.local_solver = self.algorithm.local_solver;
        a.kappa = self.algorithm.kappa;
        a.prox_scaling = self.algorithm.prox_scaling;
        a.iterations_per_sample = self.algorithm.iterations_per_sample;
        if let Some(t) = &mut f.target {
            t.samples = self.samples;
        }
        f.geometry.receivers = self.geometry.receivers.iter().map(Pt::of).collect();
        if f.algorithm.init_u == InitU::default() {
            f.algorithm.init_u = InitU::One(vec![0.0; D + 1]);
        }
        // A generator that draws the receivers (rgg with `count`) would
        // conflict with them listed: the graph it made is listed instead.
        if f.network.generator.is_some() {
            f.network.generator = None;
            f.network.edges = Some(self.graph.edges().iter().map(|&(a, b)| [a, b]).collect());
        }
        f.baselines = self.baselines.clone();
        f.monte_carlo = self.trials.map(|trials| MonteCarloCfg { trials });
        f.nemesis = self.nemesis.clone();
        let base = self.path.parent().unwrap_or(Path::new("."));
        let abs = |p: &str| {
            let p = base.join(p);
            std::path::absolute(&p).unwrap_or(p).display().to_string()
        };
        f.measurements.trace = f.measurements.trace.as_deref().map(abs);
        f.measurements.truth = f.measurements.truth.as_deref().map(abs);
        f.algorithm.schedule = f.algorithm.schedule.as_deref().map(abs);
        f
    }

    /// `scenario.toml` of a run written into a results directory: the
    /// [`Scenario::resolved_file`] as TOML. A single run (not Monte Carlo)
    /// reads its measurements, truth and (async logical clock) schedule from
    /// the files of that directory (`measurements.csv`, `truth.csv`,
    /// `schedule.csv`), which hold every value exactly; a Monte Carlo run
    /// draws them from the seeds again. `logical_async` says whether the
    /// run's schedule replays (async on the logical clock).
    pub fn resolved_toml(
        &self,
        logical_async: bool,
        how: &str,
    ) -> Result<String, toml::ser::Error> {
        let mut f = self.resolved_file();
        let single = self.trials.unwrap_or(1) <= 1;
        if single {
            f.measurements.trace = Some("measurements.csv".into());
            let has_truth = match &self.source {
                DataSource::Synthetic { .. } => true,
                DataSource::Trace { truth, .. } => truth.is_some(),
            };
            f.measurements.truth = has_truth.then(|| "truth.csv".into());
            // With `inverse_probability` scaling a schedule file sets
            // `p_v` to its empirical frequencies, which would change the
            // run: the schedule is then drawn from the seed again (or read
            // from the original file, if the run replayed one).
            if logical_async
                && self.algorithm.prox_scaling == crate::estimators::gossip::ProxScaling::None
            {
                f.algorithm.schedule = Some("schedule.csv".into());
            }
        }
        // The variant's name, so that the run is labelled as it was: a file
        // with this one variant (its keys are already merged in).
        if let Some(v) = &self.variant {
            f.variants = vec![VariantCfg {
                name: v.clone(),
                overrides: toml::Table::new(),
            }];
        }
        let body = toml::to_string(&f)?;
        Ok(format!(
            "# The resolved scenario of this run (sonarnet {}), with every override\n\
             # applied{}.\n\
             # Reproduce it with: {how}\n\n{body}",
            env!("CARGO_PKG_VERSION"),
            if single {
                "; the measurements, truth and schedule are this directory's\n\
                 # files (the [target] motion is then unused)"
            } else {
                ""
            }
        ))
    }
}
