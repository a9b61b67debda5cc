//! The sections of a scenario file, checked one by one in the order of
//! [`Scenario::from_parsed`](crate::scenario::Scenario::from_parsed): the
//! first problem found is the one reported.

use super::ClockCfg;
use super::GeneratorCfg;
use super::InitU;
use super::ScenarioFile;
use crate::estimators::gossip::Mode;
use crate::model::error::InputError;
use crate::model::geometry::Point;
use crate::model::graph::Graph;
use crate::model::measure::Geometry;
use crate::model::rng::SonarRng;
use crate::model::rng::Stream;
use crate::model::rng::stream_rng;
use crate::model::synth::MeasurementsCfg;
use crate::model::xy::Pt;
use crate::scenario::Algorithm;
use crate::scenario::DataSource;
use crate::scenario::readers::read_schedule;
use crate::scenario::readers::read_trace;
use crate::scenario::readers::read_truth;
use rand::RngExt;
use std::path::Path;

/// The range of `realtime.sample_period_ms`: 0.1 ms to one hour.
pub const SAMPLE_PERIOD_MS: (f64, f64) = (0.1, 3.6e6);
/// The range of `realtime.wake_rate_hz`: one wake-up in 1000 s to a million a second.
pub const WAKE_RATE_HZ: (f64, f64) = (1e-3, 1e6);

/// The scenario's dimension, 2 or 3: that of its receivers (or, when a
/// generator draws them, of the generator's box; with neither, of its
/// transmitters; else 2). Every point of the file must have it: the first
/// that does not is named with its key.
pub(crate) fn dimension(path: &Path, file: &ScenarioFile) -> Result<usize, InputError> {
    let mut points: Vec<(String, Pt)> = Vec::new();
    let g = &file.geometry;
    for (i, p) in g.receivers.iter().enumerate() {
        points.push((format!("geometry.receivers[{i}]"), *p));
    }
    if let Some(GeneratorCfg::RandomGeometric { min, max, .. }) = &file.network.generator {
        for (k, p) in [("min", min), ("max", max)] {
            if let Some(p) = p {
                points.push((format!("network.generator.{k}"), *p));
            }
        }
    }
    for (i, p) in g.transmitters.iter().enumerate() {
        points.push((format!("geometry.transmitters[{i}]"), *p));
    }
    let Some((first_key, first)) = points.first().cloned() else {
        return Ok(2);
    };
    let dim = first.dim();
    for (key, p) in &points {
        if p.dim() != dim {
            return Err(InputError::at(
                path,
                key.as_str(),
                format!(
                    "this point has {} coordinates but the scenario is {dim}-D ({first_key} has \
                     {dim}); every point of a scenario has the same dimension",
                    p.dim()
                ),
            ));
        }
    }
    Ok(dim)
}

/// `[geometry]`: the transmitters and receivers in `D` dimensions (checked
/// by [`dimension`]), every coordinate finite.
pub(super) fn points<const D: usize>(
    path: &Path,
    file: &ScenarioFile,
) -> Result<(Vec<Point<D>>, Vec<Point<D>>), InputError> {
    let transmitters = file
        .geometry
        .transmitters
        .iter()
        .enumerate()
        .map(|(i, p)| check_point(path, &format!("geometry.transmitters[{i}]"), p))
        .collect::<Result<Vec<_>, _>>()?;
    at_most(
        path,
        "transmitters",
        transmitters.len(),
        super::MAX_TRANSMITTERS,
    )?;
    let receivers = file
        .geometry
        .receivers
        .iter()
        .enumerate()
        .map(|(i, p)| check_point(path, &format!("geometry.receivers[{i}]"), p))
        .collect::<Result<Vec<_>, _>>()?;

    Ok((transmitters, receivers))
}

/// `geometry.WHAT` holds at most `max` points.
fn at_most(path: &Path, what: &str, n: usize, max: usize) -> Result<(), InputError> {
    if n > max {
        return Err(InputError::at(
            path,
            format!("geometry.{what}"),
            format!("{n} {what}, at most {max} are supported"),
        ));
    }
    Ok(())
}

/// `[network]`: the gossip graph, given or generated (a generator may place
/// the receivers), and the number of receivers.
pub(super) fn network<const D: usize>(
    path: &Path,
    file: &ScenarioFile,
    receivers: &mut Vec<Point<D>>,
) -> Result<Graph, InputError> {
    let graph = match (&file.network.edges, &file.network.generator) {
        (Some(_), Some(_)) => {
            return Err(InputError::at(
                path,
                "network",
                "give either `edges` or `generator`, not both",
            ));
        }
        (None, None) => {
            return Err(InputError::at(
                path,
                "network",
                "give `edges` or `generator`",
            ));
        }
        (Some(edges), None) => {
            let e: Vec<(usize, usize)> = edges.iter().map(|e| (e[0], e[1])).collect();
            Graph::new(receivers.len(), &e).map_err(|err| {
                let key = match &err {
                    crate::model::graph::GraphError::OutOfRange { index, .. }
                    | crate::model::graph::GraphError::SelfLoop { index, .. }
                    | crate::model::graph::GraphError::Duplicate { index, .. } => {
                        format!("network.edges[{index}]")
                    }
                    _ => "network.edges".to_string(),
                };
                InputError::at(path, key, err.to_string())
            })?
        }
        (None, Some(generator)) => build_generated(path, generator, receivers)?,
    };
    at_most(path, "receivers", receivers.len(), super::MAX_RECEIVERS)?;
    if receivers.is_empty() {
        return Err(InputError::at(path, "geometry.receivers", "no receivers"));
    }
    Ok(graph)
}

/// `[measurements]`: the noise models and the NLOS links.
pub(super) fn measurements<const D: usize>(
    path: &Path,
    m: &MeasurementsCfg,
    geometry: &Geometry<D>,
) -> Result<(), InputError> {
    if !(m.omega.is_finite() && m.omega > 0.0) {
        return Err(InputError::at(
            path,
            "measurements.omega",
            format!("must be finite and > 0, got {}", m.omega),
        ));
    }
    if let Some(n) = &m.range_noise {
        n.validate()
            .map_err(|e| e.under("measurements.range_noise").in_file(path))?;
    }
    if let Some(n) = &m.doa_noise {
        n.validate()
            .map_err(|e| e.under("measurements.doa_noise").in_file(path))?;
    }
    if let Some(n) = &m.elevation_noise {
        n.validate()
            .map_err(|e| e.under("measurements.elevation_noise").in_file(path))?;
    }
    if m.elevation_noise.is_some() && D == 2 {
        return Err(InputError::at(
            path,
            "measurements.elevation_noise",
            "an elevation is measured only in 3-D (positions [x, y, z]); this scenario is 2-D",
        ));
    }
    m.nlos_links
        .validate()
        .map_err(|e| e.under("measurements.nlos_links").in_file(path))?;
    m.nlos_links
        .draw(
            geometry.transmitters.len(),
            geometry.receivers.len(),
            &mut stream_rng(0, Stream::Links, 0),
        )
        .map_err(|e| InputError::at(path, "measurements.nlos_links", e.to_string()))?;
    Ok(())
}

/// Where the measurements come from (a trace, or synthesized along
/// `[target]`), and how many samples.
pub(super) fn data_source<const D: usize>(
    path: &Path,
    base: &Path,
    file: &ScenarioFile,
    geometry: &Geometry<D>,
) -> Result<(DataSource<D>, usize), InputError> {
    let m = &file.measurements;
    let (source, samples) = match &m.trace {
        Some(trace) => {
            let tpath = base.join(trace);
            let meas = read_trace(&tpath, geometry)?;
            let truth = match &m.truth {
                Some(t) => {
                    let p = base.join(t);
                    let tr = read_truth(&p)?;
                    if tr.len() != meas.len() {
                        return Err(InputError::file(
                            &p,
                            format!(
                                "has {} samples but the trace {} has {}",
                                tr.len(),
                                tpath.display(),
                                meas.len()
                            ),
                        ));
                    }
                    Some(tr)
                }
                None => None,
            };
            let samples = meas.len();
            if let Some(t) = &file.target
                && t.samples > samples
            {
                return Err(InputError::at(
                    path,
                    "target.samples",
                    format!("asks for {} samples but the trace has {samples}", t.samples),
                ));
            }
            let samples = file.target.as_ref().map_or(samples, |t| t.samples);
            (
                DataSource::Trace {
                    path: tpath,
                    measurements: meas,
                    truth,
                },
                samples,
            )
        }
        None => {
            if m.truth.is_some() {
                return Err(InputError::at(
                    path,
                    "measurements.truth",
                    "a truth file only goes with a trace (measurements.trace)",
                ));
            }
            let Some(t) = &file.target else {
                return Err(InputError::at(
                    path,
                    "target",
                    "missing: give [target] (samples, motion) or measurements.trace",
                ));
            };
            t.motion
                .validate(D)
                .map_err(|e| e.under("target.motion").in_file(path))?;
            if !m.bistatic && !m.doa && !m.range {
                return Err(InputError::at(
                    path,
                    "measurements",
                    "nothing to measure: enable bistatic, doa or range",
                ));
            }
            if m.bistatic && geometry.transmitters.is_empty() {
                return Err(InputError::at(
                    path,
                    "measurements.bistatic",
                    "bistatic ranges need at least one transmitter in geometry.transmitters \
                     (set bistatic = false for a pure TOA/DOA network)",
                ));
            }
            if (m.bistatic || m.range) && m.range_noise.is_none() {
                return Err(InputError::at(
                    path,
                    "measurements.range_noise",
                    "missing: ranges are synthesized, so give their noise model",
                ));
            }
            if m.doa && m.doa_noise.is_none() {
                return Err(InputError::at(
                    path,
                    "measurements.doa_noise",
                    "missing: DOAs are synthesized, so give their noise model",
                ));
            }
            (
                DataSource::Synthetic {
                    motion: t.motion.clone(),
                },
                t.samples,
            )
        }
    };
    super::limits::check_count(samples, super::MAX_SAMPLES)
        .map_err(|r| InputError::at(path, "target.samples", r))?;
    Ok((source, samples))
}

/// `[algorithm]`, with `samples` samples and the gossip graph `graph`, in
/// a scenario of `D` dimensions (`init_u` entries are `[x, y, d]` or
/// `[x, y, z, d]`).
pub(super) fn algorithm<const D: usize>(
    path: &Path,
    base: &Path,
    file: &ScenarioFile,
    graph: &Graph,
    samples: usize,
) -> Result<Algorithm, InputError> {
    let a = &file.algorithm;
    if !(a.gamma.is_finite() && a.gamma > 0.0) {
        return Err(InputError::at(
            path,
            "algorithm.gamma",
            format!("must be finite and > 0, got {}", a.gamma),
        ));
    }
    super::limits::check_count(a.iterations_per_sample, super::MAX_ITERATIONS_PER_SAMPLE)
        .map_err(|r| InputError::at(path, "algorithm.iterations_per_sample", r))?;
    let n_nodes = graph.len();
    let form = if D == 3 { "[x, y, z, d]" } else { "[x, y, d]" };
    let check_len = |u: &Vec<f64>, key: String| {
        if u.len() == D + 1 {
            Ok(u.clone())
        } else {
            Err(InputError::at(
                path,
                key,
                format!("has {} numbers: a {D}-D scenario's u is {form}", u.len()),
            ))
        }
    };
    let init_u: Vec<Vec<f64>> = match &a.init_u {
        InitU::One(u) if u.is_empty() => vec![vec![0.0; D + 1]; n_nodes],
        InitU::One(u) => vec![check_len(u, "algorithm.init_u".into())?; n_nodes],
        InitU::PerNode(us) => {
            if us.len() != n_nodes {
                return Err(InputError::at(
                    path,
                    "algorithm.init_u",
                    format!(
                        "has {} entries, one per node is {n_nodes} (or give one {form} for all)",
                        us.len()
                    ),
                ));
            }
            us.iter()
                .enumerate()
                .map(|(i, u)| check_len(u, format!("algorithm.init_u[{i}]")))
                .collect::<Result<Vec<_>, _>>()?
        }
    };
    if !init_u.iter().all(|u| u.iter().all(|x| x.is_finite())) {
        return Err(InputError::at(path, "algorithm.init_u", "must be finite"));
    }
    if a.burn_in >= samples {
        return Err(InputError::at(
            path,
            "algorithm.burn_in",
            format!(
                "must be below the number of samples ({samples}), got {}",
                a.burn_in
            ),
        ));
    }
    let schedule = match &a.schedule {
        Some(s) => {
            let p = base.join(s);
            Some((p.clone(), read_schedule(&p, graph)?))
        }
        None => None,
    };
    Ok(Algorithm {
        mode: a.mode,
        gamma: a.gamma,
        iterations_per_sample: a.iterations_per_sample,
        local_solver: a.local_solver,
        kappa: a.kappa,
        prox_scaling: a.prox_scaling,
        init: a.init,
        row_weights: a.row_weights,
        init_u,
        schedule,
        burn_in: a.burn_in,
        clock: a.clock,
    })
}

/// `[realtime]`: its ranges, and the realtime clock's needs.
pub(super) fn realtime(path: &Path, file: &ScenarioFile) -> Result<(), InputError> {
    let a = &file.algorithm;
    if let Some(rt) = &file.realtime {
        for (key, v, (lo, hi)) in [
            (
                "realtime.sample_period_ms",
                rt.sample_period_ms,
                SAMPLE_PERIOD_MS,
            ),
            ("realtime.wake_rate_hz", rt.wake_rate_hz, WAKE_RATE_HZ),
        ] {
            if !(v.is_finite() && (lo..=hi).contains(&v)) {
                return Err(InputError::at(
                    path,
                    key,
                    format!("must be in [{lo:e}, {hi:e}], got {v:e}"),
                ));
            }
        }
    }
    if a.clock == Some(ClockCfg::Realtime) {
        if a.mode != Mode::Async {
            return Err(InputError::at(
                path,
                "algorithm.clock",
                "the realtime clock runs async gossip (algorithm.mode = \"async\")",
            ));
        }
        if file.realtime.is_none() {
            return Err(InputError::at(
                path,
                "algorithm.clock",
                "the realtime clock needs a [realtime] table (sample_period_ms, wake_rate_hz)",
            ));
        }
    }
    Ok(())
}

fn check_point<const D: usize>(path: &Path, key: &str, p: &Pt) -> Result<Point<D>, InputError> {
    if p.is_finite() {
        Ok(p.point::<D>())
    } else {
        Err(InputError::at(
            path,
            key,
            format!("coordinates must be finite, got {:?}", p.coords()),
        ))
    }
}

fn build_generated<const D: usize>(
    path: &Path,
    generator: &GeneratorCfg,
    receivers: &mut Vec<Point<D>>,
) -> Result<Graph, InputError> {
    let key = "network.generator";
    let wrap = |e: crate::model::graph::GraphError| InputError::at(path, key, e.to_string());
    match generator {
        GeneratorCfg::Ring {} => {
            Graph::new(receivers.len(), &Graph::ring_edges(receivers.len())).map_err(wrap)
        }
        GeneratorCfg::Grid { rows, cols } => {
            let cells = rows.checked_mul(*cols);
            if cells != Some(receivers.len()) {
                return Err(InputError::at(
                    path,
                    key,
                    format!(
                        "grid {rows} x {cols} = {} nodes but there are {} receivers",
                        cells.map_or("too many".into(), |c| c.to_string()),
                        receivers.len()
                    ),
                ));
            }
            Graph::new(receivers.len(), &Graph::grid_edges(*rows, *cols)).map_err(wrap)
        }
        GeneratorCfg::RandomGeometric {
            radius,
            seed,
            count,
            min,
            max,
        } => {
            if !(radius.is_finite() && *radius > 0.0) {
                return Err(InputError::at(
                    path,
                    "network.generator.radius",
                    "must be finite and > 0",
                ));
            }
            match (count, min, max) {
                (None, None, None) => {
                    if receivers.is_empty() {
                        return Err(InputError::at(
                            path,
                            key,
                            "no geometry.receivers: give count, min and max to draw them",
                        ));
                    }
                    Graph::new(receivers.len(), &Graph::geometric_edges(receivers, *radius))
                        .map_err(|e| {
                            InputError::at(path, key, format!("{e} (radius {radius} is too small)"))
                        })
                }
                (Some(count), Some(lo), Some(hi)) => {
                    if !receivers.is_empty() {
                        return Err(InputError::at(
                            path,
                            key,
                            "count/min/max draw the receivers, so geometry.receivers must be empty",
                        ));
                    }
                    super::limits::check_count(*count, super::MAX_RECEIVERS)
                        .map_err(|r| InputError::at(path, "network.generator.count", r))?;
                    let lo: Point<D> = check_point(path, "network.generator.min", lo)?;
                    let hi: Point<D> = check_point(path, "network.generator.max", hi)?;
                    if (0..D).any(|i| lo[i] >= hi[i]) {
                        return Err(InputError::at(
                            path,
                            key,
                            "min must be below max in every coordinate",
                        ));
                    }
                    let mut last_err = None;
                    for attempt in 0..1000u64 {
                        let mut rng: SonarRng = stream_rng(*seed, Stream::Graph, attempt);
                        // Coordinates drawn in order x, y(, z) per receiver.
                        let pts: Vec<Point<D>> = (0..*count)
                            .map(|_| Point::<D>::from_fn(|i, _| rng.random_range(lo[i]..hi[i])))
                            .collect();
                        match Graph::new(*count, &Graph::geometric_edges(&pts, *radius)) {
                            Ok(g) => {
                                *receivers = pts;
                                return Ok(g);
                            }
                            Err(e) => last_err = Some(e),
                        }
                    }
                    Err(InputError::at(
                        path,
                        key,
                        format!(
                            "no connected layout in 1000 draws (last: {}); increase radius",
                            last_err.map(|e| e.to_string()).unwrap_or_default()
                        ),
                    ))
                }
                _ => Err(InputError::at(
                    path,
                    key,
                    "give all of count, min and max (to draw receivers) or none of them",
                )),
            }
        }
    }
}
