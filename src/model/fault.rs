//! Faults as a schedule: what can go wrong with a node or a link,
//! and when. I/O-free: a [`FaultSpec`] is what a scenario's `[[faults]]` entry
//! or a `--fault` flag says, typed as it is read (a [`FaultKind`] tagged by
//! `kind`, and [`When`]); [`FaultSpec::resolve`] checks it against the
//! network and turns it into a [`Fault`] in emulated seconds; the engines
//! apply [`Fault`]s.
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

use crate::model::error::{KeyError, in_range};
use crate::model::rng::{Stream, link_draw};
use serde::{Deserialize, Serialize};

crate::named_enum! {
    /// The name of a fault's kind (`kind = ...`, `--nemesis KINDS`).
    pub enum FaultName {
        /// The node does nothing until the fault ends.
        Pause = "pause",
        /// The node dies.
        Crash = "crash",
        /// The node starts again, fresh or from its checkpoint.
        Restart = "restart",
        /// Links between groups of nodes are blocked.
        Partition = "partition",
        /// Extra loss on one link.
        LinkLoss = "link_loss",
        /// Extra one-way delay on one link.
        Delay = "delay",
        /// A node's clock runs fast or slow.
        ClockDrift = "clock_drift",
    }
}

/// One `[[faults]]` entry or `--fault` flag: what goes wrong (`kind` and
/// its keys) and when. Read with every key checked by name (a key the kind
/// does not take, or a missing one, is refused as it is read); the values
/// are checked against the network by [`FaultSpec::resolve`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FaultSpec {
    /// What it does, with the keys of its kind.
    #[serde(flatten)]
    pub kind: FaultKind,
    /// When it starts and how long it lasts.
    #[serde(flatten)]
    pub when: When,
}

/// When a fault starts (`at_s` or `at_sample`) and how long it lasts
/// (`for_s`, `for_samples` or, if neither, until the run ends).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct When {
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

impl When {
    /// Its keys, as written.
    const KEYS: [&'static str; 4] = ["at_s", "at_sample", "for_s", "for_samples"];
}

/// A fault's table is split in two by key: the keys of [`When`] and the
/// rest, which is the kind's (internally tagged by `kind`, every key
/// checked). serde's `flatten` would read it in one go but cannot refuse
/// unknown keys.
impl<'de> Deserialize<'de> for FaultSpec {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let mut what = toml::Table::deserialize(d)?;
        let mut when = toml::Table::new();
        for key in When::KEYS {
            if let Some(v) = what.remove(key) {
                when.insert(key.into(), v);
            }
        }
        if !what.contains_key("kind") {
            return Err(D::Error::custom(format!(
                "missing field `kind` (one of {})",
                FaultName::NAMES.join(", ")
            )));
        }
        let kind = FaultKind::deserialize(toml::Value::Table(what))
            .map_err(|e| D::Error::custom(e.message()))?;
        let when = When::deserialize(toml::Value::Table(when))
            .map_err(|e| D::Error::custom(e.message()))?;
        Ok(FaultSpec { kind, when })
    }
}

/// What a fault does: the kind (`kind = "..."`, names as [`FaultName`])
/// with its keys.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
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
        /// From its last checkpoint (`state = "checkpoint"`), else from
        /// `init_u` (`state = "fresh"`, the default).
        #[serde(
            rename = "state",
            default,
            with = "restart_state",
            skip_serializing_if = "is_false"
        )]
        checkpoint: bool,
        /// Samples between two checkpoints (`checkpoint_every`, in
        /// [1, 1000000], default 1), counted from the start of the run.
        #[serde(
            rename = "checkpoint_every",
            default = "every_sample",
            skip_serializing_if = "is_every_sample"
        )]
        every: u32,
    },
    /// Links between groups are blocked.
    Partition {
        /// Two or more disjoint, non-empty groups of nodes.
        groups: Vec<Vec<u32>>,
    },
    /// Extra loss on a link.
    LinkLoss {
        /// One end.
        a: u32,
        /// The other.
        b: u32,
        /// Probability in [0, 1].
        p: f64,
    },
    /// Extra delay on a link.
    Delay {
        /// One end.
        a: u32,
        /// The other.
        b: u32,
        /// Seconds in [0, 3600].
        extra_s: f64,
    },
    /// A node's clock runs fast or slow.
    ClockDrift {
        /// The node.
        node: u32,
        /// Parts per million in [-500000, 500000].
        ppm: f64,
    },
}

fn is_false(b: &bool) -> bool {
    !*b
}

fn every_sample() -> u32 {
    1
}

fn is_every_sample(k: &u32) -> bool {
    *k == 1
}

/// `state = "fresh" | "checkpoint"` as the `checkpoint` flag of a restart.
mod restart_state {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(checkpoint: &bool, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(if *checkpoint { "checkpoint" } else { "fresh" })
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<bool, D::Error> {
        match String::deserialize(d)?.as_str() {
            "fresh" => Ok(false),
            "checkpoint" => Ok(true),
            other => Err(serde::de::Error::custom(format!(
                "state `{other}` is not `fresh` or `checkpoint`"
            ))),
        }
    }
}

impl FaultKind {
    /// The kind's name.
    pub fn which(&self) -> FaultName {
        match self {
            FaultKind::Pause { .. } => FaultName::Pause,
            FaultKind::Crash { .. } => FaultName::Crash,
            FaultKind::Restart { .. } => FaultName::Restart,
            FaultKind::Partition { .. } => FaultName::Partition,
            FaultKind::LinkLoss { .. } => FaultName::LinkLoss,
            FaultKind::Delay { .. } => FaultName::Delay,
            FaultKind::ClockDrift { .. } => FaultName::ClockDrift,
        }
    }

    /// The kind's name, as in the files.
    pub fn name(&self) -> &'static str {
        self.which().as_str()
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

    /// Checks its values among `n` nodes: a [`KeyError`].
    fn check(&self, n: usize) -> Result<(), KeyError> {
        let exists = |v: u32, key: &str| -> Result<(), KeyError> {
            if v as usize >= n {
                return Err(KeyError::new(
                    key,
                    format!("node {v} does not exist ({n} nodes)"),
                ));
            }
            Ok(())
        };
        let link = |a: u32, b: u32| -> Result<(), KeyError> {
            exists(a, "a")?;
            exists(b, "b")?;
            if a == b {
                return Err(KeyError::new("b", "a link joins two different nodes"));
            }
            Ok(())
        };
        match self {
            FaultKind::Pause { node } | FaultKind::Crash { node } => exists(*node, "node"),
            FaultKind::Restart { node, every, .. } => {
                exists(*node, "node")?;
                if !(1..=1_000_000).contains(every) {
                    return Err(KeyError::new(
                        "checkpoint_every",
                        format!("{every} is outside [1, 1000000]"),
                    ));
                }
                Ok(())
            }
            FaultKind::Partition { groups } => {
                if groups.len() < 2 || groups.iter().any(Vec::is_empty) {
                    return Err(KeyError::new("groups", "two or more non-empty groups"));
                }
                let mut seen = vec![false; n];
                for &v in groups.iter().flatten() {
                    let Some(s) = seen.get_mut(v as usize) else {
                        return Err(KeyError::new(
                            "groups",
                            format!("node {v} does not exist ({n} nodes)"),
                        ));
                    };
                    if *s {
                        return Err(KeyError::new(
                            "groups",
                            format!("node {v} is in two groups"),
                        ));
                    }
                    *s = true;
                }
                Ok(())
            }
            FaultKind::LinkLoss { a, b, p } => {
                link(*a, *b)?;
                in_range("p", *p, 0.0, 1.0)
            }
            FaultKind::Delay { a, b, extra_s } => {
                link(*a, *b)?;
                in_range("extra_s", *extra_s, 0.0, 3600.0)
            }
            FaultKind::ClockDrift { node, ppm } => {
                exists(*node, "node")?;
                in_range("ppm", *ppm, -500_000.0, 500_000.0)
            }
        }
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
    /// sample lasts `period_s` emulated seconds. a [`KeyError`] names
    /// the key (relative to the entry: `node`, `at_s`, ...).
    pub fn resolve(&self, n: usize, period_s: f64) -> Result<Fault, KeyError> {
        self.kind.check(n)?;
        let (at_s, until_s) = self.when(period_s)?;
        Ok(Fault {
            kind: self.kind.clone(),
            at_s,
            until_s,
        })
    }

    /// When the fault starts and ends (emulated seconds, samples `period_s`
    /// long; no end: it lasts until the run ends).
    fn when(&self, period_s: f64) -> Result<(f64, Option<f64>), KeyError> {
        let w = &self.when;
        let at_s = match (w.at_s, w.at_sample) {
            (Some(t), None) => {
                in_range("at_s", t, 0.0, 1e9)?;
                t
            }
            (None, Some(k)) => k as f64 * period_s,
            (None, None) => return Err(KeyError::new("at_s", "give at_s or at_sample")),
            (Some(_), Some(_)) => {
                return Err(KeyError::new(
                    "at_sample",
                    "give at_s or at_sample, not both",
                ));
            }
        };
        let dur = match (w.for_s, w.for_samples) {
            (Some(d), None) => {
                in_range("for_s", d, 1e-9, 1e9)?;
                Some(d)
            }
            (None, Some(0)) => return Err(KeyError::new("for_samples", "at least 1")),
            (None, Some(k)) => Some(k as f64 * period_s),
            (None, None) => None,
            (Some(_), Some(_)) => {
                return Err(KeyError::new(
                    "for_samples",
                    "give for_s or for_samples, not both",
                ));
            }
        };
        if dur.is_some() && !self.kind.lasts() {
            let key = if w.for_s.is_some() {
                "for_s"
            } else {
                "for_samples"
            };
            return Err(KeyError::new(
                key,
                format!("`{}` is instantaneous", self.kind.name()),
            ));
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
    /// `link_loss`, `delay`, `clock_drift`; at least one).
    pub kinds: Vec<FaultName>,
    /// Emulated seconds between two faults, in (0, 1e9]; the first comes
    /// after one interval.
    pub interval_s: f64,
}

impl NemesisCfg {
    /// Checks the kinds and the interval: a [`KeyError`].
    pub fn validate(&self) -> Result<(), KeyError> {
        if self.kinds.is_empty() {
            return Err(KeyError::new(
                "nemesis.kinds",
                "name at least one fault kind",
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
            let kind = self.kinds[rng.random_range(0..self.kinds.len())];
            let node = rng.random_range(0..n) as u32;
            let edge = (!edges.is_empty())
                .then(|| edges[rng.random_range(0..edges.len())])
                .map(|(a, b)| (a as u32, b as u32));
            let lasting = |kind: FaultKind| Fault {
                kind,
                at_s: t,
                until_s: Some(t + half),
            };
            match kind {
                FaultName::Pause => out.push(lasting(FaultKind::Pause { node })),
                FaultName::Crash => {
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
                FaultName::Restart => out.push(Fault {
                    kind: FaultKind::Restart {
                        node,
                        checkpoint: true,
                        every: 1,
                    },
                    at_s: t,
                    until_s: None,
                }),
                FaultName::Partition => {
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
                FaultName::LinkLoss => {
                    if let Some((a, b)) = edge {
                        out.push(lasting(FaultKind::LinkLoss { a, b, p: 0.5 }));
                    }
                }
                FaultName::Delay => {
                    if let Some((a, b)) = edge {
                        out.push(lasting(FaultKind::Delay {
                            a,
                            b,
                            extra_s: self.interval_s / 10.0,
                        }));
                    }
                }
                FaultName::ClockDrift => {
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
    fn a_bad_value_names_its_key_and_the_reason() {
        for (flag, key, needle) in [
            ("pause:node=9,at_s=1", "node", "does not exist"),
            ("crash:node=1,at_s=1,for_s=2", "for_s", "instantaneous"),
            ("pause:node=1", "at_s", "give at_s or at_sample"),
            ("pause:node=1,at_s=1,at_sample=2", "at_sample", "not both"),
            ("link_loss:a=1,b=1,p=0.5,at_s=1", "b", "two different nodes"),
            ("link_loss:a=0,b=1,p=1.5,at_s=1", "p", "outside"),
            ("delay:a=0,b=7,extra_s=1,at_s=1", "b", "does not exist"),
            ("clock_drift:node=0,ppm=1e6,at_s=1", "ppm", "outside"),
            (
                "partition:groups=[[0,1],[1,2]],at_s=1",
                "groups",
                "two groups",
            ),
            ("partition:groups=[[0,1]],at_s=1", "groups", "two or more"),
            (
                "restart:node=1,state=checkpoint,checkpoint_every=0,at_s=1",
                "checkpoint_every",
                "outside",
            ),
        ] {
            let KeyError {
                key: k,
                reason: why,
            } = spec(flag).resolve(6, 1.0).unwrap_err();
            assert_eq!(k, key, "{flag}");
            assert!(why.contains(needle), "{flag}: {why}");
        }
    }

    #[test]
    fn a_missing_or_foreign_key_or_an_unknown_kind_is_refused_as_it_is_read() {
        for (flag, needle) in [
            ("pause:at_s=1", "missing field `node`"),
            ("pause:node=1,p=0.5,at_s=1", "unknown field `p`"),
            ("pause:nod=1", "unknown field `nod`"),
            ("explode:node=1,at_s=1", "unknown variant `explode`"),
            (
                "restart:node=1,state=\"warm\",at_s=1",
                "not `fresh` or `checkpoint`",
            ),
            ("link_loss:a=0,b=1,at_s=1", "missing field `p`"),
            ("pause:node", "KEY=VALUE"),
        ] {
            let e = FaultSpec::parse_flag(flag).unwrap_err();
            assert!(e.contains(needle), "{flag}: {e}");
        }
        let e = toml::from_str::<FaultSpec>("node = 1\nat_s = 1").unwrap_err();
        assert!(e.to_string().contains("missing field `kind`"), "{e}");
    }

    #[test]
    fn a_fault_is_written_back_as_it_was_read_kind_first() {
        for flag in [
            "pause:node=3,at_s=20,for_s=10",
            "restart:node=1,at_sample=3",
            "restart:node=1,state=checkpoint,checkpoint_every=5,at_s=3",
            "partition:groups=[[0,1],[2]],at_s=0,for_samples=2",
            "link_loss:a=0,b=1,p=0.25,at_s=1",
            "delay:a=0,b=1,extra_s=0.5,at_s=1",
            "clock_drift:node=2,ppm=-100,at_s=1",
        ] {
            let f = spec(flag);
            let text = toml::to_string(&f).unwrap();
            assert!(text.starts_with("kind = "), "{flag}: {text}");
            assert_eq!(toml::from_str::<FaultSpec>(&text).unwrap(), f, "{flag}");
        }
        // The defaults of a restart are not written out.
        let text = toml::to_string(&spec("restart:node=1,at_s=3")).unwrap();
        assert_eq!(text, "kind = \"restart\"\nnode = 1\nat_s = 3.0\n");
        // Every kind's tag is its FaultName.
        let kinds = [
            "pause:node=0,at_s=0",
            "crash:node=0,at_s=0",
            "restart:node=0,at_s=0",
            "partition:groups=[[0],[1]],at_s=0",
            "link_loss:a=0,b=1,p=0.5,at_s=0",
            "delay:a=0,b=1,extra_s=1,at_s=0",
            "clock_drift:node=0,ppm=1,at_s=0",
        ]
        .map(|f| spec(f).kind.which());
        assert_eq!(&kinds[..], FaultName::ALL);
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
            kinds: vec![FaultName::Pause, FaultName::Crash, FaultName::Partition],
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
            kinds: vec![],
            interval_s: 1.0,
        };
        assert_eq!(bad.validate().unwrap_err().key, "nemesis.kinds");
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
