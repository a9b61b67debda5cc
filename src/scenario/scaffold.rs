//! `sonarnet new`: a commented scenario file from a few layout words
//! (`circle:8:1500`, `grid:3x4:500`, `rgg:1200`, `spiral`), which validates
//! and runs as written.

use crate::model::error::InputError;
use crate::model::rng::Stream;
use crate::model::rng::stream_rng;
use crate::scenario::cli_error;
use rand::RngExt;
use std::collections::BTreeSet;

/// Largest node count `sonarnet new` lays out.
pub const MAX_LAYOUT_POINTS: usize = 4096;

/// Where points go (`--receivers`, `--transmitters`).
#[derive(Debug, Clone, PartialEq)]
pub enum Layout {
    /// `circle:N:RADIUS`: N points on a circle about the origin.
    Circle { n: usize, radius: f64 },
    /// `line:N:X0,Y0:X1,Y1`: N points evenly from one end to the other.
    Line { n: usize, a: [f64; 2], b: [f64; 2] },
    /// `grid:RxC:SPACING`: R rows of C points, centred on the origin.
    Grid {
        rows: usize,
        cols: usize,
        spacing: f64,
    },
    /// `random:N:XMIN,YMIN:XMAX,YMAX`: N points uniform in the box, drawn
    /// from the scenario seed (written out as coordinates).
    Random {
        n: usize,
        min: [f64; 2],
        max: [f64; 2],
    },
}

fn bad(flag: &str, text: &str, why: impl Into<String>) -> InputError {
    cli_error(flag, format!("`{text}`: {}", why.into()))
}

fn pair(flag: &str, text: &str, s: &str) -> Result<[f64; 2], InputError> {
    let v: Vec<&str> = s.split(',').collect();
    let num = |t: &str| {
        t.trim()
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite() && x.abs() <= 1e9)
            .ok_or_else(|| {
                bad(
                    flag,
                    text,
                    format!("{t:?} is not a coordinate (|x| <= 1e9 m)"),
                )
            })
    };
    match v.as_slice() {
        [x, y] => Ok([num(x)?, num(y)?]),
        _ => Err(bad(flag, text, format!("{s:?} is not X,Y"))),
    }
}

fn count(flag: &str, text: &str, s: &str) -> Result<usize, InputError> {
    match s.trim().parse::<usize>() {
        Ok(n) if (1..=MAX_LAYOUT_POINTS).contains(&n) => Ok(n),
        _ => Err(bad(
            flag,
            text,
            format!("{s:?} is not a count in 1..={MAX_LAYOUT_POINTS}"),
        )),
    }
}

fn length(flag: &str, text: &str, s: &str) -> Result<f64, InputError> {
    match s.trim().parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 && x <= 1e9 => Ok(x),
        _ => Err(bad(
            flag,
            text,
            format!("{s:?} is not a length in (0, 1e9] m"),
        )),
    }
}

impl Layout {
    /// Parse a layout word for `flag`.
    pub fn parse(flag: &str, text: &str) -> Result<Layout, InputError> {
        let parts: Vec<&str> = text.split(':').collect();
        let forms =
            "circle:N:RADIUS, line:N:X0,Y0:X1,Y1, grid:RxC:SPACING or random:N:XMIN,YMIN:XMAX,YMAX";
        match parts.as_slice() {
            ["circle", n, r] => Ok(Layout::Circle {
                n: count(flag, text, n)?,
                radius: length(flag, text, r)?,
            }),
            ["line", n, a, b] => Ok(Layout::Line {
                n: count(flag, text, n)?,
                a: pair(flag, text, a)?,
                b: pair(flag, text, b)?,
            }),
            ["grid", rc, s] => {
                let (r, c) = rc
                    .split_once(['x', 'X'])
                    .ok_or_else(|| bad(flag, text, "write the grid as RxC, e.g. 3x4"))?;
                let (rows, cols) = (count(flag, text, r)?, count(flag, text, c)?);
                if rows * cols > MAX_LAYOUT_POINTS {
                    return Err(bad(
                        flag,
                        text,
                        format!("more than {MAX_LAYOUT_POINTS} points"),
                    ));
                }
                Ok(Layout::Grid {
                    rows,
                    cols,
                    spacing: length(flag, text, s)?,
                })
            }
            ["random", n, a, b] => {
                let (min, max) = (pair(flag, text, a)?, pair(flag, text, b)?);
                if !(min[0] < max[0] && min[1] < max[1]) {
                    return Err(bad(flag, text, "the box needs XMIN < XMAX and YMIN < YMAX"));
                }
                Ok(Layout::Random {
                    n: count(flag, text, n)?,
                    min,
                    max,
                })
            }
            _ => Err(bad(flag, text, format!("expected {forms}"))),
        }
    }

    /// The points, rounded to 0.1 m.
    pub fn points(&self, seed: u64) -> Vec<[f64; 2]> {
        let r = |x: f64| (x * 10.0).round() / 10.0 + 0.0;
        let pts: Vec<[f64; 2]> = match *self {
            Layout::Circle { n, radius } => (0..n)
                .map(|i| {
                    let a = std::f64::consts::TAU * i as f64 / n as f64;
                    [radius * a.cos(), radius * a.sin()]
                })
                .collect(),
            Layout::Line { n, a, b } => (0..n)
                .map(|i| {
                    let t = if n == 1 {
                        0.5
                    } else {
                        i as f64 / (n - 1) as f64
                    };
                    [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
                })
                .collect(),
            Layout::Grid {
                rows,
                cols,
                spacing,
            } => (0..rows * cols)
                .map(|i| {
                    let (row, col) = (i / cols, i % cols);
                    [
                        (col as f64 - (cols - 1) as f64 / 2.0) * spacing,
                        (row as f64 - (rows - 1) as f64 / 2.0) * spacing,
                    ]
                })
                .collect(),
            Layout::Random { n, min, max } => {
                // The graph stream: a layout drawn like a generated graph's receivers.
                let mut rng = stream_rng(seed, Stream::Graph, 1);
                (0..n)
                    .map(|_| {
                        [
                            rng.random_range(min[0]..max[0]),
                            rng.random_range(min[1]..max[1]),
                        ]
                    })
                    .collect()
            }
        };
        pts.into_iter().map(|p| [r(p[0]), r(p[1])]).collect()
    }
}

/// The gossip graph (`--network`).
#[derive(Debug, Clone, PartialEq)]
pub enum NetworkSpec {
    /// `ring`.
    Ring,
    /// `grid`: the lattice of a `grid:RxC` receiver layout.
    Grid,
    /// `rgg:RADIUS`: receivers closer than RADIUS are joined.
    Rgg(f64),
    /// `edges`: an explicit edge list to edit (each receiver to its nearest
    /// neighbours, connected).
    Edges,
}

impl NetworkSpec {
    /// Parse `--network`.
    pub fn parse(text: &str) -> Result<NetworkSpec, InputError> {
        match text.split_once(':') {
            None if text == "ring" => Ok(NetworkSpec::Ring),
            None if text == "grid" => Ok(NetworkSpec::Grid),
            None if text == "edges" => Ok(NetworkSpec::Edges),
            Some(("rgg", r)) => Ok(NetworkSpec::Rgg(length("--network", text, r)?)),
            _ => Err(bad(
                "--network",
                text,
                "expected ring, grid, rgg:RADIUS or edges",
            )),
        }
    }
}

/// The target's motion (`--motion`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionSpec {
    /// A spiral out from the scene's centre (Mourya 2017 Sec. III-C).
    Spiral,
    /// A straight line across the scene at constant velocity.
    Line,
    /// A closed loop of four waypoints.
    Waypoints,
    /// A target that does not move.
    Static,
}

impl MotionSpec {
    /// Parse `--motion`.
    pub fn parse(text: &str) -> Result<MotionSpec, InputError> {
        match text {
            "spiral" => Ok(MotionSpec::Spiral),
            "line" => Ok(MotionSpec::Line),
            "waypoints" => Ok(MotionSpec::Waypoints),
            "static" => Ok(MotionSpec::Static),
            _ => Err(bad(
                "--motion",
                text,
                "expected spiral, line, waypoints or static",
            )),
        }
    }
}

/// Everything `sonarnet new` needs.
#[derive(Debug, Clone, PartialEq)]
pub struct ScaffoldSpec {
    /// Scenario name.
    pub name: String,
    /// Receiver layout.
    pub receivers: Layout,
    /// Transmitter layout (`None`: two transmitters inside the receivers).
    pub transmitters: Option<Layout>,
    /// Gossip graph.
    pub network: NetworkSpec,
    /// Target motion.
    pub motion: MotionSpec,
    /// The run seed.
    pub seed: u64,
}

fn fmt_pts(p: &[[f64; 2]]) -> String {
    let items: Vec<String> = p
        .iter()
        .map(|q| format!("[{:?}, {:?}]", q[0], q[1]))
        .collect();
    if items.len() <= 4 {
        format!("[{}]", items.join(", "))
    } else {
        format!("[\n  {},\n]", items.join(",\n  "))
    }
}

/// Edges joining each receiver to its two nearest neighbours, plus the
/// shortest links that join the pieces into one connected graph.
fn nearest_edges(p: &[[f64; 2]]) -> Vec<[usize; 2]> {
    let n = p.len();
    let d = |i: usize, j: usize| ((p[i][0] - p[j][0]).powi(2) + (p[i][1] - p[j][1]).powi(2)).sqrt();
    let mut edges = BTreeSet::new();
    for i in 0..n {
        let mut others: Vec<usize> = (0..n).filter(|&j| j != i).collect();
        others.sort_by(|&a, &b| d(i, a).total_cmp(&d(i, b)));
        for &j in others.iter().take(2) {
            edges.insert([i.min(j), i.max(j)]);
        }
    }
    // Join components (Kruskal on the remaining pairs).
    let mut comp: Vec<usize> = (0..n).collect();
    fn find(c: &mut [usize], i: usize) -> usize {
        let mut r = i;
        while c[r] != r {
            r = c[r];
        }
        c[i] = r;
        r
    }
    for e in &edges {
        let (a, b) = (find(&mut comp, e[0]), find(&mut comp, e[1]));
        comp[a] = b;
    }
    let mut pairs: Vec<(usize, usize)> = (0..n)
        .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
        .collect();
    pairs.sort_by(|a, b| d(a.0, a.1).total_cmp(&d(b.0, b.1)));
    for (i, j) in pairs {
        let (a, b) = (find(&mut comp, i), find(&mut comp, j));
        if a != b {
            comp[a] = b;
            edges.insert([i, j]);
        }
    }
    edges.into_iter().collect()
}

impl ScaffoldSpec {
    /// The scenario file, commented.
    pub fn to_toml(&self) -> Result<String, InputError> {
        let rx = self.receivers.points(self.seed);
        if rx.len() < 2 {
            return Err(cli_error(
                "--receivers",
                "a network needs at least 2 receivers",
            ));
        }
        // The scene: the receivers' bounding box.
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in &rx {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let c = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
        let size = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1.0);
        let tx = match &self.transmitters {
            Some(l) => l.points(self.seed.wrapping_add(1)),
            None => Layout::Line {
                n: 2,
                a: [c[0] - size / 4.0, c[1]],
                b: [c[0] + size / 4.0, c[1]],
            }
            .points(0),
        };
        let samples = 100;
        let (motion, motion_note) = self.motion_toml(lo, hi, samples);
        let network = self.network_toml(&rx)?;
        // The prox step scales as 1/length^2 (the local cost is quadratic in
        // lengths): 2e-6 at a 3 km scene tracks well from 6 to 20 receivers
        // (measured: within 2x of ML on rings of 6, 10 and 20 and a 4 x 5
        // grid), where Mourya 2017's 2e-8 lags by 100 m and more.
        let gamma = 2e-6 * (3000.0 / size).powi(2);
        let gamma = format!("{:.1e}", gamma).parse::<f64>().unwrap_or(2e-6);
        // Pairwise gossip mixes a ring in about N^2 exchanges: 3 N^2 per
        // sample lets the nodes agree before the target has moved on.
        let ips = (3 * rx.len() * rx.len()).clamp(50, 2000);
        Ok(format!(
            r#"# Written by `sonarnet new` ({n_rx} receivers, {n_tx} transmitters). Every key is
# documented in the book's scenario reference (docs/src/scenarios.md). Check it with `sonarnet validate`,
# read it back with `sonarnet describe`, and tune it with `--set` and
# `sonarnet sweep` (e.g. --grid algorithm.gamma=1e-9,1e-8,1e-7).
name = "{name}"
description = "{n_rx} receivers, {n_tx} transmitters, {motion_word} track"
seed = {seed}

[geometry]
# Positions in metres.
transmitters = {tx}
receivers = {rx}

[network]
# Which receivers exchange gossip messages (0-based receiver indices).
{network}

[target]
samples = {samples}
# The true track: {motion_note}.
motion = {motion}

[measurements]
# A bistatic range per transmitter-receiver pair and a direction of
# arrival at every receiver, with Gaussian noise.
bistatic = true
doa = true
range_noise = {{ model = "gaussian", sigma = 5.0 }}
doa_noise = {{ model = "gaussian", sigma = 0.5 }}

[algorithm]
# Asynchronous randomized Douglas-Rachford gossip with exact GTRS local
# steps (Mourya 2017). gamma is the prox step: it scales as 1 / length^2, here
# set for a {size:.0} m scene (2e-6 at 3 km). Each iteration is one exchange
# between two neighbours; pairwise gossip needs about N^2 of them to mix a
# ring of N nodes, so a sample gets 3 N^2 (at least 50, at most 2000).
# Larger gamma follows a fast target more closely but averages less noise;
# `sonarnet sweep --grid algorithm.gamma=...` finds the best for your scene.
mode = "async"
gamma = {gamma:?}
iterations_per_sample = {ips}
local_solver = "gtrs"
burn_in = 10

[realtime]
# Free-running nodes (--clock realtime): a sample every 20 ms, each node
# waking 2000 times a second.
sample_period_ms = 20.0
wake_rate_hz = 2000.0

# [expect]
# Thresholds `sonarnet run --check` asserts, e.g.:
# rmse_after_burn_in_max = 20.0
"#,
            n_rx = rx.len(),
            n_tx = tx.len(),
            name = self.name,
            motion_word = match self.motion {
                MotionSpec::Spiral => "spiral",
                MotionSpec::Line => "straight",
                MotionSpec::Waypoints => "waypoint",
                MotionSpec::Static => "static",
            },
            seed = self.seed,
            tx = fmt_pts(&tx),
            rx = fmt_pts(&rx),
        ))
    }

    /// The target's motion as a TOML inline table in the scene `lo`..`hi`
    /// (the receivers' bounding box), over `samples` samples, and a note on
    /// it.
    fn motion_toml(&self, lo: [f64; 2], hi: [f64; 2], samples: usize) -> (String, &'static str) {
        let c = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
        let size = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1.0);
        let r = |x: f64| (x * 10.0).round() / 10.0 + 0.0;
        match self.motion {
            MotionSpec::Spiral => (
                format!(
                    "{{ model = \"spiral\", center = [{:?}, {:?}], r0 = 0.0, dr = {:?}, t0 = 0.0, dt = 0.25 }}",
                    r(c[0]),
                    r(c[1]),
                    r(size / 4.0 / samples as f64 * 10.0) / 10.0
                ),
                "a spiral out from the centre of the receivers",
            ),
            MotionSpec::Line => {
                let (a, b) = (
                    [lo[0] + size / 8.0, c[1]],
                    [hi[0] - size / 8.0, c[1] + size / 8.0],
                );
                (
                    format!(
                        "{{ model = \"constant_velocity\", start = [{:?}, {:?}], velocity = [{:?}, {:?}] }}",
                        r(a[0]),
                        r(a[1]),
                        r((b[0] - a[0]) / samples as f64 * 100.0) / 100.0,
                        r((b[1] - a[1]) / samples as f64 * 100.0) / 100.0
                    ),
                    "a straight line across the scene (metres per sample)",
                )
            }
            MotionSpec::Waypoints => {
                let q = size / 4.0;
                let w = [
                    [c[0] - q, c[1] - q],
                    [c[0] + q, c[1] - q],
                    [c[0] + q, c[1] + q],
                    [c[0] - q, c[1] + q],
                    [c[0] - q, c[1] - q],
                ];
                (
                    format!(
                        "{{ model = \"waypoints\", points = {} }}",
                        fmt_pts(&w.map(|p| [r(p[0]), r(p[1])])).replace('\n', " ")
                    ),
                    "a closed loop of waypoints at constant speed",
                )
            }
            MotionSpec::Static => (
                format!(
                    "{{ model = \"constant_velocity\", start = [{:?}, {:?}], velocity = [0.0, 0.0] }}",
                    r(c[0] + size / 10.0),
                    r(c[1] + size / 10.0)
                ),
                "a target that does not move",
            ),
        }
    }

    /// The `[network]` table's body for receivers `rx`.
    fn network_toml(&self, rx: &[[f64; 2]]) -> Result<String, InputError> {
        Ok(match &self.network {
            NetworkSpec::Ring => "generator = { kind = \"ring\" }".to_string(),
            NetworkSpec::Grid => match self.receivers {
                Layout::Grid { rows, cols, .. } => {
                    format!("generator = {{ kind = \"grid\", rows = {rows}, cols = {cols} }}")
                }
                _ => {
                    return Err(cli_error(
                        "--network",
                        "grid needs receivers laid out as a grid (--receivers grid:RxC:SPACING)",
                    ));
                }
            },
            NetworkSpec::Rgg(radius) => {
                format!("generator = {{ kind = \"random_geometric\", radius = {radius:?} }}")
            }
            NetworkSpec::Edges => {
                let e: Vec<String> = nearest_edges(rx)
                    .iter()
                    .map(|e| format!("[{}, {}]", e[0], e[1]))
                    .collect();
                format!(
                    "# Each receiver joined to its two nearest neighbours: edit freely.\nedges = [{}]",
                    e.join(", ")
                )
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::Scenario;
    use std::path::Path;

    #[test]
    fn layouts_put_their_points_where_they_say() {
        let c = Layout::parse("--receivers", "circle:4:100")
            .unwrap()
            .points(0);
        assert_eq!(
            c,
            vec![
                [100.0, 0.0],
                [0.0, 100.0],
                [-100.0, 0.0],
                [-0.0 + 0.0, -100.0]
            ]
        );
        let l = Layout::parse("--receivers", "line:3:0,0:10,20")
            .unwrap()
            .points(0);
        assert_eq!(l, vec![[0.0, 0.0], [5.0, 10.0], [10.0, 20.0]]);
        let g = Layout::parse("--receivers", "grid:2x3:10")
            .unwrap()
            .points(0);
        assert_eq!(
            g,
            vec![
                [-10.0, -5.0],
                [0.0, -5.0],
                [10.0, -5.0],
                [-10.0, 5.0],
                [0.0, 5.0],
                [10.0, 5.0]
            ]
        );
        let r = Layout::parse("--receivers", "random:50:-5,0:5,10").unwrap();
        let p = r.points(3);
        assert_eq!(p, r.points(3), "seeded");
        assert!(
            p.iter()
                .all(|q| (-5.0..=5.0).contains(&q[0]) && (0.0..=10.0).contains(&q[1]))
        );
    }

    #[test]
    fn bad_layout_words_name_the_flag() {
        for w in [
            "circle:0:10",
            "circle:4",
            "line:3:0,0",
            "grid:3:10",
            "random:4:1,1:0,0",
            "hex:3",
            "circle:4:-1",
        ] {
            let e = Layout::parse("--receivers", w).unwrap_err().to_string();
            assert!(e.contains("--receivers") && e.contains(w), "{e}");
        }
        assert!(NetworkSpec::parse("rgg:0").is_err());
        assert!(MotionSpec::parse("zigzag").is_err());
    }

    #[test]
    fn nearest_neighbour_edges_connect_every_receiver() {
        let p = Layout::Random {
            n: 30,
            min: [0.0, 0.0],
            max: [1000.0, 1000.0],
        }
        .points(9);
        let e = nearest_edges(&p);
        let g = crate::model::graph::Graph::new(
            30,
            &e.iter().map(|e| (e[0], e[1])).collect::<Vec<_>>(),
        );
        assert!(g.is_ok(), "{g:?}");
    }

    #[test]
    fn every_combination_of_words_writes_a_scenario_that_validates() {
        for rx in [
            "circle:8:1500",
            "grid:3x4:600",
            "random:12:-2000,-2000:2000,2000",
            "line:5:-2000,0:2000,500",
        ] {
            for net in ["ring", "grid", "rgg:2500", "edges"] {
                for motion in ["spiral", "line", "waypoints", "static"] {
                    let spec = ScaffoldSpec {
                        name: "t".into(),
                        receivers: Layout::parse("--receivers", rx).unwrap(),
                        transmitters: None,
                        network: NetworkSpec::parse(net).unwrap(),
                        motion: MotionSpec::parse(motion).unwrap(),
                        seed: 1,
                    };
                    let Ok(text) = spec.to_toml() else {
                        assert!(net == "grid" && !rx.starts_with("grid"), "{rx} {net}");
                        continue;
                    };
                    let sc = Scenario::from_toml_str(&text, Path::new("new.toml"));
                    // A long thin line may leave an rgg disconnected: said clearly.
                    match sc {
                        Ok(sc) => assert_eq!(sc.graph.len(), spec.receivers.points(1).len()),
                        Err(e) => panic!("{rx} {net} {motion}: {e}\n{text}"),
                    }
                }
            }
        }
    }
}
