//! Who really sent a frame: a frame's `from` is what its sender wrote, but
//! the shared-memory sample it came in names the publisher, and the
//! publisher's iceoryx2 node names the process that created it. The
//! coordinator knows the process id of every node it started, so a frame
//! from a process that is not the node it claims to be is caught here.
//!
//! The nodes learn the process ids from the run's **roster**, a file the
//! coordinator writes in the run's namespace of the per-user iceoryx2 root
//! (`<root>/<run prefix>.roster`, mode 0600 in a 0700 directory) before it
//! opens the start gate, and again when it restarts a node; a node reads it
//! when a publisher it does not know sends it a frame. The file goes with
//! the run's other resources (the coordinator removes it; the last node out
//! of a run whose coordinator was killed, or the next run's clean-up, does).
//! Like the check itself, this guards against broken peers, not against a
//! process of the same user set on forging shared memory.

use super::PubSub;
use super::Svc;
use crate::transport::wire::{COORDINATOR_ID, Frame};
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::PortFactory;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The roster file's name after the run's resource prefix.
pub(super) const ROSTER_SUFFIX: &str = ".roster";

/// The largest roster read (a line per node of at most 4096, and the
/// coordinator's).
const MAX_ROSTER_BYTES: u64 = 1 << 20;

/// How often a node reads the roster again at most, while publishers it
/// does not know send it frames (a restarted peer's new process is on it
/// within microseconds of its start; a stranger's flood costs no more than
/// this).
const RELOAD_EVERY: std::time::Duration = std::time::Duration::from_millis(10);

/// The roster file of the run with resource prefix `prefix`.
pub(super) fn roster_path(prefix: &str) -> Result<PathBuf, crate::transport::TransportError> {
    let cfg = super::base_config()?;
    Ok(super::iox_path_to_std(cfg.global.root_path()).join(format!("{prefix}{ROSTER_SUFFIX}")))
}

/// The node processes an endpoint accepts frames from, by process id.
#[derive(Debug, Default)]
pub(super) struct Senders {
    /// Process id -> node ([`COORDINATOR_ID`] for the coordinator).
    pids: HashMap<i64, u32>,
    /// Publisher id -> the node its process is (only publishers found).
    known: HashMap<u128, u32>,
    /// A node's: the roster to read the process ids from, and when it was
    /// last read (read again for a publisher it does not know, at most
    /// every [`RELOAD_EVERY`]).
    roster: Option<PathBuf>,
    read_at: Option<std::time::Instant>,
    /// The coordinator's: the roster to write, and whether it is behind.
    writes: Option<PathBuf>,
    stale: bool,
}

impl Senders {
    /// A node's senders, from the roster file `path`.
    pub(super) fn from_roster(path: PathBuf) -> Senders {
        let mut s = Senders {
            roster: Some(path),
            ..Senders::default()
        };
        s.reload();
        s
    }

    /// The coordinator's senders, which write the roster `path` (with
    /// `coordinator`, its own process id).
    pub(super) fn writing(path: PathBuf, coordinator: u32) -> Senders {
        let mut s = Senders {
            writes: Some(path),
            ..Senders::default()
        };
        s.pids.insert(i64::from(coordinator), COORDINATOR_ID);
        s
    }

    /// Node `node` runs as process `pid` (again, after a restart).
    pub(super) fn set(&mut self, node: u32, pid: u32) {
        self.pids.retain(|_, n| *n != node);
        self.pids.insert(i64::from(pid), node);
        self.known.retain(|_, n| *n != node);
        self.stale = true;
    }

    /// The roster's text: one `node pid` line per process, `c` for the
    /// coordinator, by node.
    fn roster_text(&self) -> String {
        let mut lines: Vec<(u32, i64)> = self.pids.iter().map(|(p, n)| (*n, *p)).collect();
        lines.sort_unstable();
        let mut out = String::new();
        for (n, p) in lines {
            if n == COORDINATOR_ID {
                out.push_str(&format!("c {p}\n"));
            } else {
                out.push_str(&format!("{n} {p}\n"));
            }
        }
        out
    }

    /// The coordinator's: write the roster if it is behind (atomically: a
    /// temporary file of mode 0600, then a rename).
    pub(super) fn publish(&mut self) -> std::io::Result<()> {
        use std::io::Write;
        use std::os::unix::fs::OpenOptionsExt;
        let (Some(path), true) = (self.writes.as_ref(), self.stale) else {
            return Ok(());
        };
        let tmp = path.with_extension("roster.tmp");
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(true)
            .mode(0o600)
            .open(&tmp)?;
        f.write_all(self.roster_text().as_bytes())?;
        std::fs::rename(&tmp, path)?;
        self.stale = false;
        Ok(())
    }

    /// The coordinator's: remove the roster (the run is over).
    pub(super) fn withdraw(&mut self) {
        if let Some(p) = self.writes.take() {
            let _ = std::fs::remove_file(p);
        }
    }

    /// A node's: read the roster again (a missing or unreadable one leaves
    /// what is known).
    fn reload(&mut self) {
        let Some(path) = &self.roster else { return };
        self.read_at = Some(std::time::Instant::now());
        if let Some(pids) = read_roster(path) {
            self.pids = pids;
        }
    }

    /// The node whose process created the publisher `publisher` of the
    /// inbox `inbox`, if it is one of ours.
    fn node_of(&mut self, inbox: &PubSub, publisher: u128) -> Option<u32> {
        if let Some(n) = self.known.get(&publisher) {
            return Some(*n);
        }
        let mut found = None;
        inbox.dynamic_config().list_publishers(|p| {
            if p.publisher_id.value() == publisher {
                found = p
                    .node_id
                    .pid::<Svc>()
                    .ok()
                    .map(|pid| i64::from(pid.value()));
                CallbackProgression::Stop
            } else {
                CallbackProgression::Continue
            }
        });
        let pid = found?;
        let mut node = self.pids.get(&pid).copied();
        let due = self.read_at.is_none_or(|t| t.elapsed() >= RELOAD_EVERY);
        if node.is_none() && self.roster.is_some() && due {
            self.reload();
            node = self.pids.get(&pid).copied();
        }
        let node = node?;
        self.known.insert(publisher, node);
        Some(node)
    }

    /// `f` as it came from the publisher `publisher` of `inbox`, whose
    /// process is the node (or coordinator) it was found to be, if any
    /// ([`Frame::as_sent_by`]).
    pub(super) fn stamp(&mut self, inbox: &PubSub, publisher: u128, f: Frame) -> Frame {
        f.as_sent_by(self.node_of(inbox, publisher))
    }
}

/// The process ids of a roster file (`node pid` lines, `c` for the
/// coordinator), or `None` if it cannot be read or a line does not read.
fn read_roster(path: &Path) -> Option<HashMap<i64, u32>> {
    use std::io::Read;
    let mut text = String::new();
    std::fs::File::open(path)
        .ok()?
        .take(MAX_ROSTER_BYTES)
        .read_to_string(&mut text)
        .ok()?;
    let mut pids = HashMap::new();
    for line in text.lines() {
        let (who, pid) = line.split_once(' ')?;
        let node = match who {
            "c" => COORDINATOR_ID,
            n => n.parse().ok()?,
        };
        pids.insert(pid.parse().ok()?, node);
    }
    Some(pids)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_roster_written_by_the_coordinator_reads_back_at_a_node_after_a_restart_too() {
        let dir = std::env::temp_dir().join(format!("sonarnet-roster-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("r.roster");
        let mut c = Senders::writing(path.clone(), 100);
        c.set(0, 200);
        c.set(1, 201);
        c.publish().unwrap();
        let n = Senders::from_roster(path.clone());
        assert_eq!(n.pids.get(&100), Some(&COORDINATOR_ID));
        assert_eq!(n.pids.get(&201), Some(&1));
        c.set(1, 301);
        c.publish().unwrap();
        let again = read_roster(&path).unwrap();
        assert_eq!(again.get(&301), Some(&1));
        assert_eq!(again.get(&201), None, "the old incarnation is gone");
        std::fs::write(&path, "0 12\nnot a line\n").unwrap();
        assert!(read_roster(&path).is_none());
        c.withdraw();
        assert!(!path.exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
