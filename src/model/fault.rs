//! Faults as a schedule: what can go wrong with a node or a link,
//! and when. I/O-free: a [`FaultSpec`] is what a scenario's `[[faults]]` entry
//! or a `--fault` flag says; [`FaultSpec::resolve`] checks it and turns it into
//! a [`Fault`] in emulated seconds; the engines apply [`Fault`]s.
//!
//! Kinds (the anchors are Jepsen's nemesis, Maelstrom and turmoil):
//! * `pause { node }`: the node does nothing until the fault ends (SIGSTOP /
//!   SIGCONT on node processes); what reaches it meanwhile waits for it;
//! * `crash { node }`: the node dies (SIGKILL);
//! * `restart { node, state = "fresh" | "checkpoint" }`: the node (crashed
//!   first if alive) starts again, from `init_u` or from its last checkpoint;
//! * `partition { groups }`: every link between two groups is blocked until
//!   the fault ends;
//! * `link_loss { a, b, p }`: extra loss probability on the link `a - b`;
//! * `delay { a, b, extra_s }`: extra one-way delay on the link `a - b`;
//! * `clock_drift { node, ppm }`: the node's Poisson clock and timeouts run
//!   `ppm` parts per million fast (positive) or slow (negative).
//!
//! Each fault starts `at_s` emulated seconds after the run starts, or at the
//! start of sample `at_sample`; a fault that lasts (`pause`, `partition`,
//! `link_loss`, `delay`, `clock_drift`) ends after `for_s` seconds or
//! `for_samples` samples, or never if neither is given.

use crate::model::error::in_range;
use crate::model::rng::{Stream, link_draw};
use serde::{Deserialize, Serialize};

/// One `[[faults]]` entry or `--fault` flag, as written. Every key but
/// `kind` is optional here; [`FaultSpec::resolve`] checks which the kind
/// needs and which it refuses.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaultSpec {
    /// `pause`, `crash`, `restart`, `partition`, `link_loss`, `delay` or
    /// `clock_drift`.
    pub kind: String,
    /// The node (`pause`, `crash`, `restart`, `clock_drift`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node: Option<u32>,
    /// `restart`: `fresh` (the default) or `checkpoint`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state: Option<String>,
    /// `restart` from `checkpoint`: the node saves its state every this many
    /// samples, from the start of the run (default 1, at most 1e6).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub checkpoint_every: Option<u32>,
    /// `partition`: two or more disjoint groups of nodes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub groups: Option<Vec<Vec<u32>>>,
    /// One end of the link (`link_loss`, `delay`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub a: Option<u32>,
    /// The other end.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub b: Option<u32>,
    /// `link_loss`: loss probability in [0, 1].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub p: Option<f64>,
    /// `delay`: extra one-way delay, seconds in [0, 3600].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extra_s: Option<f64>,
    /// `clock_drift`: parts per million in [-500000, 500000].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ppm: Option<f64>,
    /// Start, emulated seconds in [0, 1e9].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub at_s: Option<f64>,
    /// Start: the start of this sample.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub at_sample: Option<u32>,
    /// Duration, emulated seconds in (0, 1e9].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub for_s: Option<f64>,
    /// Duration in samples (at least 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub for_samples: Option<u32>,
}

/// What a fault does.
#[derive(Debug, Clone, PartialEq)]
pub enum FaultKind {
    /// The node does nothing.
    Pause {
        /// The node.
        node: u32,
    },
    /// The node dies.
    Crash {
        /// The node.
        node: u32,
    },
    /// The node starts again.
    Restart {
        /// The node.
        node: u32,
        /// From its last checkpoint (else from `init_u`).
        checkpoint: bool,
        /// Samples between two checkpoints.
        every: u32,
    },
    /// Links between groups are blocked.
    Partition {
        /// The groups; `group[i]` is node `i`'s group (`None`: in none).
        groups: Vec<Vec<u32>>,
    },
    /// Extra loss on a link.
    LinkLoss {
        /// One end.
        a: u32,
        /// The other.
        b: u32,
        /// Probability.
        p: f64,
    },
    /// Extra delay on a link.
    Delay {
        /// One end.
        a: u32,
        /// The other.
        b: u32,
        /// Seconds.
        extra_s: f64,
    },
    /// A node's clock runs fast or slow.
    ClockDrift {
        /// The node.
        node: u32,
        /// Parts per million.
        ppm: f64,
    },
}

impl FaultKind {
    /// The kind's name, as in the files.
    pub fn name(&self) -> &'static str {
        match self {
            FaultKind::Pause { .. } => "pause",
            FaultKind::Crash { .. } => "crash",
            FaultKind::Restart { .. } => "restart",
            FaultKind::Partition { .. } => "partition",
            FaultKind::LinkLoss { .. } => "link_loss",
            FaultKind::Delay { .. } => "delay",
            FaultKind::ClockDrift { .. } => "clock_drift",
        }
    }

    /// The nodes it concerns (`faults.csv` `nodes`).
    pub fn nodes(&self) -> Vec<u32> {
        match self {
            FaultKind::Pause { node }
            | FaultKind::Crash { node }
            | FaultKind::Restart { node, .. }
            | FaultKind::ClockDrift { node, .. } => vec![*node],
            FaultKind::Partition { groups } => groups.iter().flatten().copied().collect(),
            FaultKind::LinkLoss { a, b, .. } | FaultKind::Delay { a, b, .. } => vec![*a, *b],
        }
    }

    /// Its parameters in words (`faults.csv` `detail`).
    pub fn detail(&self) -> String {
        match self {
            FaultKind::Pause { .. } | FaultKind::Crash { .. } => String::new(),
            FaultKind::Restart {
                checkpoint, every, ..
            } => {
                if *checkpoint {
                    format!("checkpoint every {every} samples")
                } else {
                    "fresh".into()
                }
            }
            FaultKind::Partition { groups } => groups
                .iter()
                .map(|g| g.iter().map(u32::to_string).collect::<Vec<_>>().join(" "))
                .collect::<Vec<_>>()
                .join(" | "),
            FaultKind::LinkLoss { p, .. } => format!("p={p}"),
            FaultKind::Delay { extra_s, .. } => format!("extra_s={extra_s}"),
            FaultKind::ClockDrift { ppm, .. } => format!("ppm={ppm}"),
        }
    }

    /// Whether it acts on links (a partition, link loss or delay).
    pub fn on_links(&self) -> bool {
        matches!(
            self,
            FaultKind::Partition { .. } | FaultKind::LinkLoss { .. } | FaultKind::Delay { .. }
        )
    }

    /// Whether it lasts (has an end).
    fn lasts(&self) -> bool {
        !matches!(self, FaultKind::Crash { .. } | FaultKind::Restart { .. })
    }
}

/// A checked fault, in emulated seconds.
#[derive(Debug, Clone, PartialEq)]
pub struct Fault {
    /// What it does.
    pub kind: FaultKind,
    /// When it starts.
    pub at_s: f64,
    /// When it ends (`None`: it does not, or it is instantaneous).
    pub until_s: Option<f64>,
}

impl FaultSpec {
    /// Checks the spec against `n` nodes and turns it into a [`Fault`]; a
    /// sample lasts `period_s` emulated seconds. `Err((key, reason))` names
    /// the key (relative to the entry: `node`, `at_s`, ...).
    pub fn resolve(&self, n: usize, period_s: f64) -> Result<Fault, (String, String)> {
        let kind = self.kind_among(n)?;
        self.takes_only_keys_of(&kind)?;
        let (at_s, until_s) = self.when(&kind, period_s)?;
        Ok(Fault {
            kind,
            at_s,
            until_s,
        })
    }

    /// What the fault does, among `n` nodes: its kind with the keys it needs.
    fn kind_among(&self, n: usize) -> Result<FaultKind, (String, String)> {
        let need = |v: Option<u32>, key: &str| -> Result<u32, (String, String)> {
            let v = v.ok_or_else(|| (key.to_string(), format!("`{}` needs it", self.kind)))?;
            if v as usize >= n {
                return Err((key.into(), format!("node {v} does not exist ({n} nodes)")));
            }
            Ok(v)
        };
        let link = || -> Result<(u32, u32), (String, String)> {
            let (a, b) = (need(self.a, "a")?, need(self.b, "b")?);
            if a == b {
                return Err(("b".into(), "a link joins two different nodes".into()));
            }
            Ok((a, b))
        };
        let kind = match self.kind.as_str() {
            "pause" => FaultKind::Pause {
                node: need(self.node, "node")?,
            },
            "crash" => FaultKind::Crash {
                node: need(self.node, "node")?,
            },
            "restart" => FaultKind::Restart {
                node: need(self.node, "node")?,
                every: match self.checkpoint_every {
                    None => 1,
                    Some(k) if (1..=1_000_000).contains(&k) => k,
                    Some(k) => {
                        return Err((
                            "checkpoint_every".into(),
                            format!("{k} is outside [1, 1000000]"),
                        ));
                    }
                },
                checkpoint: match self.state.as_deref() {
                    None | Some("fresh") => false,
                    Some("checkpoint") => true,
                    Some(o) => {
                        return Err((
                            "state".into(),
                            format!("`{o}` is not `fresh` or `checkpoint`"),
                        ));
                    }
                },
            },
            "partition" => {
                let groups = self
                    .groups
                    .clone()
                    .ok_or_else(|| ("groups".to_string(), "`partition` needs it".to_string()))?;
                if groups.len() < 2 || groups.iter().any(Vec::is_empty) {
                    return Err(("groups".into(), "two or more non-empty groups".into()));
                }
                let mut seen = vec![false; n];
                for &v in groups.iter().flatten() {
                    let Some(s) = seen.get_mut(v as usize) else {
                        return Err((
                            "groups".into(),
                            format!("node {v} does not exist ({n} nodes)"),
                        ));
                    };
                    if *s {
                        return Err(("groups".into(), format!("node {v} is in two groups")));
                    }
                    *s = true;
                }
                FaultKind::Partition { groups }
            }
            "link_loss" => {
                let (a, b) = link()?;
                let p = self
                    .p
                    .ok_or_else(|| ("p".to_string(), "`link_loss` needs it".to_string()))?;
                in_range("p", p, 0.0, 1.0)?;
                FaultKind::LinkLoss { a, b, p }
            }
            "delay" => {
                let (a, b) = link()?;
                let e = self
                    .extra_s
                    .ok_or_else(|| ("extra_s".to_string(), "`delay` needs it".to_string()))?;
                in_range("extra_s", e, 0.0, 3600.0)?;
                FaultKind::Delay { a, b, extra_s: e }
            }
            "clock_drift" => {
                let node = need(self.node, "node")?;
                let ppm = self
                    .ppm
                    .ok_or_else(|| ("ppm".to_string(), "`clock_drift` needs it".to_string()))?;
                in_range("ppm", ppm, -500_000.0, 500_000.0)?;
                FaultKind::ClockDrift { node, ppm }
            }
            other => {
                return Err((
                    "kind".into(),
                    format!(
                        "`{other}` is not a fault (pause, crash, restart, partition, link_loss, delay, clock_drift)"
                    ),
                ));
            }
        };
        Ok(kind)
    }

    /// Refuses a key the fault's kind does not take.
    fn takes_only_keys_of(&self, kind: &FaultKind) -> Result<(), (String, String)> {
        let takes: &[&str] = match kind {
            FaultKind::Pause { .. } | FaultKind::Crash { .. } => &["node"],
            FaultKind::Restart { .. } => &["node", "state", "checkpoint_every"],
            FaultKind::Partition { .. } => &["groups"],
            FaultKind::LinkLoss { .. } => &["a", "b", "p"],
            FaultKind::Delay { .. } => &["a", "b", "extra_s"],
            FaultKind::ClockDrift { .. } => &["node", "ppm"],
        };
        let given = [
            ("node", self.node.is_some()),
            ("state", self.state.is_some()),
            ("checkpoint_every", self.checkpoint_every.is_some()),
            ("groups", self.groups.is_some()),
            ("a", self.a.is_some()),
            ("b", self.b.is_some()),
            ("p", self.p.is_some()),
            ("extra_s", self.extra_s.is_some()),
            ("ppm", self.ppm.is_some()),
        ];
        if let Some((k, _)) = given.iter().find(|(k, g)| *g && !takes.contains(k)) {
            return Err((k.to_string(), format!("`{}` does not take it", self.kind)));
        }
        Ok(())
    }

    /// When the fault starts and ends (emulated seconds, samples `period_s`
    /// long; no end: it lasts until the run ends).
    fn when(
        &self,
        kind: &FaultKind,
        period_s: f64,
    ) -> Result<(f64, Option<f64>), (String, String)> {
        let at_s = match (self.at_s, self.at_sample) {
            (Some(t), None) => {
                in_range("at_s", t, 0.0, 1e9)?;
                t
            }
            (None, Some(k)) => k as f64 * period_s,
            (None, None) => return Err(("at_s".into(), "give at_s or at_sample".into())),
            (Some(_), Some(_)) => {
                return Err((
                    "at_sample".into(),
                    "give at_s or at_sample, not both".into(),
                ));
            }
        };
        let dur = match (self.for_s, self.for_samples) {
            (Some(d), None) => {
                in_range("for_s", d, 1e-9, 1e9)?;
                Some(d)
            }
            (None, Some(0)) => return Err(("for_samples".into(), "at least 1".into())),
            (None, Some(k)) => Some(k as f64 * period_s),
            (None, None) => None,
            (Some(_), Some(_)) => {
                return Err((
                    "for_samples".into(),
                    "give for_s or for_samples, not both".into(),
                ));
            }
        };
        if dur.is_some() && !kind.lasts() {
            let key = if self.for_s.is_some() {
                "for_s"
            } else {
                "for_samples"
            };
            return Err((key.into(), format!("`{}` is instantaneous", self.kind)));
        }
        Ok((at_s, dur.map(|d| at_s + d)))
    }

    /// Parses a `--fault` flag, `KIND:KEY=VALUE,KEY=VALUE,...`; each value is
    /// TOML (`groups=[[0,1],[2,3]]` works; commas inside brackets belong to
    /// the value).
    pub fn parse_flag(s: &str) -> Result<FaultSpec, String> {
        let (kind, rest) = s.split_once(':').unwrap_or((s, ""));
        let mut table = toml::Table::new();
        table.insert("kind".into(), toml::Value::String(kind.trim().into()));
        let mut depth = 0i32;
        let mut parts = Vec::new();
        let mut cur = String::new();
        for c in rest.chars() {
            match c {
                '[' => depth += 1,
                ']' => depth -= 1,
                _ => {}
            }
            if c == ',' && depth == 0 {
                parts.push(std::mem::take(&mut cur));
            } else {
                cur.push(c);
            }
        }
        if !cur.trim().is_empty() {
            parts.push(cur);
        }
        for p in parts {
            let (k, v) = p
                .split_once('=')
                .ok_or_else(|| format!("`{p}` is not KEY=VALUE"))?;
            let v = v.trim();
            let doc = format!("v = {v}");
            // A bare word is a string (`state=checkpoint`), as a shell user
            // would type it; anything else is a TOML value.
            let bare = !v.is_empty()
                && v.chars()
                    .all(|c| c.is_ascii_alphabetic() || c == '_' || c == '-');
            let value = match doc.parse::<toml::Table>() {
                Ok(t) => t.get("v").cloned().unwrap_or(toml::Value::Integer(0)),
                Err(_) if bare => toml::Value::String(v.into()),
                Err(_) => return Err(format!("`{}`: `{v}` is not a value", k.trim())),
            };
            table.insert(k.trim().into(), value);
        }
        toml::Value::Table(table)
            .try_into()
            .map_err(|e: toml::de::Error| e.message().to_string())
    }
}

/// The faults in force on the links at one moment: partitions, extra loss
/// and extra delay. Undirected: a fault on `a - b` applies both ways.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LinkFaults {
    /// Active partitions (each as its node-to-group map).
    partitions: Vec<(usize, Vec<Option<usize>>)>,
    /// Active `link_loss` faults: `(id, a, b, p)`.
    loss: Vec<(usize, u32, u32, f64)>,
    /// Active `delay` faults: `(id, a, b, extra_s)`.
    delay: Vec<(usize, u32, u32, f64)>,
}

fn same_link(a: u32, b: u32, i: u32, j: u32) -> bool {
    (a, b) == (i, j) || (a, b) == (j, i)
}

impl LinkFaults {
    /// True if no fault is in force on any link.
    pub fn is_empty(&self) -> bool {
        self.partitions.is_empty() && self.loss.is_empty() && self.delay.is_empty()
    }

    /// Fault `id` (a partition, link loss or delay) starts; other kinds are
    /// ignored.
    pub fn start(&mut self, id: usize, kind: &FaultKind) {
        match kind {
            FaultKind::Partition { groups } => {
                let n = groups
                    .iter()
                    .flatten()
                    .map(|&v| v as usize + 1)
                    .max()
                    .unwrap_or(0);
                let mut of = vec![None; n];
                for (g, members) in groups.iter().enumerate() {
                    for &v in members {
                        of[v as usize] = Some(g);
                    }
                }
                self.partitions.push((id, of));
            }
            FaultKind::LinkLoss { a, b, p } => self.loss.push((id, *a, *b, *p)),
            FaultKind::Delay { a, b, extra_s } => self.delay.push((id, *a, *b, *extra_s)),
            _ => {}
        }
    }

    /// Fault `id` ends (heals).
    pub fn end(&mut self, id: usize) {
        self.partitions.retain(|p| p.0 != id);
        self.loss.retain(|l| l.0 != id);
        self.delay.retain(|l| l.0 != id);
    }

    /// True if a partition separates `i` and `j` (two nodes in different
    /// groups; a node in no group is cut from none).
    pub fn blocked(&self, i: u32, j: u32) -> bool {
        self.partitions.iter().any(|(_, of)| {
            match (
                of.get(i as usize).copied().flatten(),
                of.get(j as usize).copied().flatten(),
            ) {
                (Some(x), Some(y)) => x != y,
                _ => false,
            }
        })
    }

    /// The extra loss probability of the link `i - j` (independent faults
    /// combine: `1 - prod(1 - p)`).
    pub fn loss(&self, i: u32, j: u32) -> f64 {
        1.0 - self
            .loss
            .iter()
            .filter(|l| same_link(l.1, l.2, i, j))
            .map(|l| 1.0 - l.3)
            .product::<f64>()
    }

    /// The extra one-way delay of the link `i - j`, seconds (faults add up).
    pub fn delay(&self, i: u32, j: u32) -> f64 {
        self.delay
            .iter()
            .filter(|l| same_link(l.1, l.2, i, j))
            .map(|l| l.3)
            .sum()
    }
}

/// The ideal channel under link faults: a frame arrives at once unless a
/// partition blocks it, a `link_loss` draw ([`fault_draw`]) drops it, or a
/// `delay` holds it. The ideal carrier of the world's channel
/// ([`crate::world::medium::Channel`]), which every engine drives.
#[derive(Debug, Clone, Default)]
pub struct IdealLinks {
    /// The faults in force, set by the engine as they start and end.
    pub faults: LinkFaults,
    /// Frames sent per directed link while a fault was in force.
    numbers: std::collections::HashMap<(u32, u32), u64>,
}

impl IdealLinks {
    /// The fate of a frame `from -> to` sent now, on a run with seed `seed`:
    /// `Some(extra delay, s)` if it arrives, `None` if it is lost. Frames
    /// are numbered per link only while some fault is in force.
    pub fn send(&mut self, seed: u64, from: u32, to: u32) -> Option<f64> {
        if self.faults.is_empty() {
            return Some(0.0);
        }
        let k = self.numbers.entry((from, to)).or_insert(0);
        let number = *k;
        *k += 1;
        if self.faults.blocked(from, to) {
            return None;
        }
        let p = self.faults.loss(from, to);
        if p > 0.0 && fault_draw(seed, from, to, number) < p {
            return None;
        }
        Some(self.faults.delay(from, to))
    }
}

/// `[nemesis]` / `--nemesis`: random faults, drawn from the run seed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NemesisCfg {
    /// Kinds to draw from (any of `pause`, `crash`, `restart`, `partition`,
    /// `link_loss`, `delay`, `clock_drift`).
    pub kinds: Vec<String>,
    /// Emulated seconds between two faults, in (0, 1e9]; the first comes
    /// after one interval.
    pub interval_s: f64,
}

impl NemesisCfg {
    /// Checks the kinds and the interval: `Err((key, reason))`.
    pub fn validate(&self) -> Result<(), (String, String)> {
        const KINDS: [&str; 7] = [
            "pause",
            "crash",
            "restart",
            "partition",
            "link_loss",
            "delay",
            "clock_drift",
        ];
        if self.kinds.is_empty() {
            return Err((
                "nemesis.kinds".into(),
                "name at least one fault kind".into(),
            ));
        }
        if let Some(k) = self.kinds.iter().find(|k| !KINDS.contains(&k.as_str())) {
            return Err((
                "nemesis.kinds".into(),
                format!("`{k}` is not a fault ({})", KINDS.join(", ")),
            ));
        }
        in_range("nemesis.interval_s", self.interval_s, 1e-9, 1e9)
    }

    /// The faults of a run of `horizon_s` emulated seconds over `n` nodes
    /// joined by `edges`, drawn from the run seed (stream
    /// [`Stream::Faults`], index 0): every `interval_s`, a kind drawn
    /// uniformly from `kinds`, lasting half an interval where it lasts:
    /// `pause`, `restart` (from a checkpoint) and `clock_drift` (+-10 %) of a
    /// random node; `crash` of a random node, restarted fresh half an
    /// interval later (a bounce); `partition` into a random half and the rest;
    /// `link_loss` (p = 0.5) and `delay` (a tenth of an interval) on a random
    /// edge.
    pub fn draw(
        &self,
        seed: u64,
        horizon_s: f64,
        n: usize,
        edges: &[(usize, usize)],
    ) -> Vec<Fault> {
        use rand::RngExt;
        let mut rng = crate::model::rng::stream_rng(seed, Stream::Faults, 0);
        let mut out = Vec::new();
        if n == 0 {
            return out;
        }
        let half = self.interval_s / 2.0;
        let mut t = self.interval_s;
        while t < horizon_s && out.len() < 100_000 {
            let kind = &self.kinds[rng.random_range(0..self.kinds.len())];
            let node = rng.random_range(0..n) as u32;
            let edge = (!edges.is_empty())
                .then(|| edges[rng.random_range(0..edges.len())])
                .map(|(a, b)| (a as u32, b as u32));
            let lasting = |kind: FaultKind| Fault {
                kind,
                at_s: t,
                until_s: Some(t + half),
            };
            match kind.as_str() {
                "pause" => out.push(lasting(FaultKind::Pause { node })),
                "crash" => {
                    out.push(Fault {
                        kind: FaultKind::Crash { node },
                        at_s: t,
                        until_s: None,
                    });
                    out.push(Fault {
                        kind: FaultKind::Restart {
                            node,
                            checkpoint: false,
                            every: 1,
                        },
                        at_s: t + half,
                        until_s: None,
                    });
                }
                "restart" => out.push(Fault {
                    kind: FaultKind::Restart {
                        node,
                        checkpoint: true,
                        every: 1,
                    },
                    at_s: t,
                    until_s: None,
                }),
                "partition" => {
                    let mut order: Vec<u32> = (0..n as u32).collect();
                    for i in (1..order.len()).rev() {
                        order.swap(i, rng.random_range(0..=i));
                    }
                    let cut = (n / 2).max(1);
                    let (a, b) = order.split_at(cut);
                    if !b.is_empty() {
                        out.push(lasting(FaultKind::Partition {
                            groups: vec![a.to_vec(), b.to_vec()],
                        }));
                    }
                }
                "link_loss" => {
                    if let Some((a, b)) = edge {
                        out.push(lasting(FaultKind::LinkLoss { a, b, p: 0.5 }));
                    }
                }
                "delay" => {
                    if let Some((a, b)) = edge {
                        out.push(lasting(FaultKind::Delay {
                            a,
                            b,
                            extra_s: self.interval_s / 10.0,
                        }));
                    }
                }
                _ => {
                    let ppm = if rng.random_bool(0.5) { 1e5 } else { -1e5 };
                    out.push(lasting(FaultKind::ClockDrift { node, ppm }));
                }
            }
            t += self.interval_s;
        }
        out
    }
}

/// The uniform draw in `[0, 1)` that decides whether frame number `k` on the
/// directed link `from -> to` is lost to a `link_loss` fault.
pub fn fault_draw(seed: u64, from: u32, to: u32, k: u64) -> f64 {
    link_draw(seed, Stream::Faults, from, to, k)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(s: &str) -> FaultSpec {
        FaultSpec::parse_flag(s).unwrap()
    }

    #[test]
    fn a_fault_flag_parses_into_the_scenario_table_and_resolves_in_seconds() {
        let f = spec("pause:node=3,at_s=20,for_s=10")
            .resolve(6, 5.0)
            .unwrap();
        assert_eq!(f.kind, FaultKind::Pause { node: 3 });
        assert_eq!((f.at_s, f.until_s), (20.0, Some(30.0)));
        let f = spec("partition:groups=[[0,1,2],[3,4,5]],at_sample=4,for_samples=2")
            .resolve(6, 5.0)
            .unwrap();
        assert_eq!((f.at_s, f.until_s), (20.0, Some(30.0)));
        assert_eq!(f.kind.detail(), "0 1 2 | 3 4 5");
        let f = spec("restart:node=1,state=\"checkpoint\",at_s=3")
            .resolve(6, 5.0)
            .unwrap();
        assert_eq!(
            f.kind,
            FaultKind::Restart {
                node: 1,
                checkpoint: true,
                every: 1
            }
        );
        // A bare word is a string, as typed in a shell.
        let bare = spec("restart:node=1,state=checkpoint,at_s=3")
            .resolve(6, 5.0)
            .unwrap();
        assert_eq!(bare.kind, f.kind);
        assert!(FaultSpec::parse_flag("pause:node=1,at_s=1.2.3").is_err());
    }

    #[test]
    fn a_bad_fault_names_its_key_and_the_reason() {
        for (flag, key, needle) in [
            ("pause:at_s=1", "node", "needs it"),
            ("pause:node=9,at_s=1", "node", "does not exist"),
            ("crash:node=1,at_s=1,for_s=2", "for_s", "instantaneous"),
            ("pause:node=1", "at_s", "give at_s or at_sample"),
            ("link_loss:a=1,b=1,p=0.5,at_s=1", "b", "two different nodes"),
            ("link_loss:a=0,b=1,p=1.5,at_s=1", "p", "outside"),
            (
                "partition:groups=[[0,1],[1,2]],at_s=1",
                "groups",
                "two groups",
            ),
            ("pause:node=1,p=0.5,at_s=1", "p", "does not take it"),
            ("explode:node=1,at_s=1", "kind", "not a fault"),
            ("restart:node=1,state=\"warm\",at_s=1", "state", "fresh"),
        ] {
            let (k, why) = spec(flag).resolve(6, 1.0).unwrap_err();
            assert_eq!(k, key, "{flag}");
            assert!(why.contains(needle), "{flag}: {why}");
        }
        assert!(FaultSpec::parse_flag("pause:node").is_err());
        let e = FaultSpec::parse_flag("pause:nod=1").unwrap_err();
        assert!(e.contains("unknown field"), "{e}");
    }

    #[test]
    fn link_faults_block_across_groups_add_delays_and_combine_losses_until_healed() {
        let mut lf = LinkFaults::default();
        let part = spec("partition:groups=[[0,1],[2,3]],at_s=0")
            .resolve(5, 1.0)
            .unwrap();
        lf.start(0, &part.kind);
        assert!(lf.blocked(0, 2) && lf.blocked(3, 1));
        assert!(!lf.blocked(0, 1) && !lf.blocked(2, 3) && !lf.blocked(4, 0));
        lf.start(1, &FaultKind::LinkLoss { a: 0, b: 1, p: 0.5 });
        lf.start(2, &FaultKind::LinkLoss { a: 1, b: 0, p: 0.5 });
        assert!((lf.loss(0, 1) - 0.75).abs() < 1e-15 && lf.loss(0, 2).abs() < 1e-15);
        lf.start(
            3,
            &FaultKind::Delay {
                a: 2,
                b: 3,
                extra_s: 1.5,
            },
        );
        assert!((lf.delay(3, 2) - 1.5).abs() < 1e-15);
        for id in 0..4 {
            lf.end(id);
        }
        assert!(lf.is_empty() && !lf.blocked(0, 2));
    }

    #[test]
    fn the_nemesis_draws_the_same_faults_from_the_same_seed_and_others_from_another() {
        let nem = NemesisCfg {
            kinds: vec!["pause".into(), "crash".into(), "partition".into()],
            interval_s: 1.0,
        };
        nem.validate().unwrap();
        let edges = [(0, 1), (1, 2), (2, 3)];
        let a = nem.draw(5, 20.5, 4, &edges);
        assert_eq!(a, nem.draw(5, 20.5, 4, &edges));
        assert_ne!(a, nem.draw(6, 20.5, 4, &edges));
        // One fault a second (a crash comes with its restart).
        let starts: Vec<f64> = a
            .iter()
            .filter(|f| !matches!(f.kind, FaultKind::Restart { .. }))
            .map(|f| f.at_s)
            .collect();
        assert_eq!(starts.len(), 20);
        for f in &a {
            assert!(f.kind.nodes().iter().all(|&v| v < 4), "{f:?}");
        }
        let bad = NemesisCfg {
            kinds: vec!["flood".into()],
            interval_s: 1.0,
        };
        assert_eq!(bad.validate().unwrap_err().0, "nemesis.kinds");
    }

    #[test]
    fn fault_draws_are_uniform_and_keyed_by_link_and_number() {
        let n = 20_000;
        let hits = (0..n).filter(|&k| fault_draw(7, 0, 1, k) < 0.25).count();
        let rate = hits as f64 / n as f64;
        assert!(
            (rate - 0.25).abs() < 3.29 * (0.25 * 0.75 / n as f64).sqrt(),
            "{rate}"
        );
        assert!((fault_draw(7, 0, 1, 5) - fault_draw(7, 1, 0, 5)).abs() > 0.0);
    }
}
