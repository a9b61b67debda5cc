//! Validation: a parsed [`ScenarioFile`] checked value by value and built
//! into a [`Scenario`], with one [`InputError`] naming the file, the key or
//! line, and the reason.

use super::BoundsCfg;
use super::ScenarioFile;
use super::sections;
use crate::model::error::{InputError, KeyError};
use crate::model::measure::Geometry;
use crate::scenario::Scenario;
use std::collections::BTreeSet;
use std::path::Path;
use std::path::PathBuf;

/// Check the baselines (parameters, unique names) and the `[bounds]` table
/// against them: a [`KeyError`]. The one check for the file and for
/// `--baselines`, which replaces the list (so `bounds.tracks` must still name
/// existing tracks).
/// TDMA on the acoustic channel: a given slot must hold the longest frame
/// and delay, and sync rounds need the SINR reception rule (their frames go
/// to and from the root, outside the gossip graph the slots are coloured on
/// under the graph rule).
pub(super) fn check_tdma<const D: usize>(
    ch: &crate::model::channel::AcousticCfg,
    geometry: &Geometry<D>,
    graph: &crate::model::graph::Graph,
    mode: super::Mode,
) -> Result<(), KeyError> {
    if !matches!(ch.mac, crate::model::mac::Mac::Tdma { .. }) {
        return Ok(());
    }
    let pos: Vec<crate::model::xy::Pt> = geometry
        .receivers
        .iter()
        .map(crate::model::xy::Pt::of)
        .collect();
    let links: Vec<Vec<u32>> = (0..pos.len())
        .map(|v| graph.neighbours(v).iter().map(|&j| j as u32).collect())
        .collect();
    ch.check_slot(&pos, &links)?;
    if mode == super::Mode::Sync && ch.reception.is_graph() {
        return Err(KeyError::new(
            "channel.mac",
            "tdma with sync rounds needs reception = { model = \"sinr\", ... }: the rounds' \
             frames go to and from the root, outside the gossip graph whose distance-2 \
             colouring gives the slots under the graph rule",
        ));
    }
    Ok(())
}

/// Whether the scenario's receivers measure one-way ranges: asked for in
/// `[measurements]`, or present in its trace.
pub(super) fn has_one_way_ranges<const D: usize>(
    source: &super::DataSource<D>,
    measurements: &super::MeasurementsCfg,
) -> bool {
    match source {
        super::DataSource::Synthetic { .. } => measurements.range,
        super::DataSource::Trace { measurements, .. } => measurements
            .iter()
            .any(|s| s.nodes.iter().any(|n| n.range.is_some())),
    }
}

pub(super) fn check_tracks<const D: usize>(
    baselines: &[crate::estimators::baselines::BaselineCfg],
    bounds: Option<&BoundsCfg>,
    geometry: &Geometry<D>,
    one_way: bool,
) -> Result<(), KeyError> {
    let mut names = BTreeSet::new();
    for (i, b) in baselines.iter().enumerate() {
        b.validate(geometry, !geometry.transmitters.is_empty())
            .map_err(|e| e.under(&format!("baselines[{i}]")))?;
        if matches!(b, crate::estimators::baselines::BaselineCfg::Sdp { .. }) && !one_way {
            return Err(KeyError::new(
                format!("baselines[{i}].kind"),
                "sdp (the SDP relaxation of Gholami 2015) takes one-way ranges, and this \
                 scenario measures none: set measurements.range = true",
            ));
        }
        if !names.insert(b.name()) {
            return Err(KeyError::new(
                format!("baselines[{i}].name"),
                format!(
                    "duplicate track name {:?}: give each baseline its own `name`",
                    b.name()
                ),
            ));
        }
    }
    let Some(b) = bounds else {
        return Ok(());
    };
    if b.names.is_empty() {
        return Err(KeyError::new("bounds.names", "list at least one bound"));
    }
    for (k, v) in [("bounds.rho", b.rho), ("bounds.rho_sigmas", b.rho_sigmas)] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(KeyError::new(
                k,
                format!("must be finite and >= 0, got {v}"),
            ));
        }
    }
    let keys = b
        .tracks
        .iter()
        .flatten()
        .enumerate()
        .map(|(i, t)| (format!("bounds.tracks[{i}]"), t))
        .chain(
            b.per_track
                .keys()
                .map(|t| (format!("bounds.per_track.{t}"), t)),
        );
    for (key, t) in keys {
        if t != "theta_bar" && t != "ml" && !names.contains(t) {
            return Err(KeyError::new(
                key,
                format!(
                    "no track {t:?}: use theta_bar, ml or a baseline name ({})",
                    names.iter().cloned().collect::<Vec<_>>().join(", ")
                ),
            ));
        }
    }
    if let Some((t, _)) = b.per_track.iter().find(|(_, v)| v.is_empty()) {
        return Err(KeyError::new(
            format!("bounds.per_track.{t}"),
            "list at least one bound",
        ));
    }
    Ok(())
}

/// Deep-merge `over` into `base`: tables merge key by key, anything else
/// (values, arrays, arrays of tables) replaces. A table that names a
/// different `model` or `kind` (a noise model, a generator, a motion)
/// replaces the base table whole, so a variant can switch models.
pub fn merge_tables(base: &mut toml::Table, over: &toml::Table) {
    let switches = |b: &toml::Table, o: &toml::Table| {
        ["model", "kind", "rule"]
            .iter()
            .any(|tag| o.get(*tag).is_some_and(|v| b.get(*tag) != Some(v)))
    };
    for (k, v) in over {
        match (base.get_mut(k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) if !switches(b, o) => {
                merge_tables(b, o)
            }
            _ => {
                base.insert(k.clone(), v.clone());
            }
        }
    }
}

impl Scenario {
    /// Read, parse and validate a 2-D scenario file without `[[variants]]`
    /// (a file with variants is an error here: use [`Scenario::load_all`]; a
    /// 3-D file is an error naming its receivers: [`AnyScenario`] reads
    /// either).
    ///
    /// [`AnyScenario`]: super::AnyScenario
    pub fn load(path: &Path) -> Result<Scenario, InputError> {
        load_one(path)
    }

    /// Read, parse and validate a 2-D scenario file: one scenario, or one
    /// per `[[variants]]` entry, in file order.
    pub fn load_all(path: &Path) -> Result<Vec<Scenario>, InputError> {
        load_every(path)
    }

    /// Parse and validate 2-D scenario text without variants; `path` names
    /// it in errors and anchors relative file names.
    pub fn from_toml_str(text: &str, path: &Path) -> Result<Scenario, InputError> {
        one_from_toml_str(text, path)
    }

    /// Parse and validate 2-D scenario text with any `[[variants]]`: each
    /// variant is the base file with the variant's tables deep-merged over it.
    pub fn all_from_toml_str(text: &str, path: &Path) -> Result<Vec<Scenario>, InputError> {
        every_from_toml_str(text, path)
    }
}

fn read_text(path: &Path) -> Result<String, InputError> {
    crate::scenario::limits::read_scenario_text(path)
}

/// [`Scenario::load`] in `D` dimensions.
pub(super) fn load_one<const D: usize>(path: &Path) -> Result<Scenario<D>, InputError> {
    one_from_toml_str(&read_text(path)?, path)
}

/// [`Scenario::load_all`] in `D` dimensions.
pub(super) fn load_every<const D: usize>(path: &Path) -> Result<Vec<Scenario<D>>, InputError> {
    every_from_toml_str(&read_text(path)?, path)
}

/// [`Scenario::from_toml_str`] in `D` dimensions.
pub(super) fn one_from_toml_str<const D: usize>(
    text: &str,
    path: &Path,
) -> Result<Scenario<D>, InputError> {
    let file: ScenarioFile = toml::from_str(text).map_err(|e| toml_error(path, text, &e))?;
    if !file.variants.is_empty() {
        let names: Vec<&str> = file.variants.iter().map(|v| v.name.as_str()).collect();
        return Err(InputError::at(
            path,
            "variants",
            format!(
                "the file has {} variants ({}); load them all, or pick one with --variant",
                names.len(),
                names.join(", ")
            ),
        ));
    }
    Scenario::<D>::from_parsed(file, path)
}

/// [`Scenario::all_from_toml_str`] in `D` dimensions.
pub(super) fn every_from_toml_str<const D: usize>(
    text: &str,
    path: &Path,
) -> Result<Vec<Scenario<D>>, InputError> {
    let file: ScenarioFile = toml::from_str(text).map_err(|e| toml_error(path, text, &e))?;
    if file.variants.is_empty() {
        return Ok(vec![Scenario::<D>::from_parsed(file, path)?]);
    }
    let mut base: toml::Table = toml::from_str(text).map_err(|e| toml_error(path, text, &e))?;
    base.remove("variants");
    for_each_variant(&file, &base, path, &[], |t| {
        let f: ScenarioFile = toml::Value::Table(t)
            .try_into()
            .map_err(|e: toml::de::Error| InputError::file(path, e.message().trim()))?;
        Scenario::<D>::from_parsed(f, path)
    })
}

impl<const D: usize> Scenario<D> {
    /// Validate a parsed scenario file.
    pub fn from_parsed(file: ScenarioFile, path: &Path) -> Result<Scenario<D>, InputError> {
        let base = path.parent().unwrap_or(Path::new("."));
        if file.name.trim().is_empty() {
            return Err(InputError::at(path, "name", "must not be empty"));
        }
        let dim = sections::dimension(path, &file)?;
        if dim != D {
            return Err(InputError::at(
                path,
                "geometry.receivers",
                if dim == 3 {
                    "the scenario is 3-D ([x, y, z] positions) and a 2-D `Scenario` was asked \
                     for: read it with `AnyScenario` (either dimension) or `Scenario::<3>`"
                        .to_string()
                } else {
                    format!("the scenario is {dim}-D, {D}-D was expected")
                },
            ));
        }
        let (transmitters, mut receivers) = sections::points(path, &file)?;
        let graph = sections::network(path, &file, &mut receivers)?;
        let drift = crate::model::drift::resolve(&file.geometry.drift, D, receivers.len())
            .map_err(|e| e.in_file(path))?;
        let geometry = Geometry::new(transmitters, receivers).with_drift(drift);
        sections::measurements(path, &file.measurements, &geometry)?;
        let (source, samples) = sections::data_source(path, base, &file, &geometry)?;
        let algorithm = sections::algorithm::<D>(path, base, &file, &graph, samples)?;
        sections::realtime(path, &file)?;
        if let Some(ch) = file.channel.acoustic() {
            ch.validate(geometry.receivers.len())
                .map_err(|e| e.in_file(path))?;
            check_tdma::<D>(ch, &geometry, &graph, algorithm.mode).map_err(|e| e.in_file(path))?;
        }
        if let Some(d) = &file.deploy {
            d.validate(geometry.receivers.len())
                .map_err(|e| InputError::at(path, "deploy.hosts", e.to_string()))?;
        }
        let faults =
            resolve_faults(&file, geometry.receivers.len()).map_err(|e| e.in_file(path))?;
        // Baselines, bounds, Monte Carlo.
        check_tracks(
            &file.baselines,
            file.bounds.as_ref(),
            &geometry,
            has_one_way_ranges(&source, &file.measurements),
        )
        .map_err(|e| e.in_file(path))?;
        crate::scenario::expect::validate_syntax(&file.expect).map_err(|e| {
            InputError::at(
                path,
                "expect.holds",
                format!("{:?}: {}", e.relation, e.reason),
            )
        })?;
        if let Some(mc) = &file.monte_carlo {
            super::limits::check_count(mc.trials, super::MAX_TRIALS)
                .map_err(|r| InputError::at(path, "monte_carlo.trials", r))?;
        }
        let sc = Scenario {
            path: path.to_path_buf(),
            name: file.name.clone(),
            seed: file.seed,
            geometry,
            graph,
            samples,
            source,
            measurements: file.measurements.clone(),
            algorithm,
            realtime: file.realtime.clone(),
            channel: file.channel.clone(),
            faults,
            nemesis: file.nemesis.clone(),
            expect: file.expect.clone(),
            trace_iterations: false,
            baselines: file.baselines.clone(),
            bounds: file.bounds.clone(),
            scoring: file.scoring.clone(),
            trials: file.monte_carlo.as_ref().map(|m| m.trials),
            variant: None,
            overrides: Vec::new(),
            deploy: file.deploy.clone(),
            file,
        };
        sc.check_size()
            .map_err(|(k, reason)| InputError::at(path, k.key(), reason))?;
        sc.check_schedule()?;
        sc.check_kappa()?;
        Ok(sc)
    }
}

pub(super) fn toml_error(path: &Path, text: &str, e: &toml::de::Error) -> InputError {
    if let Some(mut shape) = toml::from_str::<toml::Table>(text)
        .ok()
        .and_then(|t| unsupported_shape(&t))
    {
        shape.file = path.to_path_buf();
        return shape;
    }
    let location = e.span().map(|span| {
        let before = &text[..span.start.min(text.len())];
        let line = before.matches('\n').count() + 1;
        // A point's error is raised inside a (multi-line) array: name the
        // key it belongs to as well as the line.
        match key_before(before).filter(|_| e.message().contains("a point is [x, y]")) {
            Some(key) => format!("line {line}, {key}"),
            None => format!("line {line}"),
        }
    });
    InputError {
        file: path.to_path_buf(),
        location,
        reason: e.message().to_string(),
    }
}

/// The dotted key whose value is being read at the end of `before`: the
/// last `key =` line, under the last `[table]` header (a best effort for
/// error messages; `None` when there is none).
fn key_before(before: &str) -> Option<String> {
    let mut key = None;
    for l in before.lines().rev() {
        let t = l.trim_start();
        if key.is_none()
            && let Some((k, _)) = t.split_once('=')
        {
            let k = k.trim();
            if !k.is_empty() && k.chars().all(|c| c.is_alphanumeric() || "_-.".contains(c)) {
                key = Some(k.to_string());
            }
        }
        if let Some(h) = t.strip_prefix('[') {
            let table = h
                .trim_start_matches('[')
                .split(']')
                .next()?
                .trim()
                .to_string();
            return key.map(|k| format!("{table}.{k}"));
        }
    }
    key
}

/// A scenario shape sonarnet does not support, said in words rather than as
/// serde's type mismatch: several targets (`[[target]]` twice, or a list of
/// motions).
fn unsupported_shape(t: &toml::Table) -> Option<InputError> {
    let one = |key: &str, what: &str| InputError {
        file: PathBuf::new(),
        location: Some(key.to_string()),
        reason: format!("one target is supported: {what}"),
    };
    match t.get("target")? {
        toml::Value::Array(_) => Some(one(
            "target",
            "write a single [target] table, not [[target]] entries",
        )),
        toml::Value::Table(target) => match target.get("motion")? {
            toml::Value::Array(_) => Some(one(
                "target.motion",
                "give one motion table, e.g. motion = { model = \"spiral\", ... }, not a list",
            )),
            _ => None,
        },
        _ => None,
    }
}

/// The `[[faults]]` of `file`, checked against `n` nodes and in emulated
/// seconds (`at_sample` and `for_samples` count `[realtime]` sample periods):
/// faults run on the realtime clock, so they need a `[realtime]` table.
pub(crate) fn resolve_faults(
    file: &ScenarioFile,
    n: usize,
) -> Result<Vec<crate::model::fault::Fault>, KeyError> {
    if let Some(nem) = &file.nemesis {
        nem.validate()?;
        if file.realtime.is_none() {
            return Err(KeyError::new(
                "nemesis",
                "faults run on the realtime clock: add a [realtime] table (sample_period_ms, wake_rate_hz)",
            ));
        }
    }
    if file.faults.is_empty() {
        return Ok(Vec::new());
    }
    let Some(rt) = &file.realtime else {
        return Err(KeyError::new(
            "faults",
            "faults run on the realtime clock: add a [realtime] table (sample_period_ms, wake_rate_hz)",
        ));
    };
    file.faults
        .iter()
        .enumerate()
        .map(|(i, f)| {
            f.resolve(n, rt.sample_period_ms / 1000.0)
                .map_err(|e| e.under(&format!("faults[{i}]")))
        })
        .collect()
}

/// Build one scenario per `[[variants]]` entry of `file`: `base` (the file
/// without its variants) with the variant's tables deep-merged over it,
/// built by `build`; an error names the variant. With `only` non-empty,
/// only the variants it names are built (every name is still checked).
pub(super) fn for_each_variant<const D: usize>(
    file: &ScenarioFile,
    base: &toml::Table,
    path: &Path,
    only: &[String],
    build: impl Fn(toml::Table) -> Result<Scenario<D>, InputError>,
) -> Result<Vec<Scenario<D>>, InputError> {
    let mut seen = BTreeSet::new();
    let mut out = Vec::with_capacity(file.variants.len());
    for (i, v) in file.variants.iter().enumerate() {
        let key = format!("variants[{i}]");
        let vname = v.name.trim();
        if vname.is_empty()
            || !vname
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c))
        {
            return Err(InputError::at(
                path,
                format!("{key}.name"),
                format!(
                    "{:?} must be non-empty ASCII letters, digits, '-', '_' or '.'",
                    v.name
                ),
            ));
        }
        if !seen.insert(vname.to_string()) {
            return Err(InputError::at(
                path,
                format!("{key}.name"),
                format!("duplicate variant name {vname:?}"),
            ));
        }
        if !only.is_empty() && !only.iter().any(|o| o == vname) {
            continue;
        }
        let mut t = base.clone();
        merge_tables(&mut t, &v.overrides);
        let sc = build(t).map_err(|mut e| {
            e.location = Some(match e.location.take() {
                Some(l) => format!("{key} ({vname}): {l}"),
                None => format!("{key} ({vname})"),
            });
            e
        })?;
        out.push(Scenario {
            variant: Some(vname.to_string()),
            ..sc
        });
    }
    Ok(out)
}
