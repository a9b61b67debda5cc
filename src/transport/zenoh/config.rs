//! The zenoh session configuration of every party of a run.
//!
//! * The coordinator is a zenoh **router** that listens on the run's
//!   endpoints; every node and agent is a **client** connected to it. Frames
//!   between two nodes go through the coordinator's router (one TCP hop in,
//!   one out).
//! * Multicast and gossip scouting are off: peers are found only through the
//!   explicit endpoints.
//! * The link lease is [`LEASE_MS`] with four keep-alives per lease, so a
//!   host that vanishes without closing its sockets is noticed within about a
//!   second; a process that dies closes its socket and is noticed at once.
//! * Every client authenticates with zenoh's user and password extension
//!   ([`crate::transport::credentials`]): the router admits only the users of
//!   its run, each node with a password made for this run, each agent with
//!   the password the fleet key gives it for this run. A party without them
//!   is refused at the handshake, and
//!   the coordinator says so on standard error.
//! * The router's access control ([`run_acl`], default deny) binds each user
//!   to its own key expressions: node `i` may put only on keys that name it
//!   as the sender (`<prefix>/in/<to>/<i>`, `<prefix>/bcast/<i>`), subscribe
//!   only to its own inbox, declare only its own liveliness token; an agent
//!   only its own command and event keys. Unless the user's configuration
//!   file enables access control itself, which then replaces this one.

use super::super::credentials::{Login, RunCredentials, agent_user, node_user};
use super::super::{TransportError, ZenohSettings};

/// Link lease in milliseconds (zenoh's default is 10 000).
pub const LEASE_MS: u64 = 900;

/// How long a node keeps trying to reach the coordinator's endpoint.
pub const CONNECT_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(10);

/// The role of a session in a run, with what it authenticates with.
#[derive(Debug, Clone, Copy)]
pub enum Role<'a> {
    /// The coordinator: a router listening on `settings.listen`, admitting
    /// the run's users.
    Router(&'a RunCredentials),
    /// A node or an agent: a client of `settings.connect`, with its login
    /// (`None`: none, which a router of a run refuses).
    Client(Option<&'a Login>),
}

fn zerr(op: impl Into<String>) -> impl FnOnce(zenoh::Error) -> TransportError {
    let op = op.into();
    move |e| TransportError::Zenoh {
        op,
        detail: e.to_string(),
    }
}

fn json_list(items: &[String]) -> String {
    serde_json::to_string(items).unwrap_or_else(|_| "[]".into())
}

/// A session's configuration, and the in-memory file holding the router's
/// user dictionary (zenoh reads it when the session opens; it is never on
/// a file system, so nothing of it is left even if the process is killed).
pub struct SessionConfig {
    /// The configuration to open.
    pub config: zenoh::Config,
    _users: Option<std::fs::File>,
}

impl SessionConfig {
    /// Opens the session (the dictionary file is closed once zenoh has read
    /// it).
    pub fn open(self) -> zenoh::Result<zenoh::Session> {
        use zenoh::Wait;
        zenoh::open(self.config).wait()
    }
}

/// `text` in an anonymous in-memory file (`memfd_create`), and the path this
/// process opens it by (`/proc/self/fd/N`).
fn memory_file(text: &str) -> std::io::Result<(std::fs::File, String)> {
    use std::io::Write;
    use std::os::fd::FromRawFd;
    // SAFETY: the name is a NUL-terminated C string; the call has no other
    // inputs, and a non-negative result is a new descriptor this function
    // then owns.
    let fd = unsafe { libc::memfd_create(c"sonarnet-zenoh-users".as_ptr(), libc::MFD_CLOEXEC) };
    if fd < 0 {
        return Err(std::io::Error::last_os_error());
    }
    // SAFETY: `fd` is open and owned by nothing else.
    let mut f = unsafe { std::fs::File::from_raw_fd(fd) };
    f.write_all(text.as_bytes())?;
    Ok((f, format!("/proc/self/fd/{fd}")))
}

/// The session configuration of a party of run `run_id` with `role`.
pub fn session_config(
    settings: &ZenohSettings,
    role: Role<'_>,
    run_id: &str,
    connect_timeout: std::time::Duration,
) -> Result<SessionConfig, TransportError> {
    let mut c = match &settings.config_file {
        Some(p) => zenoh::Config::from_file(p).map_err(zerr(format!(
            "reading the zenoh configuration file {}",
            p.display()
        )))?,
        None => zenoh::Config::default(),
    };
    fn set(c: &mut zenoh::Config, key: &str, value: String) -> Result<(), TransportError> {
        c.insert_json5(key, &value)
            .map_err(zerr(format!("setting {key} = {value}")))
    }
    let mut users = None;
    match role {
        Role::Router(creds) => {
            if settings.listen.is_empty() {
                return Err(TransportError::InvalidTopology(
                    "the coordinator needs an endpoint to listen on (--listen tcp/HOST:PORT)"
                        .into(),
                ));
            }
            set(&mut c, "mode", "\"router\"".into())?;
            set(&mut c, "listen/endpoints", json_list(&settings.listen))?;
            set(&mut c, "connect/endpoints", "[]".into())?;
            // A router stamps every sample by default: nothing here reads it.
            set(&mut c, "timestamping/enabled", "false".into())?;
            let (file, path) = memory_file(&creds.dictionary()).map_err(|e| {
                TransportError::ipc("writing the run's zenoh users to an in-memory file", e)
            })?;
            set(
                &mut c,
                "transport/auth/usrpwd/dictionary_file",
                quoted(&path),
            )?;
            users = Some(file);
        }
        Role::Client(login) => {
            if settings.connect.is_empty() {
                return Err(TransportError::InvalidTopology(
                    "a node or agent needs the coordinator's endpoint (--connect tcp/HOST:PORT)"
                        .into(),
                ));
            }
            set(&mut c, "mode", "\"client\"".into())?;
            set(&mut c, "connect/endpoints", json_list(&settings.connect))?;
            set(
                &mut c,
                "connect/timeout_ms",
                connect_timeout.as_millis().max(1).to_string(),
            )?;
            set(&mut c, "connect/exit_on_failure", "true".into())?;
            set(&mut c, "listen/endpoints", "[]".into())?;
            if let Some(l) = login {
                set(&mut c, "transport/auth/usrpwd/user", quoted(&l.user))?;
                let pass = quoted(l.password.expose());
                c.insert_json5("transport/auth/usrpwd/password", &pass)
                    .map_err(zerr("setting the node's zenoh password"))?;
            }
        }
    }
    set(&mut c, "scouting/multicast/enabled", "false".into())?;
    set(&mut c, "scouting/gossip/enabled", "false".into())?;
    set(&mut c, "transport/link/tx/lease", LEASE_MS.to_string())?;
    set(&mut c, "transport/link/tx/keep_alive", "4".into())?;
    let user_acl = c
        .get_json("access_control/enabled")
        .is_ok_and(|v| v.trim() == "true");
    if let (Role::Router(creds), false) = (role, user_acl) {
        c.insert_json5("access_control", &run_acl(run_id, creds))
            .map_err(zerr("setting the run's access control"))?;
    }
    Ok(SessionConfig {
        config: c,
        _users: users,
    })
}

fn quoted(s: &str) -> String {
    serde_json::to_string(s).unwrap_or_default()
}

/// The JSON5 text of a zenoh configuration file (`--zenoh-config`) for an
/// encrypted link (`quic/...`, or `tls/...`): trust the certificate
/// authority `root_ca`, and, for the party that listens, present
/// `server = (private key, certificate)`. The book's Across hosts chapter shows
/// the same text.
pub fn tls_link_config(
    root_ca: &std::path::Path,
    server: Option<(&std::path::Path, &std::path::Path)>,
) -> String {
    let keys = server.map_or(String::new(), |(key, cert)| {
        format!("listen_private_key: {key:?}, listen_certificate: {cert:?},")
    });
    format!(
        "{{ transport: {{ link: {{ tls: {{ root_ca_certificate: {root_ca:?}, {keys} }} }} }} }}"
    )
}

/// Every message kind zenoh's access control knows.
const ALL_MESSAGES: &str = r#"["put", "delete", "declare_subscriber", "query", "declare_queryable", "reply", "liveliness_token", "declare_liveliness_subscriber", "liveliness_query"]"#;

/// zenoh access control for run `run_id` (JSON5): default deny; the router
/// delivers to any user of the run what it subscribed to under the run's
/// prefix (egress), and takes from each user only (ingress):
///
/// | user | put | declare_subscriber | liveliness_token | other |
/// |---|---|---|---|---|
/// | `node-<i>` | `<p>/in/*/<i>`, `<p>/bcast/<i>` | `<p>/in/<i>/*`, `<p>/bcast/*` | `<p>/alive/node/<i>` | query `<p>/barrier/<i>` |
/// | `agent-<h>` | `<p>/agent/<h>/ev` | `<p>/agent/<h>/cmd` | `<p>/alive/agent/<h>` | liveliness subscriber and query `<p>/alive/**` |
///
/// So a node can write no key but those naming it as the sender, and the
/// receiving side checks that every frame's sender is the key's.
pub fn run_acl(run_id: &str, creds: &RunCredentials) -> String {
    let p = super::prefix(run_id);
    let mut rules = vec![format!(
        r#"{{ id: "deliver", permission: "allow", flows: ["egress"], messages: {ALL_MESSAGES}, key_exprs: ["{p}/**"] }}"#
    )];
    let mut subjects = Vec::new();
    let mut policies = Vec::new();
    let mut party = |user: String, grants: Vec<(&str, Vec<String>)>| {
        let mut ids = vec!["\"deliver\"".to_string()];
        for (k, (message, keys)) in grants.into_iter().enumerate() {
            let id = format!("{user}-{k}");
            rules.push(format!(
                r#"{{ id: "{id}", permission: "allow", flows: ["ingress"], messages: ["{message}"], key_exprs: {} }}"#,
                json_list(&keys)
            ));
            ids.push(format!("{id:?}"));
        }
        subjects.push(format!(r#"{{ id: "{user}", usernames: ["{user}"] }}"#));
        policies.push(format!(
            r#"{{ rules: [{}], subjects: ["{user}"] }}"#,
            ids.join(", ")
        ));
    };
    for i in 0..creds.node_count() {
        party(
            node_user(i as u32),
            vec![
                (
                    "put",
                    vec![format!("{p}/in/*/{i}"), format!("{p}/bcast/{i}")],
                ),
                (
                    "declare_subscriber",
                    vec![format!("{p}/in/{i}/*"), format!("{p}/bcast/*")],
                ),
                ("liveliness_token", vec![format!("{p}/alive/node/{i}")]),
                ("query", vec![format!("{p}/barrier/{i}")]),
            ],
        );
    }
    for h in creds.agent_hosts() {
        party(
            agent_user(h),
            vec![
                ("put", vec![format!("{p}/agent/{h}/ev")]),
                ("declare_subscriber", vec![format!("{p}/agent/{h}/cmd")]),
                ("liveliness_token", vec![format!("{p}/alive/agent/{h}")]),
                (
                    "declare_liveliness_subscriber",
                    vec![format!("{p}/alive/**")],
                ),
                ("liveliness_query", vec![format!("{p}/alive/**")]),
            ],
        );
    }
    format!(
        "{{ enabled: true, default_permission: \"deny\",\n  rules: [\n    {}\n  ],\n  subjects: [{}],\n  policies: [\n    {}\n  ],\n}}",
        rules.join(",\n    "),
        subjects.join(", "),
        policies.join(",\n    ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tls_link_config_parses_as_zenoh_config_with_the_keys_for_the_server_only() {
        let ca = std::path::Path::new("/keys/ca.pem");
        let server = tls_link_config(
            ca,
            Some((
                std::path::Path::new("/keys/s.key"),
                std::path::Path::new("/keys/s.pem"),
            )),
        );
        let client = tls_link_config(ca, None);
        for (text, has_keys) in [(&server, true), (&client, false)] {
            let c = zenoh::Config::from_json5(text).expect(text);
            assert_eq!(
                c.get_json("transport/link/tls/root_ca_certificate")
                    .unwrap(),
                "\"/keys/ca.pem\""
            );
            assert_eq!(
                c.get_json("transport/link/tls/listen_private_key")
                    .is_ok_and(|v| v.contains("/keys/s.key")),
                has_keys,
                "{text}"
            );
        }
    }

    fn settings() -> ZenohSettings {
        ZenohSettings {
            listen: vec!["tcp/127.0.0.1:7447".into()],
            connect: vec!["tcp/127.0.0.1:7447".into()],
            config_file: None,
        }
    }

    fn creds() -> RunCredentials {
        let key = crate::transport::credentials::Secret::parse(&"f".repeat(40)).unwrap();
        RunCredentials::fresh(2, &["hb"], Some(&key), "run-1").unwrap()
    }

    #[test]
    fn the_router_listens_with_scouting_off_and_admits_only_its_users() {
        let creds = creds();
        let sc =
            session_config(&settings(), Role::Router(&creds), "run-1", CONNECT_TIMEOUT).unwrap();
        let c = &sc.config;
        let json = format!("{c}");
        assert!(json.contains("\"router\""), "{json}");
        assert!(json.contains("tcp/127.0.0.1:7447"), "{json}");
        assert_eq!(c.get_json("scouting/multicast/enabled").unwrap(), "false");
        assert_eq!(c.get_json("access_control/enabled").unwrap(), "true");
        assert!(json.contains("sonarnet/run-1/in/*/1"), "{json}");
        assert!(json.contains("sonarnet/run-1/agent/hb/ev"), "{json}");
        let dict = c.get_json("transport/auth/usrpwd/dictionary_file").unwrap();
        let path: String = serde_json::from_str(&dict).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text, creds.dictionary(), "{path}");
        assert!(!json.contains(creds.node(0).unwrap().expose()), "{json}");
    }

    #[test]
    fn the_run_acl_parses_and_grants_each_node_only_keys_naming_it() {
        let creds = creds();
        let text = run_acl("r", &creds);
        let mut c = zenoh::Config::default();
        c.insert_json5("access_control", &text).expect(&text);
        assert!(text.contains(r#"usernames: ["node-1"]"#), "{text}");
        assert!(
            text.contains(
                r#"messages: ["put"], key_exprs: ["sonarnet/r/in/*/1","sonarnet/r/bcast/1"]"#
            ),
            "{text}"
        );
        assert!(!text.contains("sonarnet/r/in/*/2"), "{text}");
        assert!(text.contains(r#"usernames: ["agent-hb"]"#), "{text}");
    }

    #[test]
    fn a_client_carries_its_login_and_no_other_secret() {
        let login = Login {
            user: "node-3".into(),
            password: crate::transport::credentials::Secret::parse(&"p".repeat(40)).unwrap(),
        };
        let c = session_config(
            &settings(),
            Role::Client(Some(&login)),
            "r",
            CONNECT_TIMEOUT,
        )
        .unwrap()
        .config;
        assert_eq!(
            c.get_json("transport/auth/usrpwd/user").unwrap(),
            "\"node-3\""
        );
        assert!(
            c.get_json("transport/auth/usrpwd/dictionary_file")
                .is_ok_and(|v| v == "null")
        );
    }

    #[test]
    fn a_client_without_an_endpoint_is_refused_with_the_flag_to_give() {
        let s = ZenohSettings {
            connect: vec![],
            ..settings()
        };
        let e = session_config(&s, Role::Client(None), "r", CONNECT_TIMEOUT)
            .err()
            .unwrap();
        assert!(e.to_string().contains("--connect"), "{e}");
        let s = ZenohSettings {
            listen: vec![],
            ..settings()
        };
        let e = session_config(&s, Role::Router(&creds()), "r", CONNECT_TIMEOUT)
            .err()
            .unwrap();
        assert!(e.to_string().contains("--listen"), "{e}");
    }

    #[test]
    fn a_bad_endpoint_or_configuration_file_is_named() {
        let s = ZenohSettings {
            config_file: Some("/nonexistent/zenoh.json5".into()),
            ..settings()
        };
        let e = session_config(&s, Role::Client(None), "r", CONNECT_TIMEOUT)
            .err()
            .unwrap();
        assert!(e.to_string().contains("/nonexistent/zenoh.json5"), "{e}");
    }
}
