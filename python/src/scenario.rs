//! `sonarnet.Scenario`'s native half: a scenario file's text, its
//! overrides and the chosen variant, validated exactly as `sonarnet run`
//! validates them.

use crate::errors::{argument_error, scenario_error};
use crate::run::{self, RunArgs};
use pyo3::prelude::*;
use sonarnet::scenario::{AnyScenario, Override};
use std::path::PathBuf;

/// A validated scenario (every key checked, with its overrides and variant).
#[pyclass(name = "_Scenario", module = "sonarnet._sonarnet", frozen)]
pub struct PyScenario {
    /// Where the text came from (names it in errors; anchors the relative
    /// file names in it).
    pub path: PathBuf,
    /// The scenario text.
    pub text: String,
    /// The overrides, in order (`--set` rules).
    pub overrides: Vec<Override>,
    /// The chosen variant (`--variant`), if any.
    pub variant: Option<String>,
    /// The chosen scenario: the variant, else the file's first (or only)
    /// scenario.
    pub chosen: AnyScenario,
}

impl PyScenario {
    /// Validate `text` with `overrides` and `variant`, as `sonarnet run
    /// PATH --set ... --variant V` does.
    pub fn build(
        py: Python<'_>,
        path: PathBuf,
        text: String,
        overrides: Vec<Override>,
        variant: Option<String>,
    ) -> PyResult<Self> {
        let only: Vec<String> = variant.iter().cloned().collect();
        let all = AnyScenario::text_with(&path, &text, &overrides, &only)
            .map_err(|e| scenario_error(py, &e))?;
        let chosen = match &variant {
            Some(v) => all.into_iter().find(|s| s.variant() == Some(v.as_str())),
            None => all.into_iter().next(),
        };
        let Some(chosen) = chosen else {
            let names = variant_names(&text);
            return Err(argument_error(
                py,
                "variant",
                if names.is_empty() {
                    format!("{} has no [[variants]]", path.display())
                } else {
                    format!(
                        "no variant {:?} (the file has: {})",
                        variant.unwrap_or_default(),
                        names.join(", ")
                    )
                },
            ));
        };
        Ok(PyScenario {
            path,
            text,
            overrides,
            variant,
            chosen,
        })
    }
}

/// The names of the `[[variants]]` of scenario text, in file order.
fn variant_names(text: &str) -> Vec<String> {
    let Ok(t) = text.parse::<toml::Table>() else {
        return Vec::new();
    };
    t.get("variants")
        .and_then(toml::Value::as_array)
        .map(|vs| {
            vs.iter()
                .filter_map(|v| v.get("name").and_then(toml::Value::as_str))
                .map(str::to_owned)
                .collect()
        })
        .unwrap_or_default()
}

#[pymethods]
impl PyScenario {
    /// Read and validate a scenario file.
    #[staticmethod]
    #[pyo3(signature = (path, variant=None))]
    fn from_file(py: Python<'_>, path: PathBuf, variant: Option<String>) -> PyResult<Self> {
        let text = std::fs::read_to_string(&path).map_err(|e| {
            scenario_error(
                py,
                &sonarnet::model::error::InputError::file(
                    &path,
                    format!("cannot read scenario: {e}"),
                ),
            )
        })?;
        Self::build(py, path, text, Vec::new(), variant)
    }

    /// Validate scenario text; `path` names it in errors.
    #[staticmethod]
    #[pyo3(signature = (text, path=None, variant=None))]
    fn from_toml(
        py: Python<'_>,
        text: String,
        path: Option<PathBuf>,
        variant: Option<String>,
    ) -> PyResult<Self> {
        let path = path.unwrap_or_else(|| PathBuf::from("<string>"));
        Self::build(py, path, text, Vec::new(), variant)
    }

    /// A scenario built into sonarnet (`sonarnet list`).
    #[staticmethod]
    #[pyo3(signature = (name, variant=None))]
    fn builtin(py: Python<'_>, name: &str, variant: Option<String>) -> PyResult<Self> {
        let Some(text) = sonarnet::scenario::shipped::text(name) else {
            return Err(argument_error(
                py,
                "name",
                format!(
                    "no built-in scenario {name:?} (there are: {})",
                    sonarnet::scenario::shipped::names().join(", ")
                ),
            ));
        };
        let stem = name.strip_suffix(".toml").unwrap_or(name);
        Self::build(
            py,
            sonarnet::scenario::shipped::path(stem),
            text.to_string(),
            Vec::new(),
            variant,
        )
    }

    /// This scenario with more overrides, each `KEY=VALUE` as `--set`
    /// takes it.
    fn with_overrides(&self, py: Python<'_>, sets: Vec<String>) -> PyResult<Self> {
        let mut overrides = self.overrides.clone();
        for s in &sets {
            overrides.push(Override::parse(s).map_err(|e| scenario_error(py, &e))?);
        }
        Self::build(
            py,
            self.path.clone(),
            self.text.clone(),
            overrides,
            self.variant.clone(),
        )
    }

    /// This scenario's variant `name` (the overrides kept).
    fn with_variant(&self, py: Python<'_>, name: String) -> PyResult<Self> {
        Self::build(
            py,
            self.path.clone(),
            self.text.clone(),
            self.overrides.clone(),
            Some(name),
        )
    }

    /// The scenario's name.
    #[getter]
    fn name(&self) -> String {
        self.chosen.name().to_string()
    }

    /// The file it came from (or `<string>`).
    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    /// The chosen variant (None: the file's base or first variant).
    #[getter]
    fn variant(&self) -> Option<String> {
        self.chosen.variant().map(str::to_owned)
    }

    /// The names of the file's variants, in file order.
    #[getter]
    fn variants(&self) -> Vec<String> {
        variant_names(&self.text)
    }

    /// 2 or 3 (decided by the file's coordinates).
    #[getter]
    fn dim(&self) -> usize {
        self.chosen.dim()
    }

    /// The run seed.
    #[getter]
    fn seed(&self) -> u64 {
        self.chosen.seed()
    }

    /// Samples of the run.
    #[getter]
    fn samples(&self) -> usize {
        match &self.chosen {
            AnyScenario::Plane(s) => s.samples,
            AnyScenario::Space(s) => s.samples,
        }
    }

    /// Monte Carlo trials of the scenario's `[monte_carlo]` (None: one run).
    #[getter]
    fn trials(&self) -> Option<usize> {
        match &self.chosen {
            AnyScenario::Plane(s) => s.trials,
            AnyScenario::Space(s) => s.trials,
        }
    }

    /// The overrides applied, as `KEY=VALUE` texts.
    #[getter]
    fn overrides(&self) -> Vec<String> {
        self.overrides.iter().map(|o| o.text.clone()).collect()
    }

    /// The scenario text (before overrides).
    #[getter]
    fn text(&self) -> String {
        self.text.clone()
    }

    /// What `sonarnet describe` prints, as (key, value) pairs.
    fn describe(&self) -> Vec<(String, String)> {
        self.chosen.describe()
    }

    /// The warnings `sonarnet run` prints for this scenario.
    fn warnings(&self) -> Vec<String> {
        self.chosen.warnings()
    }

    /// Run it (the Python wrapper documents the arguments).
    #[pyo3(signature = (engine=None, clock=None, seed=None, mode=None, baselines=None, transport=None, poll_us=0, stall_timeout_s=5.0, out=None, progress=None))]
    #[allow(clippy::too_many_arguments)]
    fn run(
        &self,
        py: Python<'_>,
        engine: Option<String>,
        clock: Option<String>,
        seed: Option<u64>,
        mode: Option<String>,
        baselines: Option<Vec<String>>,
        transport: Option<String>,
        poll_us: u64,
        stall_timeout_s: f64,
        out: Option<PathBuf>,
        progress: Option<Bound<'_, PyAny>>,
    ) -> PyResult<Py<PyAny>> {
        let args = RunArgs {
            engine,
            clock,
            seed,
            mode,
            baselines,
            transport,
            poll_us,
            stall_timeout_s,
            out,
            trials: None,
        };
        run::run(py, self, &args, progress.as_ref())
    }

    /// Monte Carlo: `trials` runs over seeds `seed .. seed + trials`,
    /// written into `out`; returns whether Ctrl-C cut it short.
    #[pyo3(signature = (trials, out, seed=None, mode=None, baselines=None, clock=None, progress=None))]
    #[allow(clippy::too_many_arguments)]
    fn monte_carlo(
        &self,
        py: Python<'_>,
        trials: usize,
        out: PathBuf,
        seed: Option<u64>,
        mode: Option<String>,
        baselines: Option<Vec<String>>,
        clock: Option<String>,
        progress: Option<Bound<'_, PyAny>>,
    ) -> PyResult<bool> {
        let args = RunArgs {
            engine: None,
            clock,
            seed,
            mode,
            baselines,
            transport: None,
            poll_us: 0,
            stall_timeout_s: 5.0,
            out: Some(out),
            trials: Some(trials),
        };
        run::monte_carlo(py, self, &args, progress.as_ref())
    }

    fn __repr__(&self) -> String {
        format!(
            "Scenario({:?}{}{}, {}-D, seed {})",
            self.path.display().to_string(),
            self.chosen
                .variant()
                .map_or(String::new(), |v| format!(", variant={v:?}")),
            if self.overrides.is_empty() {
                String::new()
            } else {
                format!(", overrides={:?}", self.overrides())
            },
            self.chosen.dim(),
            self.chosen.seed()
        )
    }
}
