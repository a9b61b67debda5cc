//! The network flags of `sonarnet run` (`--transport`, `--listen`, `--place`,
//! `--run-id`, `--zenoh-config`, `--agent-wait`) and `sonarnet agent`.

use super::AgentArgs;
use super::RunArgs;
use crate::cli::errors::CliError;
use crate::model::error::InputError;
use crate::pipeline::EngineKind;
use crate::pipeline::NetOptions;
use crate::scenario::Scenario;
use crate::scenario::deploy::Placement;
use crate::transport::{TransportChoice, ZenohSettings};
use std::path::Path;
use std::time::Duration;

fn cli_error(key: &str, reason: impl Into<String>) -> CliError {
    InputError::at(Path::new("<command line>"), key, reason.into()).into()
}

/// What a build without the `zenoh` feature says to `--transport zenoh`
/// and `sonarnet agent`.
pub const WITHOUT_ZENOH: &str = "this sonarnet was built without zenoh: build it with `cargo build --release --features zenoh` (on every host)";

/// The port a coordinator with nodes on other hosts listens on by default
/// (zenoh's own default port).
pub const DEFAULT_PORT: u16 = 7447;

/// The link protocols of zenoh endpoints (`PROTO/HOST:PORT`) that this
/// build carries: `tcp` always, `quic` and `tls` with the `zenoh-tls`
/// feature.
pub const LINKS: &[&str] = if cfg!(feature = "zenoh-tls") {
    &["tcp", "quic", "tls"]
} else {
    &["tcp"]
};

/// What `--listen tls/...` prints: zenoh 1.10's TLS link loses frames.
pub const TLS_LINK_WARNING: &str = "warning: zenoh's tls/ link reads and writes one rustls stream from two threads at once (zenoh issue 2557): under a run's traffic it fails with \"handshake not complete\", reconnects and loses frames, and the run stalls. Use quic/HOST:PORT: TLS 1.3 with the same certificates (the book, \"Across hosts\")";

/// Checks the endpoints given to `flag`: `PROTO/HOST:PORT` with a link this
/// build carries ([`LINKS`]).
fn check_endpoints(flag: &str, endpoints: &[String]) -> Result<(), CliError> {
    for e in endpoints {
        let Some((proto, addr)) = e.split_once('/') else {
            return Err(cli_error(
                flag,
                format!(
                    "{e:?} is not an endpoint: give PROTO/HOST:PORT, e.g. tcp/0.0.0.0:{DEFAULT_PORT}"
                ),
            ));
        };
        let addr = addr.split('#').next().unwrap_or(addr);
        if !addr.contains(':') {
            return Err(cli_error(
                flag,
                format!("{e:?} has no port: give PROTO/HOST:PORT"),
            ));
        }
        if !LINKS.contains(&proto) {
            let hint = if matches!(proto, "quic" | "tls") {
                " (build with `--features zenoh-tls` for quic and tls)"
            } else {
                ""
            };
            return Err(cli_error(
                flag,
                format!(
                    "link {proto:?} of {e:?} is not in this build, which carries {}{hint}",
                    LINKS.join(", ")
                ),
            ));
        }
    }
    if endpoints.iter().any(|e| e.starts_with("tls/")) {
        eprintln!("{TLS_LINK_WARNING}");
    }
    Ok(())
}

/// The network options of a run, checked before anything starts.
pub(super) fn net_options<const D: usize>(
    args: &RunArgs,
    sc: &Scenario<D>,
    engine: EngineKind,
) -> Result<NetOptions, CliError> {
    if args.transport == crate::protocol::TransportKind::Iceoryx2 {
        for (flag, given) in [
            ("--listen", !args.listen.is_empty()),
            ("--place", !args.place.is_empty()),
            ("--run-id", args.run_id.is_some()),
            ("--zenoh-config", args.zenoh_config.is_some()),
        ] {
            if given {
                return Err(cli_error(flag, "applies to --transport zenoh"));
            }
        }
        return Ok(NetOptions::default());
    }
    if !cfg!(feature = "zenoh") {
        return Err(cli_error("--transport", WITHOUT_ZENOH));
    }
    check_endpoints("--listen", &args.listen)?;
    if engine != EngineKind::Processes {
        return Err(cli_error(
            "--transport",
            "zenoh carries the frames of node processes: it needs --engine processes",
        ));
    }
    if let Some(f) = &args.zenoh_config
        && !f.is_file()
    {
        return Err(cli_error(
            "--zenoh-config",
            format!("{} is not a readable file", f.display()),
        ));
    }
    if let Some(id) = &args.run_id {
        crate::transport::validate_run_id(id).map_err(|e| cli_error("--run-id", e.to_string()))?;
    }
    let placement = if args.place.is_empty() {
        sc.deploy.clone()
    } else {
        let p = Placement::parse(&args.place).map_err(|e| cli_error("--place", e.to_string()))?;
        p.validate(sc.graph.len())
            .map_err(|e| cli_error("--place", e.to_string()))?;
        Some(p)
    };
    let remote = placement.as_ref().is_some_and(|p| !p.agents().is_empty());
    let checkpointed = sc.faults.iter().any(|f| {
        matches!(
            f.kind,
            crate::model::fault::FaultKind::Restart {
                checkpoint: true,
                ..
            }
        )
    });
    if remote && checkpointed {
        return Err(cli_error(
            "--place",
            "a restart from a checkpoint needs its node on this host (the checkpoint file is here)",
        ));
    }
    let fleet_key = match (&args.fleet_key, remote) {
        (Some(f), _) => Some(
            crate::transport::credentials::read_fleet_key(f)
                .map_err(|e| cli_error("--fleet-key", e.to_string()))?,
        ),
        (None, true) => {
            return Err(cli_error(
                "--fleet-key",
                format!(
                    "nodes placed on the agents of {} need the fleet's key, the file their agents were given: --fleet-key FILE (`sonarnet fleet-key FILE` makes one; copy it to every host, mode 600)",
                    placement
                        .as_ref()
                        .map(|p| p.agents().join(", "))
                        .unwrap_or_default()
                ),
            ));
        }
        (None, false) => None,
    };
    let listen = if !args.listen.is_empty() {
        args.listen.clone()
    } else if remote {
        vec![format!("tcp/0.0.0.0:{DEFAULT_PORT}")]
    } else {
        vec![
            ZenohSettings::free_loopback_endpoint()
                .map_err(|e| cli_error("--listen", e.to_string()))?,
        ]
    };
    let run_id = match (&args.run_id, remote) {
        (Some(id), _) => Some(id.clone()),
        // The agents must be told the id before the run starts.
        (None, true) => Some(crate::transport::secret_run_id()),
        (None, false) => None,
    };
    if let (true, Some(p), Some(id)) = (remote, &placement, &run_id) {
        let first = listen.first().map(String::as_str).unwrap_or("tcp/:7447");
        let port = first.rsplit(':').next().unwrap_or("7447");
        let proto = first.split('/').next().unwrap_or("tcp");
        // An encrypted link needs the CA on the agent's side too.
        let config = match (&args.zenoh_config, proto) {
            (Some(_), "quic" | "tls") => " --zenoh-config <a file with root_ca_certificate>",
            _ => "",
        };
        eprintln!(
            "run id {id}: waiting up to {} s for the agents of {} on {}; on each host run",
            args.agent_wait,
            p.agents().join(", "),
            listen.join(", ")
        );
        for h in p.agents() {
            eprintln!(
                "  sonarnet agent --connect {proto}/<this host's address>:{port} --run-id {id} --host {h} --fleet-key <the same key file>{config}"
            );
        }
    }
    Ok(NetOptions {
        transport: TransportChoice::Zenoh(ZenohSettings {
            listen,
            connect: Vec::new(),
            config_file: args.zenoh_config.clone(),
        }),
        placement,
        agent_wait: Some(Duration::from_secs_f64(args.agent_wait)),
        run_id,
        node_program: None,
        fleet_key,
    })
}

/// `sonarnet fleet-key FILE`: a fresh key, in a new file of mode 600.
pub(super) fn fleet_key_command(file: &Path) -> Result<(), CliError> {
    crate::transport::credentials::write_fleet_key(file)
        .map_err(|e| cli_error("fleet-key FILE", e.to_string()))?;
    eprintln!(
        "wrote a fresh fleet key to {} (mode 600): copy it to every host of the fleet and give it to `sonarnet run --fleet-key` and `sonarnet agent --fleet-key`",
        file.display()
    );
    Ok(())
}

/// `sonarnet agent`.
#[cfg(feature = "zenoh")]
pub(super) fn agent_command(args: &AgentArgs) -> Result<(), CliError> {
    use crate::runtime::agent::{AgentEnd, AgentOptions, run_agent};
    crate::transport::validate_run_id(&args.run_id)
        .map_err(|e| cli_error("--run-id", e.to_string()))?;
    Placement {
        hosts: [(args.host.clone(), vec![0])].into(),
    }
    .validate(1)
    .map_err(|e| cli_error("--host", e.to_string()))?;
    if let Some(f) = &args.zenoh_config
        && !f.is_file()
    {
        return Err(cli_error(
            "--zenoh-config",
            format!("{} is not a readable file", f.display()),
        ));
    }
    check_endpoints("--connect", &args.connect)?;
    let term = crate::engine::interrupt::flag();
    let fleet_key = crate::transport::credentials::read_fleet_key(&args.fleet_key)
        .map_err(|e| cli_error("--fleet-key", e.to_string()))?;
    let opts = AgentOptions {
        fleet_key,
        zenoh: ZenohSettings {
            listen: Vec::new(),
            connect: args.connect.clone(),
            config_file: args.zenoh_config.clone(),
        },
        run_id: args.run_id.clone(),
        host: args.host.clone(),
        node_program: crate::runtime::processes::default_node_program(),
        wait: Duration::from_secs_f64(args.wait),
        verbose: args.verbose,
    };
    match run_agent(&opts, &term) {
        Ok(AgentEnd::Ended) => Ok(()),
        Ok(AgentEnd::Signalled) => Err(CliError::AgentInterrupted),
        Err(e) => Err(CliError::Agent(e)),
    }
}

/// `sonarnet agent` without zenoh compiled in.
#[cfg(not(feature = "zenoh"))]
pub(super) fn agent_command(_args: &AgentArgs) -> Result<(), CliError> {
    Err(cli_error("agent", WITHOUT_ZENOH))
}
