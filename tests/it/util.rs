//! Shared helpers for the integration tests.

use sonarnet::pipeline::{Outcome, RunOptions};
use sonarnet::protocol::{Clock, EngineError, RunPlan, RunRecord};
use sonarnet::scenario::{Realization, Scenario};
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
pub fn run_inprocess<const D: usize>(sc: &Scenario<D>, out: &Path) -> Outcome<D> {
    let opts = RunOptions {
        command_line: vec!["test".into()],
        ..RunOptions::inprocess()
            .with_out_dir(out)
            .with_clock(sonarnet::pipeline::default_clock(sc))
    };
    sc.run_and_write(&opts).expect("write outputs")
}

/// The engine record of `sc` run in-process with logical clocks on `real`.
pub fn record(sc: &Scenario, real: &Realization) -> (RunRecord, Result<(), EngineError>) {
    let plan = RunPlan::new(sc, Clock::Logical).expect("plan");
    let out = sonarnet::engine::run_inprocess(&plan, real.feed(), &mut |_, _| {});
    (out.record, out.error.map_or(Ok(()), Err))
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

/// `sonarnet run FILE --out OUT ARGS...` with the watchdog of [`sonarnet`].
pub fn run_file(file: &Path, out: &Path, args: &[&str], limit: Duration) -> Output {
    let mut all = vec![
        "run",
        file.to_str().expect("utf-8 path"),
        "--out",
        out.to_str().expect("utf-8 path"),
    ];
    all.extend_from_slice(args);
    sonarnet(&all, limit)
}

/// A CSV file's header.
pub fn header(path: &Path) -> Vec<String> {
    let mut rdr = csv::Reader::from_path(path).expect("open csv");
    rdr.headers()
        .expect("header")
        .iter()
        .map(str::to_owned)
        .collect()
}

/// Read a results CSV as rows of strings (header dropped).
pub fn read_rows(path: &Path) -> Vec<Vec<String>> {
    let mut rdr = csv::Reader::from_path(path).expect("open csv");
    rdr.records()
        .map(|r| r.expect("csv row").iter().map(str::to_owned).collect())
        .collect()
}

/// A headless Chromium found on this machine, or why there is none.
///
/// Looks at `$SONARNET_CHROMIUM`, then `chromium`, `chromium-browser` and
/// `google-chrome` on `PATH`, and checks that `--version` runs.
pub fn find_chromium() -> Result<PathBuf, String> {
    let mut candidates: Vec<PathBuf> = Vec::new();
    if let Some(p) = std::env::var_os("SONARNET_CHROMIUM") {
        candidates.push(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH").unwrap_or_default();
    for name in ["chromium", "chromium-browser", "google-chrome"] {
        for dir in std::env::split_paths(&path) {
            let p = dir.join(name);
            if p.is_file() {
                candidates.push(p);
            }
        }
    }
    if candidates.is_empty() {
        return Err("no chromium, chromium-browser or google-chrome on PATH".into());
    }
    let mut why = Vec::new();
    for c in candidates {
        match Command::new(&c).arg("--version").output() {
            Ok(o) if o.status.success() => return Ok(c),
            Ok(o) => why.push(format!(
                "{} --version failed: {}",
                c.display(),
                String::from_utf8_lossy(&o.stderr).trim()
            )),
            Err(e) => why.push(format!("{}: {e}", c.display())),
        }
    }
    Err(why.join("; "))
}

/// Chromium for a test, or `None` after printing a SKIPPED line. When
/// `SONARNET_REQUIRE_CHROMIUM=1` (set by .ci/run after installing it), a
/// missing browser fails the test instead.
pub fn chromium_or_skip(test: &str) -> Option<PathBuf> {
    match find_chromium() {
        Ok(p) => Some(p),
        Err(reason) => {
            if std::env::var("SONARNET_REQUIRE_CHROMIUM").as_deref() == Ok("1") {
                panic!("{test}: chromium is required (SONARNET_REQUIRE_CHROMIUM=1) but {reason}");
            }
            // Written to the process' stderr directly, past the test
            // harness' output capture, so the line shows in every run.
            use std::io::Write;
            let _ = writeln!(
                std::io::stderr(),
                "SKIPPED: chromium not installed ({reason}) [{test}]"
            );
            None
        }
    }
}

/// Run headless Chromium on `url` with `extra` flags and a fresh profile;
/// kills it after `limit`. Returns (stdout, stderr).
pub fn chromium_run(bin: &Path, extra: &[String], url: &str, limit: Duration) -> (String, String) {
    let profile = TempDir::new("chromium-profile");
    let mut args: Vec<String> = [
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--hide-scrollbars",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    args.push(format!("--user-data-dir={}", profile.path().display()));
    args.extend(extra.iter().cloned());
    args.push(url.to_string());
    // Output goes to files: a pipe would fill up (the dumped DOM is large)
    // and block chromium before it exits.
    let out_path = profile.path().join("stdout.txt");
    let err_path = profile.path().join("stderr.txt");
    let mut child = Command::new(bin)
        .args(&args)
        .stdin(std::process::Stdio::null())
        .stdout(std::fs::File::create(&out_path).expect("create stdout file"))
        .stderr(std::fs::File::create(&err_path).expect("create stderr file"))
        .spawn()
        .expect("spawn chromium");
    let start = Instant::now();
    loop {
        match child.try_wait().expect("wait chromium") {
            Some(_) => break,
            None if start.elapsed() > limit => {
                let _ = child.kill();
                let _ = child.wait();
                panic!(
                    "watchdog: chromium did not finish within {limit:?} on {url}\nstderr:\n{}",
                    std::fs::read_to_string(&err_path).unwrap_or_default()
                );
            }
            None => std::thread::sleep(Duration::from_millis(20)),
        }
    }
    let read =
        |p: &Path| String::from_utf8_lossy(&std::fs::read(p).unwrap_or_default()).into_owned();
    (read(&out_path), read(&err_path))
}

/// A `file://` URL for a local path.
pub fn file_url(p: &Path) -> String {
    let abs = p.canonicalize().expect("canonicalize page path");
    format!("file://{}", abs.display())
}

/// Load `page` with `?selftest` in Chromium and return the JSON the page's
/// self-test wrote into `<pre id="selftest">`.
pub fn page_selftest(bin: &Path, page: &Path) -> Result<serde_json::Value, String> {
    let url = format!("{}?selftest", file_url(page));
    let (dom, stderr) = chromium_run(
        bin,
        &["--dump-dom".to_string()],
        &url,
        Duration::from_secs(90),
    );
    let start = dom.find("id=\"selftest\"").ok_or_else(|| {
        format!("no selftest element in the dumped DOM; chromium stderr:\n{stderr}")
    })?;
    let rest = &dom[start..];
    let open = rest.find('>').ok_or("malformed selftest element")? + 1;
    let close = rest.find("</pre>").ok_or("unterminated selftest element")?;
    let text = rest[open..close]
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&");
    if text.trim().is_empty() {
        return Err(format!(
            "the page's self-test did not run (empty result); chromium stderr:\n{stderr}"
        ));
    }
    serde_json::from_str(&text).map_err(|e| format!("selftest JSON `{text}`: {e}"))
}

/// Check a self-test result: no errors, the expected number of plots, and
/// every plot has a non-zero rendered size and drawn content.
pub fn check_selftest(v: &serde_json::Value) -> Result<(), String> {
    let errors = v["errors"].as_array().ok_or("no `errors` in selftest")?;
    if !errors.is_empty() {
        return Err(format!("the page raised errors: {errors:?}"));
    }
    let plots = v["plots"].as_array().ok_or("no `plots` in selftest")?;
    let expected = v["expected"].as_i64().unwrap_or(-1);
    if expected < 1 || plots.len() as i64 != expected {
        return Err(format!(
            "expected {expected} plot elements, found {}",
            plots.len()
        ));
    }
    for p in plots {
        let (w, h) = (
            p["width"].as_f64().unwrap_or(0.0),
            p["height"].as_f64().unwrap_or(0.0),
        );
        let n = p["elements"].as_u64().unwrap_or(0);
        if w < 1.0 || h < 1.0 {
            return Err(format!("plot {} has zero size ({w} x {h})", p["id"]));
        }
        if n < 10 {
            return Err(format!(
                "plot {} draws almost nothing ({n} elements)",
                p["id"]
            ));
        }
    }
    Ok(())
}

/// Screenshot `page` in Chromium (1400 x 3000) into `out`.
pub fn screenshot(bin: &Path, page: &Path, out: &Path) {
    let (_, stderr) = chromium_run(
        bin,
        &[
            format!("--screenshot={}", out.display()),
            "--window-size=1400,3000".to_string(),
        ],
        &file_url(page),
        Duration::from_secs(90),
    );
    assert!(
        out.is_file(),
        "chromium wrote no screenshot; stderr:\n{stderr}"
    );
}

/// Whether a PNG is blank: fewer than 0.5% of its pixels differ from its most
/// common colour, or it has fewer than 8 distinct colours.
pub fn png_is_blank(path: &Path) -> bool {
    let f = std::fs::File::open(path).expect("open png");
    let mut reader = png::Decoder::new(std::io::BufReader::new(f))
        .read_info()
        .expect("png header");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("png frame");
    let bpp = info.color_type.samples()
        * if info.bit_depth == png::BitDepth::Sixteen {
            2
        } else {
            1
        };
    let pixels = &buf[..info.buffer_size()];
    let mut counts: std::collections::HashMap<&[u8], usize> = std::collections::HashMap::new();
    for px in pixels.chunks_exact(bpp) {
        *counts.entry(px).or_default() += 1;
    }
    let total = pixels.len() / bpp;
    let top = counts.values().copied().max().unwrap_or(0);
    let other = total - top;
    counts.len() < 8 || (other as f64) < 0.005 * total as f64
}

/// Start the `sonarnet` binary (output piped); pair with [`wait_watchdog`].
pub fn spawn_sonarnet(args: &[&str]) -> std::process::Child {
    Command::new(env!("CARGO_BIN_EXE_sonarnet"))
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn sonarnet")
}

/// Wait for a child; kill it and panic with its output after `limit`.
pub fn wait_watchdog(mut child: std::process::Child, what: &str, limit: Duration) -> Output {
    let start = Instant::now();
    loop {
        match child.try_wait().expect("wait") {
            Some(_) => return child.wait_with_output().expect("collect output"),
            None if start.elapsed() > limit => {
                let _ = child.kill();
                let out = child.wait_with_output().expect("collect output");
                panic!(
                    "watchdog: {what} did not finish within {limit:?}\nstdout:\n{}\nstderr:\n{}",
                    String::from_utf8_lossy(&out.stdout),
                    String::from_utf8_lossy(&out.stderr)
                );
            }
            None => std::thread::sleep(Duration::from_millis(10)),
        }
    }
}

/// Pids of live processes whose parent is `parent`.
pub fn children_of(parent: u32) -> Vec<u32> {
    let mut out = Vec::new();
    let Ok(dir) = std::fs::read_dir("/proc") else {
        return out;
    };
    for e in dir.flatten() {
        let Some(pid) = e.file_name().to_str().and_then(|s| s.parse::<u32>().ok()) else {
            continue;
        };
        if let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) {
            // pid (comm) state ppid ...
            if let Some(rest) = stat.rsplit_once(')').map(|x| x.1) {
                let f: Vec<&str> = rest.split_whitespace().collect();
                if f.len() > 1 && f[0] != "Z" && f[1].parse::<u32>().ok() == Some(parent) {
                    out.push(pid);
                }
            }
        }
    }
    out
}

/// Processes whose command line mentions `needle` (e.g. a run id).
pub fn processes_mentioning(needle: &str) -> Vec<u32> {
    let mut out = Vec::new();
    let me = std::process::id();
    let Ok(dir) = std::fs::read_dir("/proc") else {
        return out;
    };
    for e in dir.flatten() {
        let Some(pid) = e.file_name().to_str().and_then(|s| s.parse::<u32>().ok()) else {
            continue;
        };
        if pid == me {
            continue;
        }
        if let Ok(cmd) = std::fs::read(format!("/proc/{pid}/cmdline"))
            && String::from_utf8_lossy(&cmd).contains(needle)
        {
            out.push(pid);
        }
    }
    out
}

/// The run id a processes run recorded in its `run.json`.
pub fn run_id_of(dir: &Path) -> String {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("run.json")).expect("run.json"))
            .expect("run.json parses");
    v["run_id"].as_str().expect("run_id recorded").to_string()
}

/// Assert that a run left no process and no IPC resource behind.
pub fn assert_nothing_left(run_id: &str) {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        let procs = processes_mentioning(run_id);
        let files = sonarnet::transport::run_resources(run_id);
        if procs.is_empty() && files.is_empty() {
            return;
        }
        if Instant::now() > deadline {
            panic!("run {run_id} left processes {procs:?} and files {files:?}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Read `metrics.json`.
pub fn metrics(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("metrics.json")).expect("metrics.json"))
        .expect("metrics.json parses")
}

/// Wait until process `pid` catches SIGINT (its handler is installed, read
/// from `SigCgt` in `/proc/PID/status`): from then on a signal is an orderly
/// interrupt, not the default death. Panics after `limit`.
pub fn wait_for_sigint_handler(pid: u32, limit: Duration) {
    let start = Instant::now();
    loop {
        let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
        let caught = status
            .lines()
            .find_map(|l| l.strip_prefix("SigCgt:"))
            .and_then(|m| u64::from_str_radix(m.trim(), 16).ok())
            .unwrap_or(0);
        if caught & (1 << (libc::SIGINT - 1)) != 0 {
            return;
        }
        assert!(
            start.elapsed() < limit,
            "watchdog: process {pid} did not install its SIGINT handler within {limit:?}"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Held by tests whose results depend on the wall clock (realtime runs) and
/// by tests that keep every core busy (parallel Monte Carlo), so that the
/// first never run starved by the second on a 2-core machine.
pub fn cpu_exclusive() -> std::sync::MutexGuard<'static, ()> {
    static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
    LOCK.lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// The spiral scenario in 3-D: every point with a depth, the target on a
/// descending helix, the elevation with its own noise.
pub fn spiral_3d() -> String {
    let text =
        std::fs::read_to_string(crate::util::scenario("mourya2017-spiral.toml")).expect("read");
    let mut out = String::new();
    let mut depth = 0;
    for line in text.lines() {
        let l = if line.starts_with("transmitters = ") {
            "transmitters = [[0.0, 0.0, -10.0], [2000.0, 2000.0, -10.0]]".to_string()
        } else if line.starts_with("  [") && line.ends_with("],") {
            depth += 1;
            line.replace("],", &format!(", {}.0],", -50 * depth))
        } else if line.starts_with("motion = ") {
            line.replace(
                "center = [500.0, 500.0]",
                "center = [500.0, 500.0, -100.0], dz = -1.0",
            )
        } else if line.starts_with("init_u = ") {
            "init_u = [0.0, 0.0, 0.0, 0.0]".to_string()
        } else if line.starts_with("doa_noise = ") {
            format!("{line}\nelevation_noise = {{ model = \"gaussian\", sigma = 0.2 }}")
        } else {
            line.to_string()
        };
        out.push_str(&l);
        out.push('\n');
    }
    assert_eq!(depth, 6, "the six receivers got a depth");
    out
}

/// Run `f` on its own thread; panic if it takes longer than `limit`.
pub fn with_watchdog<T: Send + 'static>(
    what: &str,
    limit: std::time::Duration,
    f: impl FnOnce() -> T + Send + 'static,
) -> T {
    let (send, recv) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = send.send(f());
    });
    recv.recv_timeout(limit)
        .unwrap_or_else(|_| panic!("watchdog: {what} did not finish within {limit:?}"))
}
