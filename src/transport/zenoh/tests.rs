//! The zenoh transport on loopback TCP: frames, order, broadcast, the
//! barrier, liveliness, and that a party without the run's credentials is
//! shut out and a node can write only in its own name.

use super::fleet::{FleetEvent, FleetLink, Member};
use super::*;
use crate::transport::ZenohSettings;
use crate::transport::credentials::{Secret, node_user};
use crate::transport::wire::IMPOSTOR;
use std::sync::{Arc, Mutex};
use std::time::Instant;

fn router() -> ZenohSettings {
    ZenohSettings {
        listen: vec![ZenohSettings::free_loopback_endpoint().expect("a free port")],
        connect: vec![],
        config_file: None,
    }
}

/// The users of a run of `n` nodes, no agents.
fn creds(n: usize) -> RunCredentials {
    RunCredentials::fresh(n, &[], None, "zt").unwrap()
}

/// Node `i`'s login in `c`.
fn login(c: &RunCredentials, i: u32) -> Login {
    Login {
        user: node_user(i),
        password: c.node(i).unwrap().clone(),
    }
}

/// The coordinator of `topo` and node `i`'s transports, with `c`'s users.
fn coordinator(topo: &RunTopology, z: &ZenohSettings, c: &RunCredentials) -> ZenohTransport {
    ZenohTransport::coordinator(topo, z, c).unwrap()
}

fn node(topo: &RunTopology, i: u32, z: &ZenohSettings, c: &RunCredentials) -> ZenohTransport {
    ZenohTransport::node(topo, i, &z.for_local_nodes(), &login(c, i)).unwrap()
}

fn frame(from: u32, seq: u64) -> Frame {
    Frame {
        kind: 7,
        from,
        seq,
        data: [seq as f64, -0.0, f64::MAX, 1e-300, 3.5],
        ..Frame::default()
    }
}

/// Receive until `n` frames arrived or 5 s passed (the watchdog).
fn take(t: &mut ZenohTransport, n: usize) -> Vec<Frame> {
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut out = Vec::new();
    while out.len() < n && Instant::now() < deadline {
        t.recv(&mut out, Some(Duration::from_millis(100))).unwrap();
    }
    out
}

#[test]
fn frames_cross_in_order_both_ways_and_broadcasts_reach_every_member_and_the_sender() {
    let z = router();
    let topo = RunTopology::ring("zt-order", 3, 4)
        .unwrap()
        .with_broadcast(2)
        .unwrap();
    let users = creds(3);
    let mut c = coordinator(&topo, &z, &users);
    let mut nodes: Vec<ZenohTransport> = (0..3).map(|i| node(&topo, i, &z, &users)).collect();
    for s in 0..200u64 {
        c.send(Endpoint::Node(1), &frame(u32::MAX, s)).unwrap();
        if s % 7 == 0 {
            c.flush().unwrap();
        }
    }
    c.flush().unwrap();
    let got = take(&mut nodes[1], 200);
    assert_eq!(got.len(), 200);
    for (s, f) in got.iter().enumerate() {
        assert_eq!(f.seq, s as u64);
        assert_eq!(
            f.data.map(f64::to_bits),
            frame(0, s as u64).data.map(f64::to_bits)
        );
    }
    nodes[2].send(Endpoint::Coordinator, &frame(2, 9)).unwrap();
    nodes[2].send(Endpoint::Node(0), &frame(2, 10)).unwrap();
    nodes[2].broadcast(&frame(2, 11)).unwrap();
    nodes[2].shutdown(Duration::from_secs(5)).unwrap();
    assert_eq!(take(&mut c, 1)[0].seq, 9);
    let at0: Vec<u64> = take(&mut nodes[0], 2).iter().map(|f| f.seq).collect();
    assert!(at0.contains(&10) && at0.contains(&11), "{at0:?}");
    assert_eq!(
        take(&mut nodes[2], 1)[0].seq,
        11,
        "the sender hears its broadcast"
    );
    assert!(matches!(
        nodes[0].send(Endpoint::Node(0), &frame(0, 0)),
        Err(TransportError::NotAPeer { .. })
    ));
    assert!(matches!(
        c.broadcast(&frame(0, 0)),
        Err(TransportError::BroadcastUnavailable(_))
    ));
}

#[test]
fn a_party_without_the_runs_credentials_cannot_even_connect() {
    let z = router();
    let topo = RunTopology::ring("zt-secret-1f2e", 2, 4).unwrap();
    let users = creds(2);
    let _c = coordinator(&topo, &z, &users);
    let local = z.for_local_nodes();
    let wrong = Login {
        user: node_user(0),
        password: Secret::fresh().unwrap(),
    };
    let stranger = Login {
        user: "node-7".into(),
        password: users.node(1).unwrap().clone(),
    };
    for (who, l) in [
        ("no login", None),
        ("a wrong password", Some(&wrong)),
        ("a user the run does not have", Some(&stranger)),
    ] {
        let e = open_session(
            &local,
            Role::Client(l),
            "zt-secret-1f2e",
            Duration::from_millis(500),
        );
        assert!(e.is_err(), "a client with {who} connected");
    }
    assert!(
        open_session(
            &local,
            Role::Client(Some(&login(&users, 1))),
            "zt-secret-1f2e",
            Duration::from_secs(5)
        )
        .is_ok()
    );
}

#[test]
fn a_node_can_write_only_in_its_own_name_and_hear_only_its_own_inbox() {
    let z = router();
    let run = "zt-poser-9a";
    let topo = RunTopology::ring(run, 3, 4).unwrap();
    let users = creds(3);
    let mut c = coordinator(&topo, &z, &users);
    let mut n1 = node(&topo, 1, &z, &users);
    // Node 0's credentials in a raw session: it listens to every key of
    // every run, and writes into node 1's name.
    let spy = open_session(
        &z.for_local_nodes(),
        Role::Client(Some(&login(&users, 0))),
        run,
        Duration::from_secs(5),
    )
    .unwrap();
    let heard = Arc::new(Mutex::new(Vec::<String>::new()));
    let h = Arc::clone(&heard);
    let _sub = spy
        .declare_subscriber("sonarnet/**")
        .allowed_origin(zenoh::sample::Locality::Remote)
        .callback(move |s| h.lock().unwrap().push(s.key_expr().to_string()))
        .wait()
        .unwrap();
    let bytes = |f: Frame| {
        let mut b = Vec::new();
        f.put_bytes(&mut b);
        b
    };
    let p = prefix(run);
    for key in [
        format!("{p}/in/c/1"),
        format!("{p}/in/2/1"),
        format!("{p}/in/*/1"),
        "sonarnet/other/in/c/0".to_string(),
    ] {
        spy.put(key, bytes(frame(1, 666))).wait().unwrap();
    }
    // On its own key, in another's name: it arrives, as an impostor frame.
    spy.put(format!("{p}/in/c/0"), bytes(frame(2, 667)))
        .wait()
        .unwrap();
    // The run itself works meanwhile.
    n1.send(Endpoint::Coordinator, &frame(1, 1)).unwrap();
    n1.send(Endpoint::Node(2), &frame(1, 2)).unwrap();
    n1.shutdown(Duration::from_secs(5)).unwrap();
    let got = take(&mut c, 2);
    let mut rest = Vec::new();
    c.recv(&mut rest, Some(Duration::from_millis(300))).unwrap();
    let mut seen: Vec<(u32, u32, u32, u64)> = got
        .iter()
        .chain(&rest)
        .map(|f| (f.kind, f.from, f.aux, f.seq))
        .collect();
    seen.sort();
    assert_eq!(seen, vec![(7, 1, 0, 1), (IMPOSTOR, 0, 2, 667)]);
    let heard = heard.lock().unwrap();
    assert!(heard.is_empty(), "node 0 overheard {heard:?}");
}

#[test]
fn the_coordinator_sees_a_node_come_and_go_within_a_second() {
    let z = router();
    let topo = RunTopology::ring("zt-alive", 2, 4).unwrap();
    let users = creds(2);
    let c = coordinator(&topo, &z, &users);
    let events = Arc::new(Mutex::new(Vec::new()));
    let e = Arc::clone(&events);
    let _fleet = FleetLink::open(c.session(), "zt-alive", move |ev| {
        e.lock().unwrap().push((Instant::now(), ev))
    })
    .unwrap();
    let n1 = node(&topo, 1, &z, &users);
    let wait_for = |want: &FleetEvent| {
        let deadline = Instant::now() + Duration::from_secs(5);
        while Instant::now() < deadline {
            if let Some((t, _)) = events.lock().unwrap().iter().find(|(_, x)| x == want) {
                return Some(*t);
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        None
    };
    assert!(wait_for(&FleetEvent::Presence(Member::Node(1), true)).is_some());
    let dropped = Instant::now();
    drop(n1);
    let seen = wait_for(&FleetEvent::Presence(Member::Node(1), false)).expect("seen to go");
    assert!(
        seen - dropped < Duration::from_secs(1),
        "{:?}",
        seen - dropped
    );
}

#[test]
fn a_nodes_first_frame_put_as_its_session_opens_reaches_the_coordinator() {
    // A client learns of the router's subscribers after its session opens;
    // a put before that news is dropped at the source (see `await_match`).
    // In one process the news is fast; the race itself shows between
    // processes over QUIC (tests/it/zenoh.rs, the encrypted run).
    let z = router();
    let topo = RunTopology::ring("zt-first", 2, 4).unwrap();
    let users = creds(2);
    let mut c = coordinator(&topo, &z, &users);
    for round in 0..5u64 {
        let mut n = node(&topo, 1, &z, &users);
        n.send(Endpoint::Coordinator, &frame(1, round)).unwrap();
        n.flush().unwrap();
        let got = take(&mut c, 1);
        assert_eq!(
            got.iter().map(|f| f.seq).collect::<Vec<_>>(),
            vec![round],
            "round {round}"
        );
    }
}

/// Encrypted links (`zenoh-tls`): QUIC with the test certificates of
/// `tests/fixtures/tls`.
#[cfg(feature = "zenoh-tls")]
mod quic {
    use super::*;
    use std::path::PathBuf;

    fn fixture(name: &str) -> String {
        let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fixtures/tls")
            .join(name);
        p.to_string_lossy().into_owned()
    }

    /// A zenoh configuration file trusting `ca`, with the server's
    /// certificate and key when `server`.
    fn config(tag: &str, ca: &str, server: bool) -> PathBuf {
        let (key, cert) = (fixture("server.key"), fixture("server.pem"));
        let text = super::super::config::tls_link_config(
            std::path::Path::new(&fixture(ca)),
            server.then_some((std::path::Path::new(&key), std::path::Path::new(&cert))),
        );
        let path =
            std::env::temp_dir().join(format!("sonarnet-zt-{tag}-{}.json5", std::process::id()));
        std::fs::write(&path, text).unwrap();
        path
    }

    fn quic_router(tag: &str) -> ZenohSettings {
        let tcp = ZenohSettings::free_loopback_endpoint().expect("a free port");
        let port = tcp.rsplit(':').next().unwrap_or("0").to_string();
        ZenohSettings {
            listen: vec![format!("quic/127.0.0.1:{port}")],
            connect: vec![],
            config_file: Some(config(&format!("{tag}-server"), "ca.pem", true)),
        }
    }

    #[test]
    fn frames_cross_a_quic_link_in_order_from_the_first_put_on() {
        let z = quic_router("order");
        let topo = RunTopology::ring("zt-quic", 3, 4).unwrap();
        let users = creds(3);
        let mut c = coordinator(&topo, &z, &users);
        let client = ZenohSettings {
            config_file: Some(config("order-client", "ca.pem", false)),
            ..z.for_local_nodes()
        };
        let mut n1 = ZenohTransport::node(&topo, 1, &client, &login(&users, 1)).unwrap();
        let mut n2 = ZenohTransport::node(&topo, 2, &client, &login(&users, 2)).unwrap();
        // At once, before anything else: the first put must not be lost.
        n1.send(Endpoint::Coordinator, &frame(1, 0)).unwrap();
        n1.flush().unwrap();
        assert_eq!(take(&mut c, 1).len(), 1, "the first frame over QUIC");
        for s in 0..200u64 {
            n1.send(Endpoint::Node(0), &frame(1, s)).unwrap();
            c.send(Endpoint::Node(2), &frame(u32::MAX, s)).unwrap();
            if s % 5 == 0 {
                n1.flush().unwrap();
                c.flush().unwrap();
            }
        }
        n1.flush().unwrap();
        c.flush().unwrap();
        let got = take(&mut n2, 200);
        assert_eq!(got.len(), 200);
        assert!(got.iter().enumerate().all(|(s, f)| f.seq == s as u64));
        assert_eq!(
            got[7].data.map(f64::to_bits),
            frame(0, 7).data.map(f64::to_bits),
            "bit for bit"
        );
    }

    #[test]
    fn a_party_that_does_not_trust_the_runs_certificate_cannot_connect() {
        let z = quic_router("distrust");
        let topo = RunTopology::ring("zt-quic-2", 2, 4).unwrap();
        let users = creds(2);
        let _c = coordinator(&topo, &z, &users);
        let stranger = ZenohSettings {
            config_file: Some(config("distrust-client", "other-ca.pem", false)),
            ..z.for_local_nodes()
        };
        let t0 = Instant::now();
        let l = login(&users, 1);
        let e = open_session(
            &stranger,
            Role::Client(Some(&l)),
            "zt-quic-2",
            Duration::from_secs(2),
        );
        assert!(e.is_err(), "a client trusting another CA connected");
        assert!(t0.elapsed() < Duration::from_secs(30));
        let friend = ZenohSettings {
            config_file: Some(config("distrust-friend", "ca.pem", false)),
            ..z.for_local_nodes()
        };
        assert!(
            open_session(
                &friend,
                Role::Client(Some(&l)),
                "zt-quic-2",
                Duration::from_secs(5)
            )
            .is_ok()
        );
    }
}
