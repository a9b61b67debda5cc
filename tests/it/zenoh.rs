//! Runs over zenoh: the coordinator and two agents as separate
//! processes, each with its own zenoh session on loopback TCP, iceoryx2 out
//! of the path.

use crate::util::*;
use sonarnet::transport::ZenohSettings;
use std::path::Path;
use std::process::Child;
use std::time::{Duration, Instant};

const LIMIT: Duration = Duration::from_secs(120);

/// The fleet key file every agent and coordinator of these tests shares,
/// made once in Cargo's directory for test files.
fn fleet_key() -> &'static str {
    static KEY: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    KEY.get_or_init(|| {
        let p = Path::new(env!("CARGO_TARGET_TMPDIR")).join("fleet.key");
        match sonarnet::transport::credentials::write_fleet_key(&p) {
            // Another test binary made it first.
            Ok(_) | Err(sonarnet::transport::credentials::FleetKeyError::Exists { .. }) => {}
            Err(e) => panic!("a fleet key: {e}"),
        }
        p.to_string_lossy().into_owned()
    })
}

fn endpoint() -> String {
    ZenohSettings::free_loopback_endpoint().expect("a free loopback port")
}

/// `sonarnet run FILE --transport zenoh` with nodes 0-2 on agent `a` and 3-5
/// on agent `b`, listening on `ep`.
fn start_run(file: &Path, out: &Path, ep: &str, run_id: &str, extra: &[&str]) -> Child {
    start_placed(file, out, ep, run_id, &["a=0-2", "b=3-5"], extra)
}

fn start_placed(
    file: &Path,
    out: &Path,
    ep: &str,
    run_id: &str,
    places: &[&str],
    extra: &[&str],
) -> Child {
    let mut args = vec![
        "run",
        file.to_str().expect("utf-8"),
        "--out",
        out.to_str().expect("utf-8"),
        "--transport",
        "zenoh",
        "--listen",
        ep,
        "--run-id",
        run_id,
        "--quiet",
        "--fleet-key",
        fleet_key(),
    ];
    for p in places {
        args.extend_from_slice(&["--place", p]);
    }
    args.extend_from_slice(extra);
    spawn_sonarnet(&args)
}

fn start_agent(ep: &str, run_id: &str, host: &str) -> Child {
    start_agent_with(ep, run_id, host, &[])
}

/// `sonarnet agent` for `host` of run `run_id` at `ep`, waiting `wait`
/// seconds, with the fleet key file `key`.
fn agent_args<'a>(
    ep: &'a str,
    run_id: &'a str,
    host: &'a str,
    wait: &'a str,
    key: &'a str,
) -> Vec<&'a str> {
    vec![
        "agent",
        "--connect",
        ep,
        "--run-id",
        run_id,
        "--host",
        host,
        "--wait",
        wait,
        "--fleet-key",
        key,
    ]
}

fn start_agent_with(ep: &str, run_id: &str, host: &str, extra: &[&str]) -> Child {
    let mut args = agent_args(ep, run_id, host, "60", fleet_key());
    args.extend_from_slice(extra);
    spawn_sonarnet(&args)
}

/// A run spread over agents `a` (nodes 0-2) and `b` (3-5).
struct Spread {
    coordinator: Child,
    a: Child,
    b: Child,
}

impl Spread {
    /// Start the coordinator (`extra` flags) and both agents
    /// (`agent_extra` flags).
    fn start(
        file: &Path,
        out: &Path,
        ep: &str,
        id: &str,
        extra: &[&str],
        agent_extra: &[&str],
    ) -> Spread {
        Spread {
            coordinator: start_run(file, out, ep, id, extra),
            a: start_agent_with(ep, id, "a", agent_extra),
            b: start_agent_with(ep, id, "b", agent_extra),
        }
    }

    /// The spiral with 4000 iterations per sample (tens of seconds), for
    /// the tests that kill or interrupt a party mid-run.
    fn long(out: &Path, ep: &str, id: &str) -> Spread {
        Spread::start(
            &scenario("mourya2017-spiral.toml"),
            out,
            ep,
            id,
            &["--iterations-per-sample", "4000"],
            &[],
        )
    }

    /// Wait (watchdog) for the coordinator, then for both agents, which
    /// must end 0; the coordinator's output.
    fn finish(self) -> std::process::Output {
        let out = wait_watchdog(self.coordinator, "the coordinator", LIMIT);
        agents_end_cleanly(self.a, self.b);
        out
    }
}

fn agents_end_cleanly(a: Child, b: Child) {
    for (agent, name) in [(a, "a"), (b, "b")] {
        let o = wait_watchdog(agent, name, LIMIT);
        assert!(
            o.status.success(),
            "agent {name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
}

fn same_file(a: &Path, b: &Path, name: &str) {
    let x = std::fs::read(a.join(name)).expect("first file");
    let y = std::fs::read(b.join(name)).expect("second file");
    assert!(
        x == y,
        "{name} differs between {} and {}",
        a.display(),
        b.display()
    );
}

/// Wait (watchdog 30 s) until every agent of `agents` runs `each` nodes.
fn wait_for_nodes(agents: &[&Child], each: usize) {
    let deadline = Instant::now() + Duration::from_secs(30);
    while agents.iter().any(|a| children_of(a.id()).len() < each) {
        assert!(
            Instant::now() < deadline,
            "the agents never started their nodes"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn run_id(tag: &str) -> String {
    format!("zt-{tag}-{}", std::process::id())
}

#[test]
fn a_run_spread_over_two_agents_equals_the_inprocess_engine_in_sync_and_async() {
    let spiral = scenario("mourya2017-spiral.toml");
    for mode in ["async", "sync"] {
        let reference = TempDir::new("zenoh-ref");
        let out = run_file(
            &spiral,
            reference.path(),
            &["--engine", "inprocess", "--mode", mode, "--quiet"],
            LIMIT,
        );
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let dir = TempDir::new("zenoh-agents");
        let ep = endpoint();
        let id = run_id(mode);
        let out = Spread::start(&spiral, dir.path(), &ep, &id, &["--mode", mode], &[]).finish();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{stderr}");
        for f in ["track.csv", "nodes.csv", "measurements.csv"] {
            same_file(reference.path(), dir.path(), f);
        }
        assert_eq!(run_id_of(dir.path()), id);
        assert_nothing_left(&id);
    }
}

#[test]
fn killing_an_agent_mid_run_reports_its_nodes_dead_and_leaves_nothing() {
    let dir = TempDir::new("zenoh-kill");
    let ep = endpoint();
    let id = run_id("kill");
    let Spread {
        coordinator,
        a,
        mut b,
    } = Spread::long(dir.path(), &ep, &id);
    // Once b runs its three nodes, and they have worked a little.
    wait_for_nodes(&[&b], 3);
    std::thread::sleep(Duration::from_millis(500));
    b.kill().expect("SIGKILL agent b");
    let killed = Instant::now();
    let _ = b.wait();
    let out = wait_watchdog(coordinator, "the coordinator", LIMIT);
    let noticed = killed.elapsed();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("died") && stderr.contains("host b"),
        "the death names the host: {stderr}"
    );
    assert!(
        noticed < Duration::from_secs(5),
        "the run ended {noticed:?} after the kill"
    );
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("run.json")).unwrap())
            .unwrap();
    assert_eq!(run["status"], "failed");
    assert!(
        dir.path().join("track.csv").exists(),
        "partial results written"
    );
    let o = wait_watchdog(a, "agent a", LIMIT);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_nothing_left(&id);
}

#[test]
fn a_missing_agent_is_named_and_the_coordinator_gives_up_in_bounded_time() {
    let dir = TempDir::new("zenoh-missing");
    let ep = endpoint();
    let id = run_id("missing");
    let coordinator = start_run(
        &scenario("mourya2017-spiral.toml"),
        dir.path(),
        &ep,
        &id,
        &["--agent-wait", "1.5"],
    );
    let a = start_agent(&ep, &id, "a");
    let out = wait_watchdog(coordinator, "the coordinator", LIMIT);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("no agent connected for host(s) b") && stderr.contains(&id),
        "{stderr}"
    );
    // Agent a saw its coordinator come and go.
    let o = wait_watchdog(a, "agent a", LIMIT);
    assert!(!o.status.success());
    assert_nothing_left(&id);
}

#[test]
fn an_agent_with_the_wrong_run_id_is_not_admitted() {
    let dir = TempDir::new("zenoh-wrong");
    let ep = endpoint();
    let id = run_id("right");
    let coordinator = start_placed(
        &scenario("mourya2017-spiral.toml"),
        dir.path(),
        &ep,
        &id,
        &["a=0-5"],
        &["--agent-wait", "2"],
    );
    let intruder = spawn_sonarnet(&agent_args(&ep, "zt-guessed", "a", "3", fleet_key()));
    let out = wait_watchdog(coordinator, "the coordinator", LIMIT);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no agent connected for host(s) a"));
    let o = wait_watchdog(intruder, "the intruder", LIMIT);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("no coordinator of run zt-guessed"),
        "{stderr}"
    );
    assert_nothing_left(&id);
}

#[test]
fn an_agent_without_the_fleet_key_is_refused_and_named_while_the_run_goes_on() {
    let dir = TempDir::new("zenoh-stranger");
    let ep = endpoint();
    let id = run_id("stranger");
    let other_key = dir.path().join("other.key");
    sonarnet::transport::credentials::write_fleet_key(&other_key).expect("a second key");
    let coordinator = start_run(
        &scenario("mourya2017-spiral.toml"),
        &dir.path().join("out"),
        &ep,
        &id,
        &[],
    );
    // A stranger that knows the endpoint, the run id and a host name, but
    // holds another fleet's key, tries for 4 s before the real agents come.
    let other = other_key.to_str().expect("utf-8");
    let stranger = spawn_sonarnet(&agent_args(&ep, &id, "a", "4", other));
    let o = wait_watchdog(stranger, "the stranger", LIMIT);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        stderr.contains(&format!("no coordinator of run {id} admitted this agent"))
            && stderr.contains("--fleet-key"),
        "{stderr}"
    );
    let a = start_agent(&ep, &id, "a");
    let b = start_agent(&ep, &id, "b");
    let out = wait_watchdog(coordinator, "the coordinator", LIMIT);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning: refused a zenoh peer with a wrong password for its user"),
        "{stderr}"
    );
    agents_end_cleanly(a, b);
    assert_nothing_left(&id);
}

#[test]
fn a_run_on_agents_needs_a_private_fleet_key_and_fleet_key_makes_one() {
    let spiral = scenario("mourya2017-spiral.toml");
    let dir = TempDir::new("zenoh-keys");
    let placed = ["--transport", "zenoh", "--place", "a=0-5"];
    let out = run_file(&spiral, dir.path(), &placed, LIMIT);
    assert_eq!(out.status.code(), Some(2));
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(
        e.contains("--fleet-key") && e.contains("agents of a") && e.contains("sonarnet fleet-key"),
        "{e}"
    );
    let key = dir.path().join("fleet.key");
    let key_s = key.to_str().expect("utf-8");
    let made = sonarnet(&["fleet-key", key_s], LIMIT);
    assert!(made.status.success(), "{made:?}");
    let again = sonarnet(&["fleet-key", key_s], LIMIT);
    assert_eq!(again.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&again.stderr).contains("never overwritten"));
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&key, std::fs::Permissions::from_mode(0o640)).expect("chmod");
    let mut args = placed.to_vec();
    args.extend(["--fleet-key", key_s]);
    let out = run_file(&spiral, dir.path(), &args, LIMIT);
    assert_eq!(out.status.code(), Some(2));
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("readable by others (mode 640)"), "{e}");
    let agent = sonarnet(
        &[
            "agent",
            "--connect",
            "tcp/127.0.0.1:1",
            "--run-id",
            "r",
            "--host",
            "a",
            "--fleet-key",
            key_s,
        ],
        LIMIT,
    );
    assert_eq!(agent.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&agent.stderr).contains("chmod 600"));
}

#[test]
fn local_nodes_over_zenoh_give_the_inprocess_numbers_and_leave_nothing() {
    let spiral = scenario("mourya2017-spiral.toml");
    let reference = TempDir::new("zenoh-local-ref");
    let out = run_file(
        &spiral,
        reference.path(),
        &["--engine", "inprocess", "--quiet"],
        LIMIT,
    );
    assert!(out.status.success());
    let dir = TempDir::new("zenoh-local");
    let out = run_file(
        &spiral,
        dir.path(),
        &["--transport", "zenoh", "--quiet"],
        LIMIT,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    same_file(reference.path(), dir.path(), "track.csv");
    let id = run_id_of(dir.path());
    assert!(id.len() > 17, "a secret run id: {id}");
    assert_nothing_left(&id);
}

#[test]
fn the_acoustic_channel_runs_over_zenoh_as_over_shared_memory() {
    let _cpu = cpu_exclusive();
    let dir = TempDir::new("zenoh-acoustic");
    let out = run_file(
        &scenario("mourya2017-spiral-acoustic.toml"),
        dir.path(),
        &[
            "--transport",
            "zenoh",
            "--variant",
            "delay",
            "--samples",
            "12",
            "--quiet",
        ],
        LIMIT,
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("run.json")).unwrap())
            .unwrap();
    assert_eq!(run["engine"], "processes");
    assert_eq!(run["transport"], "zenoh");
    let messages = read_rows(&dir.path().join("messages.csv"));
    assert!(!messages.is_empty(), "the water recorded its messages");
    // The coordinator delivers the water's frames in their senders' names:
    // no node took one for an impostor's.
    let m = metrics(dir.path());
    for i in 0..6 {
        assert!(
            m["nodes"][i].get("bad_frames").is_none(),
            "node {i}: {}",
            m["nodes"][i]
        );
    }
    assert_nothing_left(&run_id_of(dir.path()));
}

#[test]
fn zenoh_flags_are_refused_without_zenoh_and_a_bad_placement_is_named() {
    let spiral = scenario("mourya2017-spiral.toml");
    let dir = TempDir::new("zenoh-flags");
    let out = run_file(&spiral, dir.path(), &["--listen", "tcp/127.0.0.1:1"], LIMIT);
    assert_eq!(out.status.code(), Some(2));
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(
        e.contains("--listen") && e.contains("--transport zenoh"),
        "{e}"
    );
    let out = run_file(
        &spiral,
        dir.path(),
        &[
            "--transport",
            "zenoh",
            "--place",
            "a=0-2",
            "--place",
            "b=2-5",
        ],
        LIMIT,
    );
    assert_eq!(out.status.code(), Some(2));
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("--place") && e.contains("node 2"), "{e}");
    let out = run_file(
        &spiral,
        dir.path(),
        &["--transport", "zenoh", "--engine", "inprocess"],
        LIMIT,
    );
    assert_eq!(out.status.code(), Some(2));
}

/// One agent in its own network namespace, joined to this one by a veth
/// pair: its nodes reach the coordinator only over TCP across the pair.
/// Needs root and iproute2; says so and passes where they are missing.
#[test]
fn an_agent_in_its_own_network_namespace_joins_over_a_veth_pair() {
    let ns = format!("sn{}", std::process::id());
    let ip = |args: &[&str]| {
        std::process::Command::new("ip")
            .args(args)
            .output()
            .map(|o| o.status.success())
            .unwrap_or(false)
    };
    if !ip(&["netns", "add", &ns]) {
        eprintln!("skipped: cannot create a network namespace here (needs root and iproute2)");
        return;
    }
    struct Cleanup(String);
    impl Drop for Cleanup {
        fn drop(&mut self) {
            let _ = std::process::Command::new("ip")
                .args(["link", "del", &format!("{}h", self.0)])
                .output();
            let _ = std::process::Command::new("ip")
                .args(["netns", "del", &self.0])
                .output();
        }
    }
    let _cleanup = Cleanup(ns.clone());
    let (host_if, ns_if) = (format!("{ns}h"), format!("{ns}n"));
    // A /30 per test process, from the benchmarking range 198.18.0.0/15.
    let octet = 4 * (std::process::id() % 60) + 4;
    let (host_ip, ns_ip) = (
        format!("198.18.0.{}", octet + 1),
        format!("198.18.0.{}", octet + 2),
    );
    for step in [
        vec![
            "link", "add", &host_if, "type", "veth", "peer", "name", &ns_if,
        ],
        vec!["link", "set", &ns_if, "netns", &ns],
        vec!["addr", "add", &format!("{host_ip}/30"), "dev", &host_if],
        vec!["link", "set", &host_if, "up"],
        vec![
            "-n",
            &ns,
            "addr",
            "add",
            &format!("{ns_ip}/30"),
            "dev",
            &ns_if,
        ],
        vec!["-n", &ns, "link", "set", &ns_if, "up"],
        vec!["-n", &ns, "link", "set", "lo", "up"],
    ] {
        assert!(ip(&step), "ip {}", step.join(" "));
    }
    let port = endpoint().rsplit(':').next().unwrap().to_string();
    let ep = format!("tcp/{host_ip}:{port}");
    let id = run_id("netns");
    let spiral = scenario("mourya2017-spiral.toml");
    let reference = TempDir::new("zenoh-netns-ref");
    let out = run_file(
        &spiral,
        reference.path(),
        &["--engine", "inprocess", "--quiet"],
        LIMIT,
    );
    assert!(out.status.success());
    let dir = TempDir::new("zenoh-netns");
    let coordinator = start_run(&spiral, dir.path(), &ep, &id, &[]);
    let a = start_agent(&ep, &id, "a");
    let b = std::process::Command::new("ip")
        .args(["netns", "exec", &ns, env!("CARGO_BIN_EXE_sonarnet")])
        .args(agent_args(&ep, &id, "b", "60", fleet_key()))
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("start agent b in the namespace");
    let out = wait_watchdog(coordinator, "the coordinator", LIMIT);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for (agent, name) in [(a, "a"), (b, "b")] {
        let o = wait_watchdog(agent, name, LIMIT);
        assert!(
            o.status.success(),
            "agent {name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    same_file(reference.path(), dir.path(), "track.csv");
    assert_nothing_left(&id);
}

#[test]
fn killing_the_coordinator_makes_every_agent_stop_its_nodes_and_exit() {
    let dir = TempDir::new("zenoh-kill-coordinator");
    let ep = endpoint();
    let id = run_id("killc");
    let Spread {
        mut coordinator,
        a,
        b,
    } = Spread::long(dir.path(), &ep, &id);
    wait_for_nodes(&[&a, &b], 3);
    std::thread::sleep(Duration::from_millis(300));
    coordinator.kill().expect("SIGKILL the coordinator");
    let _ = coordinator.wait();
    for (agent, name) in [(a, "a"), (b, "b")] {
        let o = wait_watchdog(agent, name, LIMIT);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "agent {name}: {stderr}");
        assert!(stderr.contains("went away"), "agent {name}: {stderr}");
    }
    assert_nothing_left(&id);
}

#[test]
fn ctrl_c_of_the_coordinator_stops_every_host_and_writes_partial_results() {
    let dir = TempDir::new("zenoh-sigint");
    let ep = endpoint();
    let id = run_id("sigint");
    let Spread { coordinator, a, b } = Spread::long(dir.path(), &ep, &id);
    wait_for_nodes(&[&a, &b], 3);
    wait_for_sigint_handler(coordinator.id(), LIMIT);
    std::thread::sleep(Duration::from_millis(300));
    // SAFETY: kill(2) on our own child.
    unsafe {
        libc::kill(coordinator.id() as i32, libc::SIGINT);
    }
    let out = wait_watchdog(coordinator, "the coordinator", LIMIT);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("interrupted"), "{stderr}");
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("run.json")).unwrap())
            .unwrap();
    assert_eq!(run["status"], "interrupted");
    // What was produced is written (how many samples depends on the load).
    assert!(dir.path().join("track.csv").exists(), "partial track");
    agents_end_cleanly(a, b);
    assert_nothing_left(&id);
}

#[test]
fn a_crash_fault_on_an_agents_host_is_a_real_signal_there_and_the_run_goes_on() {
    let _cpu = cpu_exclusive();
    let dir = TempDir::new("zenoh-fault");
    let ep = endpoint();
    let id = run_id("fault");
    let out = Spread::start(
        &scenario("mourya2017-spiral.toml"),
        dir.path(),
        &ep,
        &id,
        &[
            "--clock",
            "realtime",
            "--samples",
            "40",
            "--fault",
            "crash:node=4,at_sample=15",
        ],
        &[],
    )
    .finish();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let m = metrics(dir.path());
    let deaths = m["deaths"].to_string();
    assert!(
        deaths.contains('4') && deaths.contains("host b"),
        "{deaths}"
    );
    assert_nothing_left(&id);
}

/// The test certificates of `tests/fixtures/tls`, in a zenoh configuration
/// file written to `dir`: the CA, plus the server's key and certificate
/// when `server`.
#[cfg(feature = "zenoh-tls")]
fn tls_config(dir: &Path, server: bool) -> std::path::PathBuf {
    let fixture = |name: &str| {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fixtures/tls")
            .join(name)
    };
    let (key, cert) = (fixture("server.key"), fixture("server.pem"));
    let text = sonarnet::transport::zenoh::config::tls_link_config(
        &fixture("ca.pem"),
        server.then_some((key.as_path(), cert.as_path())),
    );
    let path = dir.join(if server {
        "server.json5"
    } else {
        "client.json5"
    });
    std::fs::write(&path, text).expect("write the zenoh configuration");
    path
}

/// QUIC (TLS 1.3) between the coordinator and two agents, each trusting the
/// run's CA: the same numbers as in-process, sync and async.
#[cfg(feature = "zenoh-tls")]
#[test]
fn an_encrypted_quic_run_over_two_agents_equals_the_inprocess_engine() {
    let spiral = scenario("mourya2017-spiral.toml");
    let keys = TempDir::new("zenoh-quic-keys");
    let server = tls_config(keys.path(), true);
    let client = tls_config(keys.path(), false);
    for mode in ["async", "sync"] {
        let reference = TempDir::new("zenoh-quic-ref");
        let out = run_file(
            &spiral,
            reference.path(),
            &["--engine", "inprocess", "--mode", mode, "--quiet"],
            LIMIT,
        );
        assert!(out.status.success());
        let dir = TempDir::new("zenoh-quic");
        let port = endpoint().rsplit(':').next().unwrap_or("0").to_string();
        let ep = format!("quic/127.0.0.1:{port}");
        let id = run_id(&format!("quic-{mode}"));
        let out = Spread::start(
            &spiral,
            dir.path(),
            &ep,
            &id,
            &[
                "--mode",
                mode,
                "--zenoh-config",
                server.to_str().expect("utf-8"),
            ],
            &["--zenoh-config", client.to_str().expect("utf-8")],
        )
        .finish();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        for f in ["track.csv", "nodes.csv"] {
            same_file(reference.path(), dir.path(), f);
        }
        assert_nothing_left(&id);
    }
}

/// Over `tls/`, zenoh 1.10 loses frames (zenoh issue 2557): the run is
/// warned; a link this build lacks, or a malformed endpoint, is refused.
#[test]
fn endpoints_are_checked_before_the_run_and_the_tls_link_is_warned_of() {
    let spiral = scenario("mourya2017-spiral.toml");
    let dir = TempDir::new("zenoh-endpoints");
    for (ep, says) in [
        ("udp/127.0.0.1:7447", "link \"udp\""),
        ("127.0.0.1:7447", "PROTO/HOST:PORT"),
        ("tcp/127.0.0.1", "no port"),
    ] {
        let out = run_file(
            &spiral,
            dir.path(),
            &["--transport", "zenoh", "--listen", ep],
            LIMIT,
        );
        let e = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{ep}: {e}");
        assert!(e.contains("--listen") && e.contains(says), "{ep}: {e}");
    }
    let out = run_file(
        &spiral,
        dir.path(),
        &[
            "--transport",
            "zenoh",
            "--listen",
            "quic/127.0.0.1:7447",
            "--engine",
            "inprocess",
        ],
        LIMIT,
    );
    let e = String::from_utf8_lossy(&out.stderr);
    if cfg!(feature = "zenoh-tls") {
        let tls = run_file(
            &spiral,
            dir.path(),
            &[
                "--transport",
                "zenoh",
                "--listen",
                "tls/127.0.0.1:7447",
                "--engine",
                "inprocess",
            ],
            LIMIT,
        );
        let w = String::from_utf8_lossy(&tls.stderr);
        assert!(w.contains("zenoh issue 2557") && w.contains("quic/"), "{w}");
        // Past the endpoints, the next check speaks: this engine has no links.
        assert_eq!(tls.status.code(), Some(2), "{w}");
        assert!(e.contains("--engine processes"), "quic is carried: {e}");
    } else {
        assert_eq!(out.status.code(), Some(2), "{e}");
        assert!(e.contains("--features zenoh-tls"), "{e}");
    }
}

/// `RUST_LOG` turns zenoh's own log on, in the coordinator and in the nodes,
/// on standard error: standard output keeps the run's summary alone.
#[test]
fn zenohs_log_goes_to_standard_error_and_leaves_the_summary_alone() {
    let dir = TempDir::new("zenoh-log");
    let spiral = scenario("mourya2017-spiral.toml");
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_sonarnet"))
        .args([
            "run",
            spiral.to_str().expect("utf-8"),
            "--out",
            dir.path().to_str().expect("utf-8"),
            "--transport",
            "zenoh",
            "--samples",
            "12",
        ])
        .env("RUST_LOG", "zenoh=info")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn sonarnet");
    let out = wait_watchdog(child, "the run", LIMIT);
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(out.status.success(), "{stderr}");
    // The coordinator's session and the six nodes' each say their ZID.
    assert!(
        stderr.matches("Using ZID").count() >= 7,
        "zenoh's log on standard error:\n{stderr}"
    );
    assert!(!stdout.contains("ZID"), "standard output:\n{stdout}");
    assert!(stdout.contains("rmse"), "the summary:\n{stdout}");
    assert_nothing_left(&run_id_of(dir.path()));
}
