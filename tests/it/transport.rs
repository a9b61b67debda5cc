//! Multi-process tests of the iceoryx2 transport.
//!
//! Node processes are this test binary re-executed with the ignored test
//! `child_entry` selected and the role passed in the `SONARNET_TRANSPORT_CHILD`
//! environment variable. Every wait has a deadline and fails with a message; child
//! processes are killed and reaped by [`Children`] even when a test panics.

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use sonarnet::transport::wire::{COORDINATOR_ID, Frame};
use sonarnet::transport::{
    Endpoint, IoxTransport, RunTopology, Transport, TransportError, cleanup_stale_resources,
    run_resources, unique_run_id,
};

const CHILD_ENV: &str = "SONARNET_TRANSPORT_CHILD";
const READY: &str = "SONARNET_CHILD_READY";

const DATA: u32 = 1;
const DONE: u32 = 2;
const QUIT: u32 = 3;
const PING: u32 = 4;

/// Generous bound for any single multi-process exchange (the machine may be loaded).
const WATCHDOG: Duration = Duration::from_secs(120);

fn frame(kind: u32, from: u32, seq: u64) -> Frame {
    Frame {
        kind,
        from,
        seq,
        ..Frame::default()
    }
}

// ---------------------------------------------------------------- child processes

/// Key/value description of what a child process does.
#[derive(Debug, Clone)]
struct Role(BTreeMap<String, String>);

impl Role {
    fn new(kind: &str, topo: &TopoSpec) -> Self {
        let mut m = BTreeMap::new();
        m.insert("role".to_string(), kind.to_string());
        m.insert("run".to_string(), topo.run_id.clone());
        m.insert("n".to_string(), topo.n.to_string());
        m.insert("buf".to_string(), topo.buffer.to_string());
        m.insert("bcast".to_string(), topo.broadcast_buffer.to_string());
        Role(m)
    }
    fn with(mut self, k: &str, v: impl ToString) -> Self {
        self.0.insert(k.to_string(), v.to_string());
        self
    }
    fn encode(&self) -> String {
        self.0
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(" ")
    }
    fn decode(s: &str) -> Self {
        Role(
            s.split_whitespace()
                .filter_map(|kv| kv.split_once('='))
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect(),
        )
    }
    fn get(&self, k: &str) -> &str {
        self.0
            .get(k)
            .unwrap_or_else(|| panic!("child role lacks {k}: {:?}", self.0))
    }
    fn num(&self, k: &str) -> u64 {
        self.get(k).parse().unwrap_or_else(|e| panic!("{k}: {e}"))
    }
}

/// Enough to rebuild the same [`RunTopology`] (a ring) in every process.
#[derive(Debug, Clone)]
struct TopoSpec {
    run_id: String,
    n: usize,
    buffer: usize,
    broadcast_buffer: usize,
}

impl TopoSpec {
    fn ring(n: usize, buffer: usize) -> Self {
        TopoSpec {
            run_id: unique_run_id(),
            n,
            buffer,
            broadcast_buffer: 0,
        }
    }
    fn with_broadcast(mut self, b: usize) -> Self {
        self.broadcast_buffer = b;
        self
    }
    fn topology(&self) -> RunTopology {
        let t = RunTopology::ring(self.run_id.clone(), self.n, self.buffer)
            .expect("valid ring")
            .with_send_timeout(Duration::from_secs(60));
        if self.broadcast_buffer > 0 {
            t.with_broadcast(self.broadcast_buffer).expect("valid")
        } else {
            t
        }
    }
    fn from_role(r: &Role) -> Self {
        TopoSpec {
            run_id: r.get("run").to_string(),
            n: r.num("n") as usize,
            buffer: r.num("buf") as usize,
            broadcast_buffer: r.num("bcast") as usize,
        }
    }
}

/// Spawned children; killed (SIGKILL) and reaped on drop unless already reaped.
struct Children(Vec<(String, Child)>);

impl Children {
    fn new() -> Self {
        Children(Vec::new())
    }

    fn spawn(&mut self, role: &Role, capture_stdout: bool) -> usize {
        let exe = std::env::current_exe().expect("test binary path");
        let child = Command::new(exe)
            .args([
                "transport::child_entry",
                "--exact",
                "--ignored",
                "--nocapture",
                "--test-threads=1",
                "-q",
            ])
            .env(CHILD_ENV, role.encode())
            .stdin(Stdio::null())
            .stdout(if capture_stdout {
                Stdio::piped()
            } else {
                Stdio::null()
            })
            .stderr(Stdio::inherit())
            .spawn()
            .expect("spawn child test process");
        self.0.push((role.encode(), child));
        self.0.len() - 1
    }

    /// Waits until child `k` prints the READY line.
    fn wait_ready(&mut self, k: usize, timeout: Duration) {
        let (desc, child) = &mut self.0[k];
        let stdout = child.stdout.take().expect("stdout was piped");
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            // keep draining after READY so the child never writes to a closed pipe
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                if line.trim() == READY {
                    let _ = tx.send(());
                }
            }
        });
        if rx.recv_timeout(timeout).is_err() {
            panic!("child [{desc}] did not report ready within {timeout:?}");
        }
    }

    /// Waits for every child to exit successfully, each within `timeout` of the call.
    fn wait_all_ok(&mut self, timeout: Duration) {
        let deadline = Instant::now() + timeout;
        for (desc, child) in &mut self.0 {
            let status = wait_with_deadline(child, deadline)
                .unwrap_or_else(|| panic!("child [{desc}] still running after {timeout:?}"));
            assert!(status.success(), "child [{desc}] failed: {status}");
        }
        self.0.clear();
    }

    /// SIGKILLs child `k` and reaps it.
    fn kill(&mut self, k: usize) {
        let (_, mut child) = self.0.remove(k);
        child.kill().expect("SIGKILL child");
        child.wait().expect("reap child");
    }
}

impl Drop for Children {
    fn drop(&mut self) {
        for (_, child) in &mut self.0 {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

fn wait_with_deadline(child: &mut Child, deadline: Instant) -> Option<ExitStatus> {
    loop {
        if let Ok(Some(status)) = child.try_wait() {
            return Some(status);
        }
        if Instant::now() >= deadline {
            return None;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Receives until `done(&all_frames_so_far)` holds, failing after `timeout`.
fn recv_until(
    t: &mut impl Transport,
    out: &mut Vec<Frame>,
    timeout: Duration,
    what: &str,
    mut done: impl FnMut(&[Frame]) -> bool,
) {
    let deadline = Instant::now() + timeout;
    while !done(out) {
        let now = Instant::now();
        assert!(
            now < deadline,
            "{:?}: timed out after {timeout:?} waiting for {what}; have {} frames",
            t.endpoint(),
            out.len()
        );
        let step = (deadline - now).min(Duration::from_secs(1));
        t.recv(out, Some(step))
            .unwrap_or_else(|e| panic!("{:?}: recv failed: {e}", t.endpoint()));
    }
}

/// Checks that the DATA frames from each sender carry seq 0, 1, 2, ... in order and
/// returns how many each sender delivered.
fn check_in_order(frames: &[Frame]) -> BTreeMap<u32, u64> {
    let mut next: BTreeMap<u32, u64> = BTreeMap::new();
    for f in frames.iter().filter(|f| f.kind == DATA) {
        let n = next.entry(f.from).or_insert(0);
        assert_eq!(f.seq, *n, "frame from {} out of order or lost", f.from);
        *n += 1;
    }
    next
}

fn count_data(frames: &[Frame], from: u32) -> u64 {
    frames
        .iter()
        .filter(|f| f.kind == DATA && f.from == from)
        .count() as u64
}

fn wait_for_quit(t: &mut IoxTransport) {
    let mut out = Vec::new();
    recv_until(t, &mut out, WATCHDOG, "QUIT", |fs| {
        fs.iter().any(|f| f.kind == QUIT)
    });
}

/// Ring node: sends `burst` DATA frames to every neighbour and the coordinator with a
/// single flush at the end, receives `burst` from each of them in order, reports DONE.
fn child_ring_node(role: &Role) {
    let spec = TopoSpec::from_role(role);
    let topo = spec.topology();
    let id = role.num("id") as u32;
    let burst = role.num("burst");
    let mut t = IoxTransport::node(&topo, id).unwrap_or_else(|e| panic!("node {id}: {e}"));
    let mut targets: Vec<Endpoint> = topo
        .neighbours(id)
        .iter()
        .map(|&j| Endpoint::Node(j))
        .collect();
    targets.push(Endpoint::Coordinator);
    for s in 0..burst {
        for &to in &targets {
            t.send(to, &frame(DATA, id, s))
                .unwrap_or_else(|e| panic!("node {id}: send {s} to {to}: {e}"));
        }
    }
    t.flush().unwrap();
    let mut senders: Vec<u32> = topo.in_neighbours(id).to_vec();
    senders.push(COORDINATOR_ID);
    let mut got = Vec::new();
    recv_until(&mut t, &mut got, WATCHDOG, "all bursts", |fs| {
        senders.iter().all(|&s| count_data(fs, s) >= burst)
    });
    let counts = check_in_order(&got);
    for s in &senders {
        assert_eq!(counts.get(s), Some(&burst), "node {id}: frames from {s}");
    }
    let received: u64 = counts.values().sum();
    let mut done = frame(DONE, id, 0);
    done.aux = received as u32;
    t.send(Endpoint::Coordinator, &done).unwrap();
    t.flush().unwrap();
    wait_for_quit(&mut t);
}

/// Broadcast member: `rounds` lock-step rounds; in each it broadcasts one frame and
/// waits until it holds that round's frame from every member (itself included).
fn child_broadcast_node(role: &Role) {
    let spec = TopoSpec::from_role(role);
    let topo = spec.topology();
    let id = role.num("id") as u32;
    let rounds = role.num("rounds");
    let n = topo.n_nodes();
    let mut t = IoxTransport::node(&topo, id).unwrap_or_else(|e| panic!("node {id}: {e}"));
    let mut got: Vec<Frame> = Vec::new();
    for r in 0..rounds {
        t.broadcast(&frame(DATA, id, r))
            .unwrap_or_else(|e| panic!("node {id} round {r}: {e}"));
        t.flush().unwrap();
        recv_until(&mut t, &mut got, WATCHDOG, "a full round", |fs| {
            fs.iter().filter(|f| f.kind == DATA && f.seq == r).count() >= n
        });
        let mut from: Vec<u32> = got
            .iter()
            .filter(|f| f.kind == DATA && f.seq == r)
            .map(|f| f.from)
            .collect();
        from.sort_unstable();
        assert_eq!(
            from,
            (0..n as u32).collect::<Vec<_>>(),
            "node {id} round {r}: one frame from every member"
        );
    }
    check_in_order(&got);
    let mut done = frame(DONE, id, 0);
    done.aux = rounds as u32;
    t.send(Endpoint::Coordinator, &done).unwrap();
    t.flush().unwrap();
    wait_for_quit(&mut t);
}

/// Opens the coordinator and every node of a run, reports READY, then sleeps until
/// killed (or a minute passes).
fn child_hold_run(role: &Role) {
    let topo = TopoSpec::from_role(role).topology();
    let _c = IoxTransport::coordinator(&topo).unwrap();
    let _nodes: Vec<IoxTransport> = (0..topo.n_nodes() as u32)
        .map(|i| IoxTransport::node(&topo, i).unwrap())
        .collect();
    println!("{READY}");
    std::thread::sleep(Duration::from_secs(60));
}

/// Opens node `id`, reports READY, waits for QUIT.
fn child_idle_node(role: &Role) {
    let topo = TopoSpec::from_role(role).topology();
    let id = role.num("id") as u32;
    let mut t = IoxTransport::node(&topo, id).unwrap_or_else(|e| panic!("node {id}: {e}"));
    println!("{READY}");
    wait_for_quit(&mut t);
}

/// Sends `count` DATA frames to the coordinator, reports READY and exits at once,
/// either by dropping the transport (`mode=drop`) or after `shutdown` (`mode=shutdown`).
fn child_send_and_exit(role: &Role) {
    let topo = TopoSpec::from_role(role).topology();
    let mut t = IoxTransport::node(&topo, 0).unwrap();
    for s in 0..role.num("count") {
        t.send(Endpoint::Coordinator, &frame(DATA, 0, s)).unwrap();
    }
    t.flush().unwrap();
    println!("{READY}");
    if role.get("mode") == "shutdown" {
        t.shutdown(WATCHDOG)
            .unwrap_or_else(|e| panic!("shutdown: {e}"));
    }
}

/// Echoes every frame back to the coordinator until QUIT.
fn child_echo(role: &Role) {
    let topo = TopoSpec::from_role(role).topology();
    let mut t = IoxTransport::node(&topo, 0).unwrap();
    let mut buf = Vec::new();
    loop {
        buf.clear();
        t.recv(&mut buf, Some(WATCHDOG)).unwrap();
        assert!(
            !buf.is_empty(),
            "echo child: nothing received for {WATCHDOG:?}"
        );
        for f in &buf {
            if f.kind == QUIT {
                return;
            }
            t.send(Endpoint::Coordinator, f).unwrap();
        }
        t.flush().unwrap();
    }
}

#[test]
#[ignore = "child-process entry point of the multi-process tests; does nothing when run directly"]
fn child_entry() {
    let Ok(spec) = std::env::var(CHILD_ENV) else {
        return;
    };
    let role = Role::decode(&spec);
    match role.get("role") {
        "ring-node" => child_ring_node(&role),
        "broadcast-node" => child_broadcast_node(&role),
        "hold" => child_hold_run(&role),
        "echo" => child_echo(&role),
        "idle-node" => child_idle_node(&role),
        "send-and-exit" => child_send_and_exit(&role),
        other => panic!("unknown child role {other}"),
    }
}

fn assert_no_leftovers(run_id: &str) {
    let left = run_resources(run_id);
    assert!(
        left.is_empty(),
        "run {run_id} left IPC resources behind: {left:#?}"
    );
}

// ---------------------------------------------------------------- tests

#[test]
fn coordinator_and_three_ring_nodes_exchange_bursts_in_order_without_loss() {
    const BURST: u64 = 300; // far more than the inbox buffer and than one wake-up
    let spec = TopoSpec::ring(3, 4);
    let topo = spec.topology();
    {
        let mut c = IoxTransport::coordinator(&topo).unwrap();
        let mut kids = Children::new();
        for i in 0..3 {
            kids.spawn(
                &Role::new("ring-node", &spec)
                    .with("id", i)
                    .with("burst", BURST),
                false,
            );
        }
        // Sends wait for the nodes to come up and to drain; meanwhile our own inbox
        // fills with their bursts and is stashed.
        for s in 0..BURST {
            for i in 0..3 {
                c.send(Endpoint::Node(i), &frame(DATA, COORDINATOR_ID, s))
                    .unwrap_or_else(|e| panic!("coordinator send {s} to node {i}: {e}"));
            }
        }
        c.flush().unwrap();
        let mut got = Vec::new();
        recv_until(&mut c, &mut got, WATCHDOG, "bursts and DONEs", |fs| {
            fs.iter().filter(|f| f.kind == DONE).count() == 3
        });
        let counts = check_in_order(&got);
        for i in 0..3u32 {
            assert_eq!(counts.get(&i), Some(&BURST), "frames from node {i}");
            let done = got
                .iter()
                .find(|f| f.kind == DONE && f.from == i)
                .expect("DONE");
            assert_eq!(done.aux as u64, 3 * BURST, "node {i} received everything");
        }
        for i in 0..3 {
            c.send(Endpoint::Node(i), &frame(QUIT, COORDINATOR_ID, 0))
                .unwrap();
        }
        c.flush().unwrap();
        kids.wait_all_ok(WATCHDOG);
    }
    assert_no_leftovers(topo.run_id());
}

#[test]
fn broadcast_group_delivers_every_members_frame_to_every_member_each_round() {
    const ROUNDS: u64 = 30;
    const N: usize = 4;
    let spec = TopoSpec::ring(N, 2).with_broadcast(2);
    let topo = spec.topology();
    {
        let mut c = IoxTransport::coordinator(&topo).unwrap();
        let mut kids = Children::new();
        for i in 0..N {
            kids.spawn(
                &Role::new("broadcast-node", &spec)
                    .with("id", i)
                    .with("rounds", ROUNDS),
                false,
            );
        }
        let mut got = Vec::new();
        recv_until(&mut c, &mut got, WATCHDOG, "DONE from every node", |fs| {
            fs.iter().filter(|f| f.kind == DONE).count() == N
        });
        for f in &got {
            assert_eq!(f.aux as u64, ROUNDS, "node {} finished every round", f.from);
        }
        assert!(matches!(
            c.broadcast(&frame(DATA, COORDINATOR_ID, 0)),
            Err(TransportError::BroadcastUnavailable(Endpoint::Coordinator))
        ));
        for i in 0..N as u32 {
            c.send(Endpoint::Node(i), &frame(QUIT, COORDINATOR_ID, 0))
                .unwrap();
        }
        c.flush().unwrap();
        kids.wait_all_ok(WATCHDOG);
    }
    assert_no_leftovers(topo.run_id());
}

#[test]
fn the_last_frames_of_an_exiting_process_reach_a_receiver_that_reads_late() {
    // The receiver has not looked at its inbox since the sender came up; without the
    // linger on drop / shutdown the frames would vanish with the sender's process.
    for mode in ["drop", "shutdown"] {
        let spec = TopoSpec::ring(1, 8);
        let topo = spec.topology();
        {
            let mut c = IoxTransport::coordinator(&topo).unwrap();
            let mut kids = Children::new();
            let k = kids.spawn(
                &Role::new("send-and-exit", &spec)
                    .with("count", 5)
                    .with("mode", mode),
                true,
            );
            kids.wait_ready(k, WATCHDOG);
            std::thread::sleep(Duration::from_millis(300));
            let mut got = Vec::new();
            recv_until(&mut c, &mut got, WATCHDOG, "5 frames", |fs| fs.len() >= 5);
            assert_eq!(check_in_order(&got).get(&0), Some(&5), "mode {mode}");
            kids.wait_all_ok(WATCHDOG);
        }
        assert_no_leftovers(topo.run_id());
    }
}

#[test]
fn two_concurrent_runs_with_different_ids_do_not_see_each_others_frames() {
    let a = TopoSpec::ring(2, 4).topology();
    let b = TopoSpec::ring(2, 4).topology();
    assert_ne!(a.run_id(), b.run_id());
    {
        let mut ca = IoxTransport::coordinator(&a).unwrap();
        let mut cb = IoxTransport::coordinator(&b).unwrap();
        let mut a0 = IoxTransport::node(&a, 0).unwrap();
        let mut b0 = IoxTransport::node(&b, 0).unwrap();
        let mut a1 = IoxTransport::node(&a, 1).unwrap();
        let mut b1 = IoxTransport::node(&b, 1).unwrap();
        let ra: Vec<PathBuf> = run_resources(a.run_id());
        let rb: Vec<PathBuf> = run_resources(b.run_id());
        assert!(!ra.is_empty() && !rb.is_empty());
        assert!(ra.iter().all(|p| !rb.contains(p)), "namespaces overlap");

        let tag = |mut f: Frame, run: u32| {
            f.aux = run;
            f
        };
        for s in 0..3 {
            a0.send(Endpoint::Coordinator, &tag(frame(DATA, 0, s), 0xA))
                .unwrap();
            b0.send(Endpoint::Coordinator, &tag(frame(DATA, 0, s), 0xB))
                .unwrap();
            ca.send(Endpoint::Node(1), &tag(frame(DATA, COORDINATOR_ID, s), 0xA))
                .unwrap();
            cb.send(Endpoint::Node(1), &tag(frame(DATA, COORDINATOR_ID, s), 0xB))
                .unwrap();
            a0.send(Endpoint::Node(1), &tag(frame(DATA, 0, s), 0xA))
                .unwrap();
            b0.send(Endpoint::Node(1), &tag(frame(DATA, 0, s), 0xB))
                .unwrap();
        }
        for t in [&mut ca, &mut cb, &mut a0, &mut b0] {
            t.flush().unwrap();
        }
        let cases: [(&mut IoxTransport, u32, usize); 4] = [
            (&mut ca, 0xA, 3),
            (&mut cb, 0xB, 3),
            (&mut a1, 0xA, 6),
            (&mut b1, 0xB, 6),
        ];
        for (t, run, expected) in cases {
            let mut got = Vec::new();
            recv_until(t, &mut got, WATCHDOG, "own run's frames", |fs| {
                fs.len() >= expected
            });
            // anything else would have arrived together with these; poll once more
            t.recv(&mut got, Some(Duration::from_millis(50))).unwrap();
            assert_eq!(got.len(), expected);
            assert!(
                got.iter().all(|f| f.aux == run),
                "{:?} of run {run:x} saw a foreign frame: {got:?}",
                t.endpoint()
            );
            check_in_order(&got);
        }
    }
    assert_no_leftovers(a.run_id());
    assert_no_leftovers(b.run_id());
}

/// CPU time of the calling thread in nanoseconds (Linux `/proc/thread-self/schedstat`).
fn thread_cpu_ns() -> u64 {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat")
        .expect("/proc/thread-self/schedstat (Linux)");
    s.split_whitespace()
        .next()
        .and_then(|v| v.parse().ok())
        .expect("schedstat format")
}

#[test]
fn recv_with_nothing_to_read_blocks_for_the_timeout_at_almost_no_cpu() {
    let topo = TopoSpec::ring(2, 4).with_broadcast(1).topology();
    let wait = Duration::from_millis(500);
    {
        let mut c = IoxTransport::coordinator(&topo).unwrap();
        let mut n0 = IoxTransport::node(&topo, 0).unwrap();
        let _n1 = IoxTransport::node(&topo, 1).unwrap();
        for t in [&mut c as &mut dyn Transport, &mut n0] {
            let mut out = Vec::new();
            let cpu0 = thread_cpu_ns();
            let t0 = Instant::now();
            let got = t.recv(&mut out, Some(wait)).unwrap();
            let wall = t0.elapsed();
            let cpu = Duration::from_nanos(thread_cpu_ns() - cpu0);
            assert_eq!(got, 0);
            assert!(out.is_empty());
            assert!(wall >= wait, "{:?} returned after {wall:?}", t.endpoint());
            assert!(
                wall < wait + Duration::from_secs(10),
                "{:?} overslept: {wall:?}",
                t.endpoint()
            );
            assert!(
                cpu < Duration::from_millis(50),
                "{:?} burnt {cpu:?} CPU while waiting {wall:?}",
                t.endpoint()
            );
        }
    }
    assert_no_leftovers(topo.run_id());
}

#[test]
fn stale_resources_of_a_killed_run_are_removed_by_cleanup_and_live_runs_are_kept() {
    let dead = TopoSpec::ring(2, 4).with_broadcast(1);
    let live = TopoSpec::ring(2, 4).topology();
    let mut kids = Children::new();
    let k = kids.spawn(&Role::new("hold", &dead), true);
    kids.wait_ready(k, WATCHDOG);
    let before = run_resources(&dead.run_id);
    assert!(!before.is_empty(), "the child created nothing?");
    kids.kill(k);
    assert_eq!(
        run_resources(&dead.run_id),
        before,
        "SIGKILL should leave the files behind"
    );

    let mut c = IoxTransport::coordinator(&live).unwrap();
    let mut n1 = IoxTransport::node(&live, 1).unwrap();
    let live_before = run_resources(live.run_id());

    let report = cleanup_stale_resources().unwrap();
    assert!(
        report.dead_nodes_removed >= 3,
        "coordinator + 2 nodes were dead: {report:?}"
    );
    assert!(report.runs_alive >= 1, "{report:?}");
    assert_no_leftovers(&dead.run_id);
    assert_eq!(
        run_resources(live.run_id()),
        live_before,
        "live run touched"
    );

    // the live run still works
    c.send(Endpoint::Node(1), &frame(DATA, COORDINATOR_ID, 0))
        .unwrap();
    c.flush().unwrap();
    let mut got = Vec::new();
    recv_until(&mut n1, &mut got, WATCHDOG, "a frame", |fs| !fs.is_empty());
    drop(n1);
    drop(c);
    assert_no_leftovers(live.run_id());
}

#[test]
fn a_64_node_ring_can_be_created_and_used_from_one_process() {
    const N: usize = 64;
    let topo = TopoSpec::ring(N, 2).topology();
    {
        let mut c = IoxTransport::coordinator(&topo).unwrap();
        // Each node inbox, the coordinator's inbox and wake-up, the shared down service.
        assert_eq!(c.open_services(), N + 3);
        let mut nodes: Vec<IoxTransport> = (0..N as u32)
            .map(|i| IoxTransport::node(&topo, i).unwrap_or_else(|e| panic!("node {i}: {e}")))
            .collect();
        for (i, t) in nodes.iter_mut().enumerate() {
            let i = i as u32;
            t.send(Endpoint::Node((i + 1) % N as u32), &frame(DATA, i, 0))
                .unwrap();
            t.send(Endpoint::Coordinator, &frame(DATA, i, 0)).unwrap();
            t.flush().unwrap();
        }
        for (i, t) in nodes.iter_mut().enumerate() {
            let mut got = Vec::new();
            recv_until(t, &mut got, WATCHDOG, "left neighbour's frame", |fs| {
                !fs.is_empty()
            });
            assert_eq!(got, vec![frame(DATA, ((i + N - 1) % N) as u32, 0)]);
        }
        let mut got = Vec::new();
        recv_until(
            &mut c,
            &mut got,
            WATCHDOG,
            "a frame from every node",
            |fs| fs.len() >= N,
        );
        let counts = check_in_order(&got);
        assert_eq!(counts.len(), N);
    }
    assert_no_leftovers(topo.run_id());
}

#[test]
fn iceoryx2_leaves_sigint_and_sigterm_to_the_default_handler() {
    // Other tests of this binary run engines, which install sonarnet's own
    // SIGINT/SIGTERM flag (`engine::interrupt`); the check runs in a fresh
    // copy of this test binary that runs only this test.
    const CHILD: &str = "SONARNET_SIGNAL_CHECK_CHILD";
    if std::env::var_os(CHILD).is_none() {
        let me = std::env::current_exe().unwrap();
        let child = std::process::Command::new(me)
            .args([
                "--exact",
                "transport::iceoryx2_leaves_sigint_and_sigterm_to_the_default_handler",
                "--test-threads",
                "1",
            ])
            .env(CHILD, "1")
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let o = crate::util::wait_watchdog(child, "the signal check", WATCHDOG);
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(
            o.status.success() && stdout.contains("1 passed"),
            "{stdout}\n{}",
            String::from_utf8_lossy(&o.stderr)
        );
        return;
    }
    let topo = TopoSpec::ring(2, 1).with_broadcast(1).topology();
    {
        let mut c = IoxTransport::coordinator(&topo).unwrap();
        let mut n = IoxTransport::node(&topo, 0).unwrap();
        let _n1 = IoxTransport::node(&topo, 1).unwrap();
        c.recv(&mut Vec::new(), Some(Duration::from_millis(1)))
            .unwrap();
        n.recv(&mut Vec::new(), Some(Duration::from_millis(1)))
            .unwrap();
        let status = std::fs::read_to_string("/proc/self/status").unwrap();
        let caught = status
            .lines()
            .find_map(|l| l.strip_prefix("SigCgt:"))
            .map(|v| u64::from_str_radix(v.trim(), 16).unwrap())
            .unwrap();
        for (name, sig) in [("SIGINT", 2), ("SIGTERM", 15), ("SIGTSTP", 20)] {
            assert_eq!(caught & (1 << (sig - 1)), 0, "{name} is caught");
        }
    }
    assert_no_leftovers(topo.run_id());
}

// ---------------------------------------------------------------- measurements

#[test]
#[ignore = "measurement: cargo test --release --test it transport -- --ignored --nocapture latency"]
fn latency_of_a_frame_and_wake_up_between_two_processes() {
    const WARMUP: usize = 1_000;
    const ROUNDS: usize = 20_000;
    let spec = TopoSpec::ring(1, 4);
    let topo = spec.topology();
    {
        let mut c = IoxTransport::coordinator(&topo).unwrap();
        let mut kids = Children::new();
        kids.spawn(&Role::new("echo", &spec), false);
        let mut rtt = Vec::with_capacity(ROUNDS);
        let mut buf = Vec::new();
        for k in 0..WARMUP + ROUNDS {
            let t0 = Instant::now();
            c.send(Endpoint::Node(0), &frame(PING, COORDINATOR_ID, k as u64))
                .unwrap();
            c.flush().unwrap();
            buf.clear();
            recv_until(&mut c, &mut buf, WATCHDOG, "echo", |fs| !fs.is_empty());
            assert_eq!(buf[0].seq, k as u64);
            if k >= WARMUP {
                rtt.push(t0.elapsed());
            }
        }
        c.send(Endpoint::Node(0), &frame(QUIT, COORDINATOR_ID, 0))
            .unwrap();
        c.flush().unwrap();
        kids.wait_all_ok(WATCHDOG);
        rtt.sort_unstable();
        let q = |p: f64| rtt[((rtt.len() - 1) as f64 * p) as usize].as_secs_f64() * 1e6 / 2.0;
        println!(
            "one-way latency (RTT/2) over {ROUNDS} ping-pongs: median {:.1} us, p90 {:.1} us, p99 {:.1} us, min {:.1} us",
            q(0.5),
            q(0.9),
            q(0.99),
            q(0.0)
        );
    }
    assert_no_leftovers(topo.run_id());
}

/// (files, apparent bytes, allocated bytes) of the run's resources.
fn footprint(run_id: &str) -> (usize, u64, u64) {
    use std::os::unix::fs::MetadataExt;
    let files = run_resources(run_id);
    let mut apparent = 0;
    let mut allocated = 0;
    for p in &files {
        if let Ok(m) = std::fs::symlink_metadata(p) {
            apparent += m.len();
            allocated += m.blocks() * 512;
        }
    }
    (files.len(), apparent, allocated)
}

#[test]
#[ignore = "measurement: cargo test --release --test it transport -- --ignored --nocapture footprint"]
fn footprint_of_the_shared_memory_and_files_per_node() {
    for (n, bcast) in [(64, 0), (256, 0), (64, 2)] {
        let mut spec = TopoSpec::ring(n, 8);
        if bcast > 0 {
            spec = spec.with_broadcast(bcast);
        }
        let topo = spec.topology();
        {
            let t0 = Instant::now();
            let c = IoxTransport::coordinator(&topo).unwrap();
            let t_coord = t0.elapsed();
            let (f_c, a_c, b_c) = footprint(topo.run_id());
            let t1 = Instant::now();
            let nodes: Vec<IoxTransport> = (0..n as u32)
                .map(|i| IoxTransport::node(&topo, i).unwrap())
                .collect();
            let t_nodes = t1.elapsed();
            let (f, a, b) = footprint(topo.run_id());
            println!(
                "N={n} ring, inbox_buffer=8, broadcast_buffer={bcast}: coordinator alone {f_c} files {:.1} MiB apparent {:.1} MiB allocated; \
                 all endpoints {f} files, {:.1} MiB apparent, {:.1} MiB allocated; per node {:.1} files, {:.1} KiB apparent, {:.1} KiB allocated; coordinator setup {t_coord:?}, all nodes' setup {t_nodes:?}",
                a_c as f64 / 1048576.0,
                b_c as f64 / 1048576.0,
                a as f64 / 1048576.0,
                b as f64 / 1048576.0,
                f as f64 / n as f64,
                a as f64 / n as f64 / 1024.0,
                b as f64 / n as f64 / 1024.0,
            );
            drop(nodes);
            drop(c);
        }
        assert_no_leftovers(topo.run_id());
    }
}

#[test]
#[ignore = "measurement: cargo test --release --test it transport -- --ignored --nocapture multi_process_footprint"]
fn multi_process_footprint_and_startup_time() {
    for (n, bcast) in [(64usize, 2usize), (256, 0), (256, 2)] {
        let mut spec = TopoSpec::ring(n, 8);
        if bcast > 0 {
            spec = spec.with_broadcast(bcast);
        }
        let topo = spec.topology();
        {
            let mut c = IoxTransport::coordinator(&topo).unwrap();
            let t0 = Instant::now();
            let mut kids = Children::new();
            for i in 0..n {
                kids.spawn(&Role::new("idle-node", &spec).with("id", i), true);
            }
            for k in 0..n {
                kids.wait_ready(k, WATCHDOG);
            }
            let startup = t0.elapsed();
            let (f, a, b) = footprint(topo.run_id());
            println!(
                "N={n} ring, inbox_buffer=8, broadcast_buffer={bcast}, {n} node processes: \
                 {f} files, {:.1} MiB apparent, {:.1} MiB allocated; per node {:.1} files, {:.1} KiB apparent, \
                 {:.1} KiB allocated; all processes up after {startup:?}",
                a as f64 / 1048576.0,
                b as f64 / 1048576.0,
                f as f64 / n as f64,
                a as f64 / n as f64 / 1024.0,
                b as f64 / n as f64 / 1024.0,
            );
            for i in 0..n as u32 {
                c.send(Endpoint::Node(i), &frame(QUIT, COORDINATOR_ID, 0))
                    .unwrap();
            }
            c.flush().unwrap();
            kids.wait_all_ok(WATCHDOG);
        }
        assert_no_leftovers(topo.run_id());
    }
}
