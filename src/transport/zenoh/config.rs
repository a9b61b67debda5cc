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
//! * The router admits only key expressions under the run's prefix
//!   (`sonarnet/<run id>/**`, zenoh access control, default deny), unless the
//!   user's configuration file enables access control itself: a party that
//!   does not know the run id can neither read nor write the run.

use super::super::{TransportError, ZenohSettings};

/// Link lease in milliseconds (zenoh's default is 10 000).
pub const LEASE_MS: u64 = 900;

/// How long a node keeps trying to reach the coordinator's endpoint.
pub const CONNECT_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(10);

/// The role of a session in a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// The coordinator: a router listening on `settings.listen`.
    Router,
    /// A node or an agent: a client of `settings.connect`.
    Client,
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

/// The session configuration of a party of run `run_id` with `role`.
pub fn session_config(
    settings: &ZenohSettings,
    role: Role,
    run_id: &str,
    connect_timeout: std::time::Duration,
) -> Result<zenoh::Config, TransportError> {
    let mut c = match &settings.config_file {
        Some(p) => zenoh::Config::from_file(p).map_err(zerr(format!(
            "reading the zenoh configuration file {}",
            p.display()
        )))?,
        None => zenoh::Config::default(),
    };
    let mut set = |key: &str, value: String| {
        c.insert_json5(key, &value)
            .map_err(zerr(format!("setting {key} = {value}")))
    };
    match role {
        Role::Router => {
            if settings.listen.is_empty() {
                return Err(TransportError::InvalidTopology(
                    "the coordinator needs an endpoint to listen on (--listen tcp/HOST:PORT)"
                        .into(),
                ));
            }
            set("mode", "\"router\"".into())?;
            set("listen/endpoints", json_list(&settings.listen))?;
            set("connect/endpoints", "[]".into())?;
            // A router stamps every sample by default: nothing here reads it.
            set("timestamping/enabled", "false".into())?;
        }
        Role::Client => {
            if settings.connect.is_empty() {
                return Err(TransportError::InvalidTopology(
                    "a node or agent needs the coordinator's endpoint (--connect tcp/HOST:PORT)"
                        .into(),
                ));
            }
            set("mode", "\"client\"".into())?;
            set("connect/endpoints", json_list(&settings.connect))?;
            set(
                "connect/timeout_ms",
                connect_timeout.as_millis().max(1).to_string(),
            )?;
            set("connect/exit_on_failure", "true".into())?;
            set("listen/endpoints", "[]".into())?;
        }
    }
    set("scouting/multicast/enabled", "false".into())?;
    set("scouting/gossip/enabled", "false".into())?;
    set("transport/link/tx/lease", LEASE_MS.to_string())?;
    set("transport/link/tx/keep_alive", "4".into())?;
    let user_acl = c
        .get_json("access_control/enabled")
        .is_ok_and(|v| v.trim() == "true");
    if role == Role::Router && !user_acl {
        c.insert_json5("access_control", &run_acl(run_id))
            .map_err(zerr("setting the run's access control"))?;
    }
    Ok(c)
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

/// zenoh access control admitting only the run's key expressions.
pub fn run_acl(run_id: &str) -> String {
    format!(
        r#"{{
  enabled: true,
  default_permission: "deny",
  rules: [{{
    id: "run",
    permission: "allow",
    flows: ["ingress", "egress"],
    messages: ["put", "delete", "declare_subscriber", "query", "declare_queryable",
               "reply", "liveliness_token", "declare_liveliness_subscriber", "liveliness_query"],
    key_exprs: ["{}/**"],
  }}],
  subjects: [{{ id: "anyone" }}],
  policies: [{{ rules: ["run"], subjects: ["anyone"] }}],
}}"#,
        super::prefix(run_id)
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

    #[test]
    fn the_router_listens_with_scouting_off_and_admits_only_its_run() {
        let c = session_config(&settings(), Role::Router, "run-1", CONNECT_TIMEOUT).unwrap();
        let json = format!("{c}");
        assert!(json.contains("\"router\""), "{json}");
        assert!(json.contains("tcp/127.0.0.1:7447"), "{json}");
        assert_eq!(c.get_json("scouting/multicast/enabled").unwrap(), "false");
        assert_eq!(c.get_json("access_control/enabled").unwrap(), "true");
        assert!(json.contains("sonarnet/run-1/**"), "{json}");
    }

    #[test]
    fn a_client_without_an_endpoint_is_refused_with_the_flag_to_give() {
        let s = ZenohSettings {
            connect: vec![],
            ..settings()
        };
        let e = session_config(&s, Role::Client, "r", CONNECT_TIMEOUT).unwrap_err();
        assert!(e.to_string().contains("--connect"), "{e}");
        let s = ZenohSettings {
            listen: vec![],
            ..settings()
        };
        let e = session_config(&s, Role::Router, "r", CONNECT_TIMEOUT).unwrap_err();
        assert!(e.to_string().contains("--listen"), "{e}");
    }

    #[test]
    fn a_bad_endpoint_or_configuration_file_is_named() {
        let s = ZenohSettings {
            config_file: Some("/nonexistent/zenoh.json5".into()),
            ..settings()
        };
        let e = session_config(&s, Role::Client, "r", CONNECT_TIMEOUT).unwrap_err();
        assert!(e.to_string().contains("/nonexistent/zenoh.json5"), "{e}");
    }
}
