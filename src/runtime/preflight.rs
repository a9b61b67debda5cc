//! What a run on node processes needs from this machine (shared memory, file
//! descriptors, processes, memory), computed from the plan and checked
//! before anything is created or spawned (100000
//! receivers failed at node 2855 with a misleading hint, and
//! `iterations_per_sample = 1e8` left a 348 GB sparse file in `/dev/shm`).
//!
//! The figures are measured on this engine (Linux, iceoryx2 0.10): one
//! publisher's data segment holds [`SLOT_BYTES`] per frame of its
//! subscriber's buffer; the coordinator holds 9 descriptors per node
//! (measured 598 at N = 64: per node an inbox service, its dynamic segment,
//! the publisher's port tag, the two data segments and two connections of
//! the coordinator-node pair, and the socket and management segment of the
//! node's listener on the shared down service), a node about 7 per node of
//! the run; a node process takes up to
//! [`NODE_RSS_BYTES`] besides the shared memory it maps.

use crate::engine::layout::{NetworkLayout, network_layout};
use crate::model::error::KeyError;
use crate::protocol::RunPlan;

/// Bytes of shared memory per frame slot of one publisher (116 measured).
pub const SLOT_BYTES: u64 = 128;
/// Resident memory of one node process, shared memory aside: peak RSS
/// measured 5.8 to 6.3 MiB from 64 to 1024 nodes (`sonarnet bench --scale`,
/// 2026-12-03; it counts the program's shared pages in every process, so it
/// overstates), plus a margin. At 12 MiB, 2048 nodes were refused on a
/// 24 GiB machine they fit in.
pub const NODE_RSS_BYTES: u64 = 8 << 20;

/// What a processes run needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Needs {
    /// Node processes.
    pub nodes: u64,
    /// Frames one node inbox holds.
    pub inbox_frames: u64,
    /// Shared memory of all the run's services (bytes).
    pub shm_bytes: u64,
    /// Open files of the coordinator.
    pub coordinator_fds: u64,
    /// Open files of one node process.
    pub node_fds: u64,
    /// Memory of all node processes, shared memory included (bytes).
    pub memory_bytes: u64,
}

/// What this machine offers (`None`: unknown, not checked).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Machine {
    /// Free space of `/dev/shm` (bytes).
    pub shm_free: Option<u64>,
    /// The hard limit of open files (`RLIMIT_NOFILE`); the soft limit is
    /// raised to what a run needs, up to this.
    pub fd_hard_limit: Option<u64>,
    /// Processes this user may still start (`RLIMIT_NPROC` less those
    /// running, and at most `kernel.pid_max`).
    pub processes_left: Option<u64>,
    /// `MemAvailable` (bytes).
    pub memory_available: Option<u64>,
}

/// The needs of `plan` on node processes.
pub fn needs(plan: &RunPlan) -> Needs {
    needs_of(&network_layout(plan))
}

pub(crate) fn needs_of(l: &NetworkLayout) -> Needs {
    let n = l.configs.len() as u64;
    let inbox = l.inbox as u64;
    // Node i's inbox has one publisher per sender (the coordinator and its
    // in-neighbours); the coordinator's inbox one per node.
    let senders: u64 = l
        .neighbours
        .iter()
        .map(|nb| 1 + nb.len() as u64)
        .sum::<u64>()
        + n;
    let mut slots = senders.saturating_mul(inbox);
    if l.broadcast {
        slots = slots.saturating_add(n.saturating_mul(4).saturating_mul(n));
    }
    let shm_bytes = slots.saturating_mul(SLOT_BYTES);
    Needs {
        nodes: n,
        inbox_frames: inbox,
        shm_bytes,
        coordinator_fds: 9 * n + 64,
        node_fds: 7 * n + 64,
        memory_bytes: n.saturating_mul(NODE_RSS_BYTES).saturating_add(shm_bytes),
    }
}

fn gib(b: u64) -> String {
    format!("{:.2} GiB", b as f64 / (1u64 << 30) as f64)
}

/// Why a run with `needs` cannot run on `m`: the [`KeyError`] names the
/// scenario key most to blame and gives the reason with the numbers.
pub fn check(needs: &Needs, m: &Machine) -> Result<(), KeyError> {
    let n = needs.nodes;
    if let Some(left) = m.processes_left
        && n > left
    {
        return Err(KeyError::new(
            "geometry.receivers",
            format!("{n} receivers need {n} node processes; this user may start only {left} more"),
        ));
    }
    if let Some(hard) = m.fd_hard_limit {
        let need = needs.coordinator_fds.max(needs.node_fds);
        if need > hard {
            return Err(KeyError::new(
                "geometry.receivers",
                format!(
                    "{n} node processes need about {need} open files each (the coordinator 9 per node), \
                     above this machine's limit of {hard} (ulimit -Hn)"
                ),
            ));
        }
    }
    let shm_key = if needs.inbox_frames > 64 * n.max(1) {
        "algorithm.iterations_per_sample"
    } else {
        "geometry.receivers"
    };
    if let Some(free) = m.shm_free
        && needs.shm_bytes > free
    {
        return Err(KeyError::new(
            shm_key,
            format!(
                "the processes engine needs about {} of shared memory for {n} nodes \
                 (inboxes of {} frames: {} samples of plan frames in flight), /dev/shm has {} free; \
                 use --engine inprocess, or fewer iterations per sample or nodes",
                gib(needs.shm_bytes),
                needs.inbox_frames,
                crate::protocol::LOOKAHEAD,
                gib(free)
            ),
        ));
    }
    if let Some(avail) = m.memory_available
        && needs.memory_bytes > avail
    {
        return Err(KeyError::new(
            shm_key,
            format!(
                "{n} node processes need about {} of memory (shared memory included), {} is available",
                gib(needs.memory_bytes),
                gib(avail)
            ),
        ));
    }
    Ok(())
}

/// This machine, read now.
pub fn machine() -> Machine {
    Machine {
        shm_free: shm_free(),
        fd_hard_limit: rlimit(libc::RLIMIT_NOFILE).map(|(_, hard)| hard),
        processes_left: processes_left(),
        memory_available: meminfo("MemAvailable:"),
    }
}

/// Raise the soft limit of open files to `need` (at most the hard limit),
/// so that the coordinator and the nodes it spawns (which inherit it) can
/// open every service of a large run.
pub fn raise_fd_limit(need: u64) {
    let Some((soft, hard)) = rlimit(libc::RLIMIT_NOFILE) else {
        return;
    };
    if soft >= need {
        return;
    }
    let lim = libc::rlimit {
        rlim_cur: need.min(hard),
        rlim_max: hard,
    };
    // SAFETY: setrlimit with a valid struct; failure leaves the limit as it was.
    unsafe { libc::setrlimit(libc::RLIMIT_NOFILE, &lim) };
}

fn rlimit(res: libc::__rlimit_resource_t) -> Option<(u64, u64)> {
    let mut r = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit writes into the struct we own.
    if unsafe { libc::getrlimit(res, &mut r) } != 0 {
        return None;
    }
    // rlim_t is u64 on Linux.
    let v = |x: libc::rlim_t| -> u64 {
        if x == libc::RLIM_INFINITY {
            u64::MAX
        } else {
            x
        }
    };
    Some((v(r.rlim_cur), v(r.rlim_max)))
}

fn shm_free() -> Option<u64> {
    let path = std::ffi::CString::new("/dev/shm").ok()?;
    // SAFETY: statvfs fills the zeroed struct we own from a valid C string.
    let mut s: libc::statvfs = unsafe { std::mem::zeroed() };
    if unsafe { libc::statvfs(path.as_ptr(), &mut s) } != 0 {
        return None;
    }
    Some((s.f_bavail as u64).saturating_mul(s.f_frsize as u64))
}

fn meminfo(key: &str) -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kib: u64 = text
        .lines()
        .find_map(|l| l.strip_prefix(key))?
        .split_whitespace()
        .next()?
        .parse()
        .ok()?;
    Some(kib.saturating_mul(1024))
}

fn processes_left() -> Option<u64> {
    let pid_max: Option<u64> = std::fs::read_to_string("/proc/sys/kernel/pid_max")
        .ok()
        .and_then(|s| s.trim().parse().ok());
    // SAFETY: getuid has no failure mode.
    let uid = unsafe { libc::getuid() };
    let mut running = 0u64;
    let mut total = 0u64;
    for e in std::fs::read_dir("/proc").ok()?.flatten() {
        let Some(pid) = e.file_name().to_str().and_then(|s| s.parse::<u32>().ok()) else {
            continue;
        };
        total += 1;
        let owner = std::fs::read_to_string(format!("/proc/{pid}/status"))
            .ok()
            .and_then(|s| {
                s.lines()
                    .find_map(|l| l.strip_prefix("Uid:"))
                    .and_then(|v| v.split_whitespace().next()?.parse::<u32>().ok())
            });
        if owner == Some(uid) {
            running += 1;
        }
    }
    let by_user = rlimit(libc::RLIMIT_NPROC).map(|(soft, _)| soft.saturating_sub(running));
    let by_pid = pid_max.map(|p| p.saturating_sub(total));
    match (by_user, by_pid) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::Clock;

    fn spiral() -> crate::scenario::Scenario {
        let p = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/scenarios/mourya2017-spiral.toml"
        );
        crate::scenario::Scenario::from_file(std::path::Path::new(p)).unwrap()
    }

    fn plenty() -> Machine {
        Machine {
            shm_free: Some(1 << 40),
            fd_hard_limit: Some(1 << 20),
            processes_left: Some(1 << 20),
            memory_available: Some(1 << 40),
        }
    }

    #[test]
    fn the_spiral_needs_24_publisher_segments_of_its_inbox_size() {
        let plan = RunPlan::new(&spiral(), Clock::Logical).unwrap();
        let n = needs(&plan);
        // 6 node inboxes with 1 + degree senders (6 + 12) and 6 senders to
        // the coordinator; 3 samples of 9 plan frames (50 steps, six to a
        // frame) + 2 transmitters + 4,
        // plus 16.
        assert_eq!(n.inbox_frames, 3 * (50_u64.div_ceil(6) + 2 + 4) + 16);
        assert_eq!(n.shm_bytes, 24 * n.inbox_frames * SLOT_BYTES);
        assert!(check(&n, &plenty()).is_ok());
    }

    #[test]
    fn a_run_larger_than_free_shared_memory_is_refused_naming_iterations_per_sample() {
        let sc = spiral().with_iterations_per_sample(1_000_000).unwrap();
        let n = needs(&RunPlan::new(&sc, Clock::Logical).unwrap());
        let m = Machine {
            shm_free: Some(1 << 30),
            ..plenty()
        };
        let KeyError { key, reason } = check(&n, &m).unwrap_err();
        assert_eq!(key, "algorithm.iterations_per_sample");
        assert!(reason.contains("/dev/shm has 1.00 GiB free"), "{reason}");
    }

    #[test]
    fn too_few_processes_or_files_are_refused_naming_the_receivers() {
        let n = needs(&RunPlan::new(&spiral(), Clock::Logical).unwrap());
        for m in [
            Machine {
                processes_left: Some(5),
                ..plenty()
            },
            Machine {
                fd_hard_limit: Some(100),
                ..plenty()
            },
        ] {
            let KeyError { key, reason } = check(&n, &m).unwrap_err();
            assert_eq!(key, "geometry.receivers", "{reason}");
        }
    }

    #[test]
    fn this_machine_is_read() {
        let m = machine();
        assert!(m.shm_free.is_some() && m.fd_hard_limit.is_some());
        assert!(m.processes_left.is_some_and(|p| p > 0));
        assert!(m.memory_available.is_some_and(|b| b > 0));
    }
}
