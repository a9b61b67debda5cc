//! The multi-process engine: real `sonarnet-node` processes over iceoryx2.
//! Every wait has a watchdog; every test checks that the run left no process
//! and no IPC resource behind.

use crate::util::{
    TempDir, assert_nothing_left, children_of, cpu_exclusive, metrics, read_rows, run_id_of,
    scenario, spawn_sonarnet, wait_watchdog,
};
use std::process::Command;
use std::time::{Duration, Instant};

const LIMIT: Duration = Duration::from_secs(300);

fn run(args: &[&str]) -> std::process::Output {
    wait_watchdog(
        spawn_sonarnet(args),
        &format!("sonarnet {}", args.join(" ")),
        LIMIT,
    )
}

fn nodes_csv_equal(a: &std::path::Path, b: &std::path::Path) {
    let ra = read_rows(&a.join("nodes.csv"));
    let rb = read_rows(&b.join("nodes.csv"));
    assert_eq!(ra.len(), rb.len(), "nodes.csv lengths differ");
    for (x, y) in ra.iter().zip(&rb) {
        assert_eq!(x[..2], y[..2]);
        for c in 2..5 {
            let (p, q): (f64, f64) = (x[c].parse().unwrap(), y[c].parse().unwrap());
            assert!(
                (p - q).abs() <= 1e-9,
                "sample {} node {}: column {c} differs: {p} vs {q}",
                x[0],
                x[1]
            );
        }
    }
}

fn equivalence(file: &str, mode: &str, samples: &str) {
    equivalence_at(&scenario(file), mode, samples, &[], &[]);
}

/// `equivalence` for the scenario file `sc`, with extra `sonarnet run` arguments
/// for both engines (`extra`) and for the processes run only (`processes_only`);
/// returns run.json of the processes run.
fn equivalence_at(
    sc: &std::path::Path,
    mode: &str,
    samples: &str,
    extra: &[&str],
    processes_only: &[&str],
) -> serde_json::Value {
    let tmp = TempDir::new("equiv");
    let file = sc.display();
    let (p, i) = (tmp.path().join("p"), tmp.path().join("i"));
    for (engine, out) in [("processes", &p), ("inprocess", &i)] {
        let mut args = vec![
            "run",
            sc.to_str().unwrap(),
            "--engine",
            engine,
            "--mode",
            mode,
            "--samples",
            samples,
            "--seed",
            "5",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        if engine == "processes" {
            args.extend_from_slice(processes_only);
        }
        let o = run(&args);
        assert!(
            o.status.success(),
            "{engine} {mode} run of {file} failed:\n{}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    nodes_csv_equal(&p, &i);
    assert_eq!(metrics(&p)["engine"], "processes");
    assert_eq!(metrics(&p)["clock"], "logical");
    assert_nothing_left(&run_id_of(&p));
    serde_json::from_str(&std::fs::read_to_string(p.join("run.json")).expect("run.json"))
        .expect("run.json parses")
}

#[test]
fn async_processes_reproduce_the_inprocess_engine_on_the_spiral() {
    equivalence("mourya2017-spiral.toml", "async", "100");
}

#[test]
fn async_processes_reproduce_the_inprocess_engine_with_the_eq_5_prox_scaling() {
    equivalence_at(
        &scenario("mourya2017-spiral.toml"),
        "async",
        "30",
        &["--prox-scaling", "inverse-probability"],
        &[],
    );
}

/// The noise-weighted costs need each sample's sigmas at the nodes: they
/// travel in the sample's frames.
#[test]
fn processes_reproduce_the_inprocess_engine_with_noise_weighted_costs() {
    let sc = scenario("mourya2017-spiral-eq5.toml");
    equivalence_at(&sc, "sync", "15", &["--variant", "sync-weighted"], &[]);
    equivalence_at(
        &sc,
        "async",
        "15",
        &["--variant", "async-eq5-weighted"],
        &[],
    );
}

#[test]
fn sync_processes_reproduce_the_inprocess_engine_on_the_spiral() {
    equivalence("mourya2017-spiral.toml", "sync", "30");
}

#[test]
fn polling_nodes_reproduce_the_inprocess_engine_and_record_the_poll_time() {
    let sc = scenario("rgg16-waypoints.toml");
    for mode in ["async", "sync"] {
        let run_json = equivalence_at(&sc, mode, "14", &[], &["--poll-us", "200"]);
        assert_eq!(run_json["poll_us"], 200, "{run_json}");
    }
}

#[test]
fn polling_is_refused_without_node_processes() {
    let o = run(&[
        "run",
        scenario("mourya2017-spiral.toml").to_str().unwrap(),
        "--engine",
        "inprocess",
        "--poll-us",
        "10",
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("--poll-us") && err.contains("--engine processes"),
        "{err}"
    );
}

#[test]
fn async_processes_reproduce_the_inprocess_engine_on_16_nodes() {
    equivalence("rgg16-waypoints.toml", "async", "60");
}

#[test]
fn sync_processes_reproduce_the_inprocess_engine_on_16_nodes() {
    equivalence("rgg16-waypoints.toml", "sync", "12");
}

/// The spiral with `local_solver = "gtrs_l0"` and `kappa = 2` (not the default, so a
/// node process that lost `kappa` on the way would disagree).
fn spiral_gtrs_l0_kappa_2(tmp: &TempDir) -> std::path::PathBuf {
    let text = std::fs::read_to_string(scenario("mourya2017-spiral.toml")).unwrap();
    assert!(text.contains("local_solver = \"gtrs\"\n"));
    let text = text.replace(
        "local_solver = \"gtrs\"\n",
        "local_solver = \"gtrs_l0\"\nkappa = 2\n",
    );
    tmp.write("spiral-l0.toml", &text)
}

#[test]
fn async_processes_reproduce_the_inprocess_engine_with_gtrs_l0() {
    let run = equivalence_at(
        &scenario("mourya2017-spiral.toml"),
        "async",
        "60",
        &["--local-solver", "gtrs_l0"],
        &[],
    );
    assert_eq!(run["local_solver"], "gtrs_l0");
    assert_eq!(run["scenario"]["algorithm"]["kappa"], 1);
    let tmp = TempDir::new("l0-async");
    let run = equivalence_at(&spiral_gtrs_l0_kappa_2(&tmp), "async", "40", &[], &[]);
    assert_eq!(run["scenario"]["algorithm"]["kappa"], 2);
}

#[test]
fn sync_processes_reproduce_the_inprocess_engine_with_gtrs_l0() {
    let tmp = TempDir::new("l0-sync");
    let run = equivalence_at(&spiral_gtrs_l0_kappa_2(&tmp), "sync", "20", &[], &[]);
    assert_eq!(run["local_solver"], "gtrs_l0");
    assert_eq!(run["scenario"]["algorithm"]["kappa"], 2);
    let run = equivalence_at(
        &scenario("rgg16-waypoints.toml"),
        "sync",
        "12",
        &["--local-solver", "gtrs_l0"],
        &[],
    );
    assert_eq!(run["local_solver"], "gtrs_l0");
}

#[test]
fn a_replayed_trace_and_schedule_give_the_same_nodes_over_processes() {
    let tmp = TempDir::new("replay-proc");
    let first = tmp.path().join("first");
    let sc = scenario("mourya2017-spiral.toml");
    let o = run(&[
        "run",
        sc.to_str().unwrap(),
        "--engine",
        "inprocess",
        "--samples",
        "20",
        "--quiet",
        "--out",
        first.to_str().unwrap(),
    ]);
    assert!(o.status.success());
    let geometry = sonarnet::model::measure::Geometry::mourya2017().toml_table();
    let text = format!(
        r#"name = "replay"
seed = 123
[geometry]
{geometry}
[network]
edges = [[0, 1], [0, 2], [1, 3], [2, 3], [3, 4], [3, 5]]
[measurements]
range_noise = {{ model = "gaussian", sigma = 5.0 }}
doa_noise = {{ model = "gaussian", sigma = 0.5 }}
trace = "{}"
truth = "{}"
[algorithm]
mode = "async"
gamma = 2e-8
iterations_per_sample = 50
schedule = "{}"
"#,
        first.join("measurements.csv").display(),
        first.join("truth.csv").display(),
        first.join("schedule.csv").display()
    );
    let p = tmp.write("replay.toml", &text);
    let second = tmp.path().join("second");
    let o = run(&[
        "run",
        p.to_str().unwrap(),
        "--quiet",
        "--out",
        second.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    nodes_csv_equal(&first, &second);
    assert_nothing_left(&run_id_of(&second));
}

#[test]
fn a_64_node_ring_completes_over_processes() {
    let tmp = TempDir::new("ring64");
    let text = sonarnet::pipeline::bench::ring_toml(64, 5, 40);
    let p = tmp.write("ring64.toml", &text);
    let out = tmp.path().join("out");
    let o = run(&[
        "run",
        p.to_str().unwrap(),
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let m = metrics(&out);
    assert_eq!(m["samples_completed"], 5);
    assert_eq!(m["nodes"].as_array().unwrap().len(), 64);
    assert_nothing_left(&run_id_of(&out));
}

/// The coordinator of a running 64-node ring holds no more open files than
/// preflight counts on (9 per node plus 64; at 12 per node, 2048 nodes could
/// not start).
#[test]
fn the_coordinator_of_a_64_node_ring_holds_at_most_9_files_per_node() {
    let tmp = TempDir::new("ring64-fds");
    let text = sonarnet::pipeline::bench::ring_toml(64, 400, 2000);
    let p = tmp.write("ring64.toml", &text);
    let out = tmp.path().join("out");
    let child = spawn_sonarnet(&[
        "run",
        p.to_str().unwrap(),
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    let pid = child.id();
    let files = || std::fs::read_dir(format!("/proc/{pid}/fd")).map_or(0, |d| d.count());
    // Once every node is up and the samples flow (the count stops rising),
    // take the largest count over half a second.
    let deadline = Instant::now() + Duration::from_secs(60);
    while children_of(pid).len() < 64 || files() < 8 * 64 {
        assert!(Instant::now() < deadline, "the ring never came up");
        std::thread::sleep(Duration::from_millis(20));
    }
    let mut most = 0;
    for _ in 0..25 {
        most = most.max(files());
        std::thread::sleep(Duration::from_millis(20));
    }
    // SAFETY: kill(2) on our own child.
    unsafe {
        libc::kill(pid as i32, libc::SIGINT);
    }
    let _ = wait_watchdog(child, "the ring", LIMIT);
    assert!(
        most <= 9 * 64 + 64,
        "the coordinator held {most} files for 64 nodes"
    );
    assert!(most >= 8 * 64, "measured while running: {most}");
    assert_nothing_left(&run_id_of(&out));
}

#[test]
fn two_concurrent_runs_on_one_host_both_succeed() {
    let tmp = TempDir::new("concurrent");
    let sc = scenario("mourya2017-spiral.toml");
    let outs = [tmp.path().join("a"), tmp.path().join("b")];
    let children: Vec<_> = outs
        .iter()
        .map(|o| {
            spawn_sonarnet(&[
                "run",
                sc.to_str().unwrap(),
                "--quiet",
                "--out",
                o.to_str().unwrap(),
            ])
        })
        .collect();
    for c in children {
        let o = wait_watchdog(c, "concurrent run", LIMIT);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    nodes_csv_equal(&outs[0], &outs[1]);
    assert_ne!(run_id_of(&outs[0]), run_id_of(&outs[1]));
    for o in &outs {
        assert_nothing_left(&run_id_of(o));
    }
}

/// Start a long processes run of the spiral (3000 iterations per sample,
/// quiet, into `out`, with the `extra` flags), to be signalled while it runs.
fn spawn_long_spiral(out: &std::path::Path, extra: &[&str]) -> std::process::Child {
    let sc = scenario("mourya2017-spiral.toml");
    let mut args = vec![
        "run",
        sc.to_str().unwrap(),
        "--iterations-per-sample",
        "3000",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    spawn_sonarnet(&args)
}

/// Wait until `pid` has `n` children (the node processes), or panic.
fn wait_for_children(pid: u32, n: usize) -> Vec<u32> {
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        let c = children_of(pid);
        if c.len() >= n {
            return c;
        }
        assert!(
            Instant::now() < deadline,
            "watchdog: only {} of {n} nodes appeared",
            c.len()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The pid, among `pids`, of the node process with id `id` (its `--launch`
/// JSON names it).
fn node_pid(pids: &[u32], id: u32) -> u32 {
    let tag = format!("\"id\":{id},");
    pids.iter()
        .copied()
        .find(|p| {
            String::from_utf8_lossy(
                &std::fs::read(format!("/proc/{p}/cmdline")).unwrap_or_default(),
            )
            .contains(&tag)
        })
        .unwrap_or_else(|| panic!("no process of node {id} among {pids:?}"))
}

/// `kill -STOP` of node 3 in a logical run (sync or async) of the spiral with
/// `--stall-timeout 1`: the watchdog names the node, the stopped process is
/// killed and reaped, the partial results are written marked failed, and
/// nothing is left behind. It used to hang forever.
#[test]
fn a_stopped_node_ends_a_logical_run_with_an_error_naming_it() {
    let tmp = TempDir::new("stop-logical");
    for mode in ["async", "sync"] {
        let out = tmp.path().join(mode);
        let child = spawn_long_spiral(&out, &["--mode", mode, "--stall-timeout", "1"]);
        let nodes = wait_for_children(child.id(), 6);
        std::thread::sleep(Duration::from_millis(800));
        let victim = node_pid(&nodes, 3);
        let stopped = Instant::now();
        // SAFETY: plain kill(2) on a grandchild we identified by its parent.
        unsafe { libc::kill(victim as i32, libc::SIGSTOP) };
        let o = wait_watchdog(child, "run with a stopped node", LIMIT);
        let took = stopped.elapsed();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{mode}: {stderr}");
        assert!(
            stderr.contains("node 3 is not responding (stopped?) at sample"),
            "{mode}: {stderr}"
        );
        let m = metrics(&out);
        assert_eq!(m["status"], "failed", "{mode}");
        let done = m["samples_completed"].as_u64().unwrap();
        let err = m["error"].as_str().unwrap();
        assert!(err.contains(&format!("at sample {done}")), "{mode}: {err}");
        eprintln!("{mode}: run ended {took:?} after the SIGSTOP, {done} samples kept");
        assert_nothing_left(&run_id_of(&out));
    }
}

/// The run id a node process was launched with (its `--launch` JSON).
fn launch_run_id(pid: u32) -> String {
    let cmd = String::from_utf8_lossy(&std::fs::read(format!("/proc/{pid}/cmdline")).unwrap())
        .to_string();
    cmd.split("\"run_id\":\"")
        .nth(1)
        .and_then(|s| s.split('"').next())
        .unwrap_or_else(|| panic!("no run_id in {cmd}"))
        .to_string()
}

/// `kill -9` of the coordinator: its nodes notice (SIGTERM from the kernel,
/// `PR_SET_PDEATHSIG`) and leave, and the last one to leave removes what
/// the coordinator could not (33-35 files in `/dev/shm`
/// and 47-51 under the iceoryx2 root were left until the next run).
#[test]
fn a_killed_coordinator_leaves_no_process_and_no_file_behind() {
    let tmp = TempDir::new("kill-coordinator");
    let out = tmp.path().join("out");
    let child = spawn_long_spiral(&out, &[]);
    let nodes = wait_for_children(child.id(), 6);
    let run_id = launch_run_id(nodes[0]);
    std::thread::sleep(Duration::from_millis(800));
    assert!(
        !sonarnet::transport::run_resources(&run_id).is_empty(),
        "a live run has resources"
    );
    // SAFETY: plain kill(2) on our own child.
    unsafe { libc::kill(child.id() as i32, libc::SIGKILL) };
    let o = wait_watchdog(child, "killed coordinator", LIMIT);
    assert!(!o.status.success());
    assert_nothing_left(&run_id);
}

/// Every file (not directory) below `dir`.
fn files_below(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        if e.path().is_dir() {
            out.extend(files_below(&e.path()));
        } else {
            out.push(e.path());
        }
    }
    out
}

/// Each user has an iceoryx2 root of their own, and one
/// that belongs to another user is refused. Runs the processes engine as
/// `nobody` (uid 65534) through `setpriv`, so it needs root; elsewhere it
/// says SKIPPED. The second user's root is put back as it was found (absent).
#[test]
fn a_second_user_runs_in_a_root_of_their_own_and_refuses_a_foreign_one() {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    // SAFETY: getuid has no failure mode.
    if unsafe { libc::getuid() } != 0 || Command::new("setpriv").arg("--version").output().is_err()
    {
        eprintln!("SKIPPED: needs root and setpriv to act as a second user");
        return;
    }
    let tmp = TempDir::new("second-user");
    std::fs::set_permissions(tmp.path(), std::fs::Permissions::from_mode(0o777)).unwrap();
    let root = std::path::Path::new("/dev/shm/sonarnet-iceoryx2-65534");
    let _ = std::fs::remove_dir_all(root);
    let sc = scenario("mourya2017-spiral.toml");
    let run_as_nobody = |out: &str| {
        let out = tmp.path().join(out);
        let child = Command::new("setpriv")
            .args(["--reuid=65534", "--regid=65534", "--clear-groups"])
            .arg(env!("CARGO_BIN_EXE_sonarnet"))
            .args(["run", sc.to_str().unwrap(), "--samples", "12", "--quiet"])
            .arg("--out")
            .arg(&out)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .expect("spawn setpriv");
        (wait_watchdog(child, "a run as a second user", LIMIT), out)
    };
    // A root made by another user (here root) is refused, naming it.
    std::fs::create_dir(root).unwrap();
    std::fs::set_permissions(root, std::fs::Permissions::from_mode(0o700)).unwrap();
    let (o, _) = run_as_nobody("foreign");
    let stderr = String::from_utf8_lossy(&o.stderr);
    std::fs::remove_dir(root).unwrap();
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("sonarnet-iceoryx2-65534/: belongs to uid 0"),
        "{stderr}"
    );
    // Without it, the second user's run makes its own root, 0700, and succeeds.
    let (o, out) = run_as_nobody("own");
    let meta = std::fs::metadata(root);
    let left = files_below(root);
    let _ = std::fs::remove_dir_all(root);
    assert!(left.is_empty(), "the run left {left:?}");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let meta = meta.unwrap();
    assert_eq!((meta.uid(), meta.mode() & 0o777), (65534, 0o700));
    assert_nothing_left(&run_id_of(&out));
}

#[test]
fn sigint_stops_every_node_writes_partial_results_and_exits_nonzero() {
    let tmp = TempDir::new("sigint");
    let out = tmp.path().join("out");
    let child = spawn_long_spiral(&out, &[]);
    let pid = child.id();
    wait_for_children(pid, 6);
    std::thread::sleep(Duration::from_millis(1500));
    // SAFETY: plain kill(2) on our own child.
    unsafe { libc::kill(pid as i32, libc::SIGINT) };
    let o = wait_watchdog(child, "interrupted run", LIMIT);
    assert!(!o.status.success(), "an interrupted run must exit non-zero");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("interrupted"), "{stderr}");
    assert!(
        stderr.contains(out.to_str().unwrap()),
        "must say where: {stderr}"
    );
    let m = metrics(&out);
    assert_eq!(m["status"], "interrupted");
    assert!(m["samples_completed"].as_u64().unwrap() < 100);
    assert_nothing_left(&run_id_of(&out));
}

#[test]
fn a_killed_node_ends_a_logical_run_with_a_clear_error_naming_it() {
    let tmp = TempDir::new("kill-logical");
    let out = tmp.path().join("out");
    let child = spawn_long_spiral(&out, &[]);
    let pid = child.id();
    let nodes = wait_for_children(pid, 6);
    std::thread::sleep(Duration::from_millis(1000));
    let victim = nodes[3];
    // Which node id is it? Its --launch JSON names it.
    let cmd = String::from_utf8_lossy(&std::fs::read(format!("/proc/{victim}/cmdline")).unwrap())
        .to_string();
    let id = cmd
        .split("\"id\":")
        .nth(1)
        .and_then(|s| s.split(|c: char| !c.is_ascii_digit()).next())
        .unwrap()
        .to_string();
    let killed = Instant::now();
    // SAFETY: plain kill(2) on a grandchild we identified by its parent.
    unsafe { libc::kill(victim as i32, libc::SIGKILL) };
    let o = wait_watchdog(child, "run with a killed node", LIMIT);
    let took = killed.elapsed();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains(&format!("node {id} died")),
        "must name node {id}: {stderr}"
    );
    assert!(stderr.contains("signal 9"), "{stderr}");
    let m = metrics(&out);
    assert_eq!(m["status"], "failed");
    assert!(m["error"].as_str().unwrap().contains(&format!("node {id}")));
    // The error names the sample in progress, and schedule.csv holds the completed
    // samples and that one, not the samples the coordinator had sent ahead.
    let done = m["samples_completed"].as_u64().unwrap() as usize;
    assert!(
        m["error"]
            .as_str()
            .unwrap()
            .contains(&format!("at sample {done}")),
        "{m}"
    );
    assert_eq!(
        read_rows(&out.join("schedule.csv")).len(),
        (done + 1) * 3000,
        "schedule rows"
    );
    eprintln!("run ended {took:?} after the kill");
    assert_nothing_left(&run_id_of(&out));
}

#[test]
fn a_killed_node_in_realtime_mode_leaves_a_recorded_gap_and_the_run_continues() {
    let _cpu = cpu_exclusive();
    let tmp = TempDir::new("kill-realtime");
    let out = tmp.path().join("out");
    let sc = scenario("mourya2017-spiral.toml");
    let child = spawn_sonarnet(&[
        "run",
        sc.to_str().unwrap(),
        "--clock",
        "realtime",
        "--samples",
        "60",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    let pid = child.id();
    let nodes = wait_for_children(pid, 6);
    std::thread::sleep(Duration::from_millis(400));
    // Node 5 is a leaf (only joined to node 3): the rest stays connected.
    let victim = node_pid(&nodes, 5);
    // SAFETY: plain kill(2).
    unsafe { libc::kill(victim as i32, libc::SIGKILL) };
    let o = wait_watchdog(child, "realtime run with a killed node", LIMIT);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "the run must continue: {stderr}");
    let m = metrics(&out);
    assert_eq!(m["samples_completed"], 60);
    let deaths = m["deaths"].as_array().unwrap();
    assert_eq!(deaths.len(), 1, "{deaths:?}");
    assert_eq!(deaths[0]["node"], 5);
    assert_nothing_left(&run_id_of(&out));
}

/// A realtime run of `sc` (80 samples, `extra` flags) in which `node`
/// gets `signal` `after` the nodes are up; returns the results directory and
/// the sample at which the death was noticed.
fn realtime_run_signalling(
    sc: &std::path::Path,
    tmp: &TempDir,
    name: &str,
    node: u32,
    signal: i32,
    after: Duration,
    extra: &[&str],
) -> (std::path::PathBuf, usize) {
    let out = tmp.path().join(name);
    let mut args = vec![
        "run",
        sc.to_str().unwrap(),
        "--clock",
        "realtime",
        "--samples",
        "80",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let child = spawn_sonarnet(&args);
    let nodes = wait_for_children(child.id(), 6);
    std::thread::sleep(after);
    let victim = node_pid(&nodes, node);
    // SAFETY: plain kill(2).
    unsafe { libc::kill(victim as i32, signal) };
    let o = wait_watchdog(child, "realtime run with a node signalled", LIMIT);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let m = metrics(&out);
    assert_eq!(m["samples_completed"], 80, "{m}");
    assert_eq!(m["deaths"][0]["node"], node, "{m}");
    let at = m["deaths"][0]["sample"].as_u64().unwrap() as usize;
    assert_nothing_left(&run_id_of(&out));
    (out, at)
}

/// A realtime run of the spiral in which node 2 is killed `after` the nodes
/// are up. Samples of 50 ms and the prox of eq. (5) (about 100 exchanges per
/// sample) put the track at its floor, so that its error does not depend on
/// how many exchanges a loaded machine manages per sample (at the spiral's own
/// 20 ms and eq. (11), two runs differed by 1.4x with no death at all).
fn realtime_run_killing_node_2(
    tmp: &TempDir,
    name: &str,
    after: Duration,
) -> (std::path::PathBuf, usize) {
    let text = std::fs::read_to_string(scenario("mourya2017-spiral.toml")).unwrap();
    let text = text.replace("sample_period_ms = 20.0", "sample_period_ms = 50.0");
    assert!(text.contains("sample_period_ms = 50.0"));
    let sc = tmp.write(&format!("{name}.toml"), &text);
    let extra = ["--prox-scaling", "inverse-probability"];
    realtime_run_signalling(&sc, tmp, name, 2, libc::SIGKILL, after, &extra)
}

/// `kill -STOP` of a leaf in a realtime run: the node is not responding to
/// its snapshot, is treated as dead (killed, left out, named), and the run
/// goes on to the end.
#[test]
fn a_stopped_node_in_realtime_mode_is_left_out_as_dead_and_the_run_continues() {
    let _cpu = cpu_exclusive();
    let tmp = TempDir::new("stop-realtime");
    let (out, _) = realtime_run_signalling(
        &scenario("mourya2017-spiral.toml"),
        &tmp,
        "out",
        5,
        libc::SIGSTOP,
        Duration::from_millis(300),
        &["--stall-timeout", "1"],
    );
    let m = metrics(&out);
    assert_eq!(m["status"], "ok");
    let deaths = m["deaths"].as_array().unwrap();
    assert_eq!(deaths.len(), 1, "{deaths:?}");
    let how = deaths[0]["how"].as_str().unwrap();
    assert!(how.contains("not responding (stopped?)"), "{how}");
    let last = read_rows(&out.join("nodes.csv"))
        .into_iter()
        .filter(|r| r[0] == "79" && r[1] == "5")
        .collect::<Vec<_>>();
    assert_eq!(last.len(), 1);
    assert_eq!(last[0][5], "false", "node 5 is not alive at the end");
}

/// A node that exits on its own (here SIGTERM: it stops cleanly) is a death
/// like a SIGKILL: named with its cause, and its neighbours do not wait for
/// it (they used to block 10 s sending to it, then fail the run).
#[test]
fn a_node_that_exits_on_its_own_in_realtime_mode_is_a_named_death_and_the_run_continues() {
    let _cpu = cpu_exclusive();
    let tmp = TempDir::new("term-realtime");
    for (i, node) in [5u32, 2].into_iter().enumerate() {
        let (out, at) = realtime_run_signalling(
            &scenario("mourya2017-spiral.toml"),
            &tmp,
            &format!("run{i}"),
            node,
            libc::SIGTERM,
            Duration::from_millis(500),
            &[],
        );
        let m = metrics(&out);
        assert_eq!(m["status"], "ok");
        let how = m["deaths"][0]["how"].as_str().unwrap();
        assert!(how.contains("SIGTERM"), "{how}");
        assert_eq!(m["deaths"].as_array().unwrap().len(), 1, "{m}");
        assert!(at < 80);
    }
}

/// The error column of track.csv from sample `from` on.
fn errors_from(out: &std::path::Path, from: usize) -> Vec<f64> {
    read_rows(&out.join("track.csv"))
        .iter()
        .skip(from)
        .map(|r| r[5].parse::<f64>().unwrap())
        .collect()
}

#[test]
fn after_a_death_theta_bar_is_the_mean_of_the_live_nodes_and_tracks_as_without_that_node() {
    let _cpu = cpu_exclusive();
    let tmp = TempDir::new("death-theta-bar");
    // Node 2 dies about half way in, and, for the reference, a few samples
    // after the start (a death during start-up fails the run): the same seed,
    // so the five other nodes see the same data.
    let (late, at) = realtime_run_killing_node_2(&tmp, "late", Duration::from_millis(2000));
    let (early, early_at) = realtime_run_killing_node_2(&tmp, "early", Duration::from_millis(500));
    assert!(early_at + 5 < at, "deaths at {early_at} and {at}");
    assert!(at > 10 && at < 70, "death noticed at sample {at}");
    // nodes.csv: node 2 is alive before the death and not from then on, and
    // est_x of track.csv is the mean of the live nodes' x.
    let nodes = read_rows(&late.join("nodes.csv"));
    let track = read_rows(&late.join("track.csv"));
    for k in [at - 1, at, at + 5] {
        let rows: Vec<&Vec<String>> = nodes.iter().filter(|r| r[0] == k.to_string()).collect();
        assert_eq!(rows.len(), 6);
        assert_eq!(
            rows[2][5],
            if k < at { "true" } else { "false" },
            "sample {k}"
        );
        let live: Vec<f64> = rows
            .iter()
            .filter(|r| r[5] == "true")
            .map(|r| r[2].parse().unwrap())
            .collect();
        let mean = live.iter().sum::<f64>() / live.len() as f64;
        let est: f64 = track[k][3].parse().unwrap();
        assert!(
            (est - mean).abs() <= 1e-9 * mean.abs(),
            "sample {k}: est_x {est} vs live mean {mean}"
        );
    }
    // After the death (and 5 samples for the consensus to settle without it)
    // the track is as good as that of the network that lost node 2 at once.
    let rms = |e: &[f64]| (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt();
    let (a, b) = (
        rms(&errors_from(&late, at + 5)),
        rms(&errors_from(&early, at + 5)),
    );
    eprintln!("after the death: {a:.2} m; without node 2 from the start: {b:.2} m");
    assert!(
        a <= 1.3 * b,
        "after a death {a:.2} m > 1.3 x {b:.2} m without that node"
    );
}

#[test]
fn realtime_gossip_with_enough_iterations_meets_the_async_accuracy_bound() {
    let _cpu = cpu_exclusive();
    let tmp = TempDir::new("realtime");
    let out = tmp.path().join("out");
    let sc = scenario("mourya2017-spiral.toml");
    let o = run(&[
        "run",
        sc.to_str().unwrap(),
        "--clock",
        "realtime",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let m = metrics(&out);
    let rt = &m["realtime"];
    let median = rt["iterations_per_sample_median"].as_f64().unwrap();
    eprintln!("realtime: {rt}");
    assert!(
        median >= 50.0,
        "precondition: the configured rate gave only {median} iterations per sample (need 50)"
    );
    let rmse = m["rmse_after_burn_in"].as_f64().unwrap();
    assert!(
        rmse <= 20.0,
        "realtime rmse_after_burn_in {rmse:.2} m > 20 m"
    );
    assert_eq!(m["clock"], "realtime");
    assert_nothing_left(&run_id_of(&out));
}

#[test]
fn the_node_program_rejects_bad_arguments_with_exit_code_2() {
    for args in [vec![], vec!["--launch", "{not json"], vec!["--bogus"]] {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_sonarnet-node"))
            .args(&args)
            .output()
            .expect("run sonarnet-node");
        assert_eq!(o.status.code(), Some(2), "args {args:?}");
        assert!(!String::from_utf8_lossy(&o.stderr).contains("panicked"));
    }
}

#[test]
fn trace_iterations_records_every_update_identically_in_both_engines() {
    let tmp = TempDir::new("trace-it");
    let sc = scenario("mourya2017-spiral.toml");
    for mode in ["async", "sync"] {
        let mut dirs = Vec::new();
        for engine in ["processes", "inprocess"] {
            let out = tmp.path().join(format!("{mode}-{engine}"));
            let o = run(&[
                "run",
                sc.to_str().unwrap(),
                "--engine",
                engine,
                "--mode",
                mode,
                "--samples",
                "12",
                "--trace-iterations",
                "--quiet",
                "--out",
                out.to_str().unwrap(),
            ]);
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            dirs.push(out);
        }
        let a = read_rows(&dirs[0].join("iterations.csv"));
        let b = read_rows(&dirs[1].join("iterations.csv"));
        // async: two updated nodes per iteration; sync: all six per round.
        let per = if mode == "async" { 2 } else { 6 };
        assert_eq!(a.len(), 12 * 50 * per, "{mode}: rows of iterations.csv");
        assert_eq!(a, b, "{mode}: iterations.csv differs between engines");
        assert!(dirs[0].join("consensus.svg").is_file());
        assert_nothing_left(&run_id_of(&dirs[0]));
    }
}

#[test]
fn a_node_program_that_cannot_start_records_the_run_id_and_leaves_nothing_behind() {
    let tmp = TempDir::new("spawn-fails");
    let out = tmp.path().join("out");
    // A node program that exists but cannot be executed (mode 0644).
    let prog = tmp.write("sonarnet-node", "not a program\n");
    let sc = scenario("mourya2017-spiral.toml");
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_sonarnet"))
        .args(["run", sc.to_str().unwrap(), "--quiet", "--out"])
        .arg(&out)
        .env("SONARNET_NODE_BIN", &prog)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn sonarnet");
    let o = wait_watchdog(child, "a run whose nodes cannot start", LIMIT);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("cannot start"), "{stderr}");
    assert_eq!(metrics(&out)["status"], "failed");
    // run.json names the namespace (it used to be null), and that namespace
    // is empty again.
    assert_nothing_left(&run_id_of(&out));
}

/// The hop measurement of `sonarnet bench`: neighbouring node
/// processes ping-pong, the edges in turn (50 hops take three of the
/// spiral's six edges, 20 + 20 + 10), blocking and polling; every probe is
/// answered, each hop is a positive, finite time, and the measuring runs
/// leave nothing behind. (How long a hop takes is a benchmark figure, not
/// asserted here.)
#[test]
fn the_one_hop_measurement_between_neighbouring_node_processes_answers_every_probe() {
    let sc = sonarnet::scenario::Scenario::load(&scenario("mourya2017-spiral.toml")).unwrap();
    let plan = sonarnet::protocol::RunPlan::new(&sc, sonarnet::protocol::Clock::Logical).unwrap();
    for poll_us in [0, 100] {
        let opts = sonarnet::runtime::processes::ProcessOptions {
            poll_us,
            ..Default::default()
        };
        let (hops, run_id) = sonarnet::runtime::processes::measure_hop(&plan, &opts, 50)
            .expect("every probe answered");
        assert_eq!(hops.len(), 50);
        assert!(hops.iter().all(|h| h.is_finite() && *h > 0.0), "{hops:?}");
        assert_nothing_left(&run_id);
    }
}

/// Runs the faults spiral (`pause` variant, 30 samples, realtime clock) on
/// node processes with `examples/garbage_node.rs` as node 1 in `mode`
/// (the real node program for the others), checks that the run finished
/// with node 1 dead from the first sample, `theta_bar` the mean of the live
/// nodes' `theta` and nothing left behind, and returns its standard error
/// and metrics.
fn run_with_a_broken_node_1(mode: &str) -> (String, serde_json::Value) {
    run_with_a_broken_node_1_and(mode, &[])
}

/// `sonarnet run` of the faults spiral on node processes into `dir`, with
/// `args`, and `examples/garbage_node.rs` as the node program: node `node`
/// broken in `mode`, the real node program for the others.
fn spawn_with_a_garbage_node(
    node: &str,
    mode: &str,
    args: &[&str],
    dir: &std::path::Path,
) -> std::process::Child {
    let exe = std::path::PathBuf::from(env!("CARGO_BIN_EXE_sonarnet"));
    let garbage = exe
        .parent()
        .expect("target dir")
        .join("examples")
        .join("garbage_node");
    assert!(garbage.exists(), "{} was not built", garbage.display());
    Command::new(&exe)
        .args([
            "run",
            scenario("mourya2017-spiral-faults.toml")
                .to_str()
                .expect("utf-8"),
            "--engine",
            "processes",
            "--quiet",
            "--out",
            dir.to_str().expect("utf-8"),
        ])
        .args(args)
        .env("SONARNET_NODE_BIN", &garbage)
        .env("SONARNET_GARBAGE_NODE", node)
        .env("SONARNET_GARBAGE_MODE", mode)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn sonarnet")
}

/// [`run_with_a_broken_node_1`] with `extra` flags for `sonarnet run`.
fn run_with_a_broken_node_1_and(mode: &str, extra: &[&str]) -> (String, serde_json::Value) {
    let _cpu = cpu_exclusive();
    let tmp = TempDir::new("garbage-node");
    let dir = tmp.path().join("run");
    let mut args = vec!["--variant", "pause", "--set", "target.samples=30"];
    args.extend_from_slice(extra);
    let child = spawn_with_a_garbage_node("1", mode, &args, &dir);
    let o = wait_watchdog(child, "sonarnet run with a broken node", LIMIT);
    let stderr = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(o.status.success(), "{stderr}");
    let m = metrics(&dir);
    assert_eq!(m["status"], "ok");
    for i in [0usize, 2, 3, 4, 5] {
        assert!(m["nodes"][i].get("bad_frames_sent").is_none(), "node {i}");
    }
    // Node 1 is dead from the first sample on; theta_bar of every sample is
    // the mean of the live nodes' theta.
    let rows = read_rows(&dir.join("nodes.csv"));
    let track = read_rows(&dir.join("track.csv"));
    assert_eq!(track.len(), 30);
    for (k, t) in track.iter().enumerate() {
        let live: Vec<&Vec<String>> = rows
            .iter()
            .filter(|r| r[0] == k.to_string() && r[5] == "true")
            .collect();
        assert!(
            live.iter().all(|r| r[1] != "1"),
            "node 1 alive at sample {k}"
        );
        for (axis, col) in [(2usize, 3usize), (3, 4)] {
            let mean = live
                .iter()
                .map(|r| r[axis].parse::<f64>().unwrap())
                .sum::<f64>()
                / live.len() as f64;
            let est: f64 = t[col].parse().unwrap();
            approx::assert_relative_eq!(est, mean, max_relative = 1e-12);
        }
    }
    assert_nothing_left(&run_id_of(&dir));
    (stderr, m)
}

/// A node that sends frames the coordinator cannot decode
/// (`examples/garbage_node.rs` as node 1) is counted, named and cut off
/// after `CUT_OFF_BAD_FRAMES` of them: its process is killed, the run goes
/// on as after a crash (realtime clock), `theta_bar` is the mean of the
/// live nodes, and nothing is left behind.
#[test]
fn a_node_that_sends_garbage_is_named_and_cut_off_and_the_run_goes_on() {
    let (stderr, m) = run_with_a_broken_node_1("junk");
    assert!(
        stderr.contains("node 1 sent") && stderr.contains("cut off"),
        "{stderr}"
    );
    let sent = m["nodes"][1]["bad_frames_sent"].as_u64().unwrap_or(0);
    assert!(
        sent >= sonarnet::runtime::processes::CUT_OFF_BAD_FRAMES,
        "{sent}"
    );
}

/// Node 1 was named on standard error and cut off for a frame in node 2's
/// name, its death says why, and node 2 did not die.
fn assert_node_1_was_cut_off_for_posing_as_node_2(stderr: &str, m: &serde_json::Value) {
    assert!(
        stderr.contains("node 1 sent a frame in the name of node 2") && stderr.contains("cut off"),
        "{stderr}"
    );
    let deaths = m["deaths"].to_string();
    assert!(deaths.contains("in the name of node 2"), "{deaths}");
    assert!(!deaths.contains("\"node\":2"), "node 2 lives: {deaths}");
}

/// A node process that sends well-formed reports in another node's name
/// (node 1 posing as node 2, with a `theta` of 1e9 m) is caught by the
/// process id iceoryx2 records for every publisher, named and cut off at
/// its first frame; none of its reports reaches `theta_bar` (checked
/// against the live nodes' own `theta`), and node 2 runs on.
#[test]
fn a_node_that_sends_frames_in_another_nodes_name_is_named_and_cut_off() {
    let (stderr, m) = run_with_a_broken_node_1("impostor");
    assert_node_1_was_cut_off_for_posing_as_node_2(&stderr, &m);
    let sent = m["nodes"][1]["bad_frames_sent"].as_u64().unwrap_or(0);
    assert!(sent >= 1, "{sent}");
}

/// A node that poses as another before it ever says READY is cut off while
/// the coordinator is still starting the run: that is no failed start-up,
/// but a death at sample 0, and the run goes on without it (over zenoh,
/// whose nodes start slower, the impostor above often meets this case).
#[test]
fn a_node_cut_off_before_it_is_ready_is_left_out_from_the_first_sample() {
    let (stderr, m) = run_with_a_broken_node_1("early-impostor");
    assert_node_1_was_cut_off_for_posing_as_node_2(&stderr, &m);
    let deaths = m["deaths"].as_array().expect("deaths");
    assert_eq!(deaths.len(), 1, "{deaths:?}");
    assert_eq!(deaths[0]["node"], 1, "{deaths:?}");
    assert_eq!(deaths[0]["sample"], 0, "{deaths:?}");
}

/// Over zenoh, the same impostor writes on the key naming it as the
/// sender (the router's access control lets it write no other): the
/// coordinator's transport finds the frames' `from` is not the key's, and
/// the node is named and cut off at its first frame as over iceoryx2.
#[cfg(feature = "zenoh")]
#[test]
fn over_zenoh_a_node_that_sends_frames_in_another_nodes_name_is_named_and_cut_off() {
    let (stderr, m) = run_with_a_broken_node_1_and("impostor", &["--transport", "zenoh"]);
    assert_node_1_was_cut_off_for_posing_as_node_2(&stderr, &m);
}

/// A node that gossips to its neighbour in a third node's name (4 requests
/// a millisecond) is caught by the neighbour: its transport checks every
/// publisher's process against the run's roster of node processes, which
/// the coordinator writes before the nodes start. The neighbour names it
/// once, counts and drops its frames, and the run finishes without it.
#[test]
fn a_node_that_gossips_in_another_nodes_name_is_named_by_its_neighbour_and_dropped() {
    let (stderr, m) = run_with_a_broken_node_1("peer-impostor");
    assert!(
        stderr.contains("warning: node 1 sent a frame in node ")
            && stderr.contains("name: dropped"),
        "{stderr}"
    );
    let dropped: u64 = (0..6)
        .filter(|&i| i != 1)
        .map(|i| m["nodes"][i]["bad_frames"].as_u64().unwrap_or(0))
        .sum();
    assert!(dropped >= 100, "{dropped}");
    let deaths = m["deaths"].as_array().expect("deaths").len();
    assert_eq!(deaths, 1, "{}", m["deaths"]);
}

/// A checkpoint file that is corrupted when a node is to restart from it
/// (`garbage_node` writes a truncated one where node 2's checkpoints go, and
/// none of its own) fails the run before the node is started: exit 2, the
/// error naming the file and the line and column where it breaks, the
/// partial results written as `failed`, and nothing left behind.
#[test]
fn a_corrupted_checkpoint_file_fails_the_restart_with_exit_2_naming_the_file_and_column() {
    let _cpu = cpu_exclusive();
    let tmp = TempDir::new("bad-checkpoint");
    let dir = tmp.path().join("run");
    let child = spawn_with_a_garbage_node("2", "bad-checkpoint", &["--variant", "restart"], &dir);
    let o = wait_watchdog(child, "sonarnet run with a corrupted checkpoint", LIMIT);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    let ck = dir.join("checkpoints").join("node-2.json");
    assert!(
        stderr.contains("node 2 cannot restart from its checkpoint")
            && stderr.contains(&ck.display().to_string())
            && stderr.contains("line 1 column"),
        "{stderr}"
    );
    assert!(stderr.contains("partial results were written"), "{stderr}");
    let m = metrics(&dir);
    assert_eq!(m["status"], "failed");
    // The restart is due at sample 30 of the realtime clock.
    assert!(m["samples_completed"].as_u64().unwrap_or(0) >= 25, "{m}");
    assert_nothing_left(&run_id_of(&dir));
}

/// A node that floods the coordinator with well-formed frames in its own
/// name (timing reports, 256 at a time) is named and cut off once it sends
/// more than its allowance (`flood_budget` frames per sample it was
/// given); the run goes on without it.
#[test]
fn a_node_that_floods_the_coordinator_with_well_formed_frames_is_named_and_cut_off() {
    let (stderr, m) = run_with_a_broken_node_1("flood");
    assert!(
        stderr.contains("error: node 1 sent") && stderr.contains("cut off as a flood"),
        "{stderr}"
    );
    let deaths = m["deaths"].to_string();
    assert!(deaths.contains("as a flood"), "{deaths}");
    assert!(
        m["nodes"][1].get("bad_frames_sent").is_none(),
        "they decode"
    );
}

/// A node that floods a neighbour with well-formed gossip requests (256
/// at a time) is named by that neighbour, which drops its frames past the
/// per-peer allowance (`peer_budget` per sample, or per sample period on
/// the realtime clock) instead of answering them; no honest node is taken
/// for a flood, and the run finishes without the flooder.
#[test]
fn a_node_that_floods_a_neighbour_is_named_by_it_and_its_frames_are_dropped() {
    let (stderr, m) = run_with_a_broken_node_1("peer-flood");
    assert!(
        stderr.contains("warning: node 1 sent more than the") && stderr.contains("are dropped"),
        "{stderr}"
    );
    assert!(!stderr.contains("as a flood"), "{stderr}");
    let dropped: u64 = (0..6)
        .filter(|&i| i != 1)
        .map(|i| m["nodes"][i]["bad_frames"].as_u64().unwrap_or(0))
        .sum();
    assert!(dropped > 1000, "{dropped}");
    let deaths = m["deaths"].as_array().expect("deaths").len();
    assert_eq!(deaths, 1, "{}", m["deaths"]);
}
