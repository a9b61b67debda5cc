//! Run namespaces in shared memory: every run's iceoryx2 resources carry a prefix made
//! from its run id, so a crashed run's files can be found and removed
//! (`cleanup_stale_resources`) while live runs are kept.

use super::CallbackProgression;
use super::FileName;
use super::LogLevel;
use super::Node;
use super::SemanticString;
use super::set_log_level_from_env_or;
use crate::transport::RootProblem;
use crate::transport::TransportError;
use crate::transport::iox::Svc;
use iceoryx2::config::Config;
use iceoryx2::node::NodeState;
use std::path::Path;
use std::path::PathBuf;
use std::sync::Once;

/// Directory where POSIX shared memory objects appear (Linux).
pub(super) const SHM_DIR: &str = "/dev/shm";
/// First part of every run prefix; followed by 16 hex digits and `_`.
pub(super) const PREFIX_HEAD: &str = "iox2_sn";
pub(super) const PREFIX_LEN: usize = PREFIX_HEAD.len() + 16 + 1;
pub(super) const GLOBAL_MGMT_SUFFIX: &str = ".global_mgmt";
pub(super) const MONITOR_SUFFIX: &str = ".node_monitor";

pub(super) fn init_logging() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| set_log_level_from_env_or(LogLevel::Error));
}

pub(super) fn fnv1a64(s: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in s.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// The iceoryx2 file prefix of a run: `iox2_sn<16 hex digits of FNV-1a(run_id)>_`.
pub fn resource_prefix(run_id: &str) -> String {
    format!("{PREFIX_HEAD}{:016x}_", fnv1a64(run_id))
}

/// If `name` starts with a sonarnet run prefix, that prefix.
pub(super) fn parse_prefix(name: &str) -> Option<&str> {
    let p = name.get(..PREFIX_LEN)?;
    let hex = &p[PREFIX_HEAD.len()..PREFIX_LEN - 1];
    (p.starts_with(PREFIX_HEAD) && p.ends_with('_') && hex.bytes().all(|b| b.is_ascii_hexdigit()))
        .then_some(p)
}

/// iceoryx2's root directory for sonarnet (static configs, node details, monitor
/// locks, event sockets): on tmpfs next to the shared memory, because creating the
/// ~40 small files per endpoint on a disk file system (the default `/tmp/iceoryx2`)
/// made a 256-node run take tens of seconds to set up instead of about one. Falls
/// back to the iceoryx2 default where `/dev/shm` does not exist.
///
/// One per user, `/dev/shm/sonarnet-iceoryx2-<uid>/`, mode 0700: a shared
/// directory would belong to whoever created it first, so another user's
/// runs would fail, and its owner could reach every other user's runs.
pub(super) fn root_dir() -> String {
    // SAFETY: getuid has no failure mode.
    let uid = unsafe { libc::getuid() };
    format!("{SHM_DIR}/sonarnet-iceoryx2-{uid}/")
}

/// Whether a directory with this owner and mode may be this user's root.
pub(super) fn check_root_owner(owner: u32, mode: u32, me: u32) -> Result<(), RootProblem> {
    if owner != me {
        return Err(RootProblem::Foreign { owner, me });
    }
    if mode & 0o077 != 0 {
        return Err(RootProblem::OpenMode(mode & 0o7777));
    }
    Ok(())
}

/// Create this user's root directory (0700) or check the one that exists.
fn ensure_root(dir: &str) -> Result<(), TransportError> {
    use std::os::unix::fs::{DirBuilderExt, MetadataExt};
    let path = Path::new(dir);
    let unsafe_root = |problem: RootProblem| TransportError::UnsafeRoot {
        path: path.to_path_buf(),
        problem,
    };
    match std::fs::DirBuilder::new().mode(0o700).create(path) {
        Ok(()) => return Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
        Err(e) => return Err(unsafe_root(RootProblem::Create(e.kind()))),
    }
    let meta =
        std::fs::symlink_metadata(path).map_err(|e| unsafe_root(RootProblem::Stat(e.kind())))?;
    if !meta.file_type().is_dir() {
        return Err(unsafe_root(RootProblem::NotADirectory));
    }
    // SAFETY: getuid has no failure mode.
    let me = unsafe { libc::getuid() };
    check_root_owner(meta.uid(), meta.mode(), me).map_err(unsafe_root)
}

/// The iceoryx2 configuration shared by all sonarnet processes (prefix not set).
pub(super) fn base_config() -> Result<Config, TransportError> {
    let mut cfg = Config::default();
    if Path::new(SHM_DIR).is_dir() {
        let dir = root_dir();
        ensure_root(&dir)?;
        let root = iceoryx2::prelude::Path::new(dir.as_bytes())
            .map_err(|e| TransportError::ipc(format!("using root {dir}"), e))?;
        cfg.global.set_root_path(&root);
    }
    Ok(cfg)
}

pub(super) fn config_for_prefix(prefix: &str) -> Result<Config, TransportError> {
    let mut cfg = base_config()?;
    cfg.global.prefix = FileName::new(prefix.as_bytes())
        .map_err(|e| TransportError::ipc(format!("using prefix {prefix:?}"), e))?;
    // Dead-node scans on every node creation/drop and service open cost O(N) each,
    // O(N^2) per run; dead nodes are handled by `cleanup_stale_resources` instead.
    cfg.global.node.cleanup_dead_nodes_on_creation = false;
    cfg.global.node.cleanup_dead_nodes_on_destruction = false;
    cfg.global.service.cleanup_dead_nodes_on_open = false;
    Ok(cfg)
}

pub(super) fn iox_path_to_std(p: &iceoryx2::prelude::Path) -> PathBuf {
    PathBuf::from(String::from_utf8_lossy(p.as_bytes()).into_owned())
}

/// Removes the run's global management segment (in `/dev/shm`). iceoryx2 only uses
/// it while creating a node, to draw a per-machine node counter; node ids stay unique
/// without it (they also contain the pid and the creation time in nanoseconds).
pub(super) fn remove_global_mgmt_segment(cfg: &Config) {
    // SAFETY: the function requires that no other process uses the segment's domain.
    // The domain is this run's prefix, whose processes use the segment only inside
    // `NodeBuilder::create`, which opens-or-creates it in a retry loop: removing it
    // concurrently at worst restarts the node counter, which cannot make node ids
    // collide (see above). The segment is removed by every process right after its
    // own node exists, so the last one to be created is also removed.
    let _ = unsafe { iceoryx2::testing::remove_global_mgmt_segment::<Svc>(cfg) };
}

/// Removes global management segments with `prefix` by listing `/dev/shm` (used by
/// the stale-resource cleanup, which does not know the exact name).
pub(super) fn remove_global_mgmt_segments_by_scan(prefix: &str) -> usize {
    let Ok(dir) = std::fs::read_dir(SHM_DIR) else {
        return 0;
    };
    let mut removed = 0;
    for entry in dir.flatten() {
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if name.starts_with(prefix)
            && name.ends_with(GLOBAL_MGMT_SUFFIX)
            && std::fs::remove_file(entry.path()).is_ok()
        {
            removed += 1;
        }
    }
    removed
}

pub(super) fn collect_files_with_prefix(dir: &Path, prefix: &str, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in rd.flatten() {
        let path = entry.path();
        let is_dir = entry.file_type().map(|t| t.is_dir()).unwrap_or(false);
        if entry.file_name().to_string_lossy().starts_with(prefix) {
            out.push(path.clone());
        }
        if is_dir {
            collect_files_with_prefix(&path, prefix, out);
        }
    }
}

/// All files and shared-memory objects that currently exist for run `run_id` (in
/// `/dev/shm`, including the iceoryx2 root below it). Empty after a clean run
/// or after [`cleanup_stale_resources`] removed a crashed one.
pub fn run_resources(run_id: &str) -> Vec<PathBuf> {
    let prefix = resource_prefix(run_id);
    let mut out = Vec::new();
    collect_files_with_prefix(Path::new(SHM_DIR), &prefix, &mut out);
    if let Ok(cfg) = base_config() {
        let root = iox_path_to_std(cfg.global.root_path());
        collect_files_with_prefix(&root, &prefix, &mut out);
    }
    out.sort();
    out.dedup();
    out
}

/// What [`cleanup_stale_resources`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CleanupReport {
    /// sonarnet run namespaces found on the machine.
    pub runs_scanned: usize,
    /// Runs that still have at least one live process (left alone).
    pub runs_alive: usize,
    /// Dead iceoryx2 nodes whose resources were removed.
    pub dead_nodes_removed: usize,
    /// Dead or undefined nodes that could not be cleaned (permissions, concurrent cleaner).
    pub cleanup_failures: usize,
    /// Orphaned global management segments and rosters of node processes
    /// removed.
    pub segments_removed: usize,
}

/// Removes the IPC resources of sonarnet runs whose processes died without cleaning
/// up (e.g. SIGKILL). Runs with a live process are left untouched. Call it when the
/// coordinator starts; it is cheap when there is nothing to do.
///
/// Uses iceoryx2's dead-node detection: `Node::list` reports nodes whose monitor lock
/// is no longer held as dead, and `try_remove_stale_resources` removes them from
/// their services (removing services nobody holds any more).
pub fn cleanup_stale_resources() -> Result<CleanupReport, TransportError> {
    init_logging();
    let base = base_config()?;
    let mut prefixes: Vec<String> = Vec::new();
    let mut note = |name: &str, suffix: &str| {
        if name.ends_with(suffix)
            && let Some(p) = parse_prefix(name)
            && !prefixes.iter().any(|q| q == p)
        {
            prefixes.push(p.to_string());
        }
    };
    if let Ok(rd) = std::fs::read_dir(iox_path_to_std(&base.global.node_dir())) {
        for e in rd.flatten() {
            note(&e.file_name().to_string_lossy(), MONITOR_SUFFIX);
        }
    }
    if let Ok(rd) = std::fs::read_dir(SHM_DIR) {
        for e in rd.flatten() {
            note(&e.file_name().to_string_lossy(), GLOBAL_MGMT_SUFFIX);
        }
    }
    if let Ok(rd) = std::fs::read_dir(iox_path_to_std(base.global.root_path())) {
        for e in rd.flatten() {
            note(
                &e.file_name().to_string_lossy(),
                super::senders::ROSTER_SUFFIX,
            );
        }
    }

    let mut report = CleanupReport::default();
    for prefix in &prefixes {
        cleanup_prefix(prefix, &mut report)?;
    }
    Ok(report)
}

/// Removes what the dead processes of run `run_id` left (its coordinator
/// SIGKILLed, say), and the run's global management segment once no process
/// of it is alive. A node program calls it as it leaves a run whose
/// coordinator is gone, after dropping its own transport, so the last node to
/// leave removes the rest of the run (a SIGKILLed
/// coordinator used to leave 80 files until the next run's
/// [`cleanup_stale_resources`]). Other runs are not looked at.
pub fn cleanup_run(run_id: &str) -> Result<CleanupReport, TransportError> {
    init_logging();
    let mut report = CleanupReport::default();
    cleanup_prefix(&resource_prefix(run_id), &mut report)?;
    Ok(report)
}

/// One run namespace of [`cleanup_stale_resources`] and [`cleanup_run`].
fn cleanup_prefix(prefix: &str, report: &mut CleanupReport) -> Result<(), TransportError> {
    let cfg = config_for_prefix(prefix)?;
    report.runs_scanned += 1;
    let mut alive = 0usize;
    Node::<Svc>::list(&cfg, |state| {
        match state {
            NodeState::Alive(_) => alive += 1,
            NodeState::Dead(view) => match view.try_remove_stale_resources() {
                Ok(()) => report.dead_nodes_removed += 1,
                Err(_) => report.cleanup_failures += 1,
            },
            NodeState::Inaccessible(_) => alive += 1,
            NodeState::Undefined(_) => report.cleanup_failures += 1,
        }
        CallbackProgression::Continue
    })
    .map_err(|e| TransportError::ipc(format!("listing iceoryx2 nodes of {prefix}"), e))?;
    if alive == 0 {
        report.segments_removed += remove_global_mgmt_segments_by_scan(prefix);
        if let Ok(roster) = super::senders::roster_path(prefix)
            && std::fs::remove_file(roster).is_ok()
        {
            report.segments_removed += 1;
        }
    } else {
        report.runs_alive += 1;
    }
    Ok(())
}

#[cfg(test)]
mod root_tests {
    use super::*;

    #[test]
    fn the_root_is_per_user_and_refused_when_foreign_or_open() {
        // SAFETY: getuid has no failure mode.
        let me = unsafe { libc::getuid() };
        assert!(root_dir().ends_with(&format!("sonarnet-iceoryx2-{me}/")));
        assert!(check_root_owner(me, 0o40700, me).is_ok());
        let foreign = check_root_owner(me + 1, 0o40700, me).unwrap_err();
        assert!(
            foreign
                .to_string()
                .contains(&format!("belongs to uid {}", me + 1)),
            "{foreign}"
        );
        let open = check_root_owner(me, 0o40750, me).unwrap_err();
        assert!(open.to_string().contains("mode 750"), "{open}");
    }
}
