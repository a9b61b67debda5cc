//! Shared helpers for the integration tests.

use sonarnet::engine::RunRecord;
use sonarnet::run::{self, Clock, EngineKind, RunOptions, RunOutcome};
use sonarnet::scenario::Scenario;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A scenario shipped in `scenarios/`.
pub fn scenario(name: &str) -> PathBuf {
    root().join("scenarios").join(name)
}

/// A fresh temporary directory, removed on drop.
pub struct TempDir(pub PathBuf);

impl TempDir {
    pub fn new(tag: &str) -> TempDir {
        static N: AtomicUsize = AtomicUsize::new(0);
        let p = std::env::temp_dir().join(format!(
            "sonarnet-test-{tag}-{}-{}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).expect("create temp dir");
        TempDir(p)
    }
    pub fn path(&self) -> &Path {
        &self.0
    }
    pub fn write(&self, name: &str, text: &str) -> PathBuf {
        let p = self.0.join(name);
        std::fs::write(&p, text).expect("write temp file");
        p
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Run a loaded scenario in-process and write its outputs to `out`.
pub fn run_inprocess(sc: &Scenario, out: &Path) -> RunOutcome {
    let real = sc.realize(sc.seed);
    let (rec, res): (RunRecord, _) = run::run_inprocess(sc, &real, &mut |_, _| {});
    let opts = RunOptions {
        engine: EngineKind::Inprocess,
        clock: Clock::Logical,
        out_dir: out.to_path_buf(),
        command_line: vec!["test".into()],
        progress: false,
    };
    run::finish(sc, &real, rec, res.err(), &opts).expect("write outputs")
}

/// Run the `sonarnet` binary with a watchdog; kills it and panics with a
/// message if it takes longer than `limit`.
pub fn sonarnet(args: &[&str], limit: Duration) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_sonarnet"))
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn sonarnet");
    let start = Instant::now();
    loop {
        match child.try_wait().expect("wait sonarnet") {
            Some(_) => return child.wait_with_output().expect("collect output"),
            None if start.elapsed() > limit => {
                let _ = child.kill();
                let out = child.wait_with_output().expect("collect output");
                panic!(
                    "watchdog: `sonarnet {}` did not finish within {limit:?}\nstdout:\n{}\nstderr:\n{}",
                    args.join(" "),
                    String::from_utf8_lossy(&out.stdout),
                    String::from_utf8_lossy(&out.stderr)
                );
            }
            None => std::thread::sleep(Duration::from_millis(10)),
        }
    }
}

/// Read a results CSV as rows of strings (header dropped).
pub fn read_rows(path: &Path) -> Vec<Vec<String>> {
    let mut rdr = csv::Reader::from_path(path).expect("open csv");
    rdr.records()
        .map(|r| r.expect("csv row").iter().map(str::to_owned).collect())
        .collect()
}
