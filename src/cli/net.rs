//! The network flags of `sonarnet run` (`--transport`, `--listen`, `--place`,
//! `--run-id`, `--zenoh-config`, `--agent-wait`) and `sonarnet agent`.

use super::*;
use crate::model::error::InputError;
use crate::pipeline::NetOptions;
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

/// The network options of a run, checked before anything starts.
pub(super) fn net_options(
    args: &RunArgs,
    sc: &Scenario,
    engine: EngineKind,
) -> Result<NetOptions, CliError> {
    if args.transport == TransportArg::Iceoryx2 {
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
        let p = Placement::parse(&args.place).map_err(|e| cli_error("--place", e))?;
        p.validate(sc.graph.len())
            .map_err(|e| cli_error("--place", e))?;
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
        let port = listen
            .first()
            .and_then(|l| l.rsplit(':').next())
            .unwrap_or("7447");
        eprintln!(
            "run id {id}: waiting up to {} s for the agents of {} on {}; on each host run",
            args.agent_wait,
            p.agents().join(", "),
            listen.join(", ")
        );
        for h in p.agents() {
            eprintln!(
                "  sonarnet agent --connect tcp/<this host's address>:{port} --run-id {id} --host {h}"
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
    })
}

/// `sonarnet agent`.
#[cfg(feature = "zenoh")]
pub(super) fn agent_command(args: &AgentArgs) -> Result<(), CliError> {
    use crate::engine::agent::{AgentEnd, AgentOptions, run_agent};
    crate::transport::validate_run_id(&args.run_id)
        .map_err(|e| cli_error("--run-id", e.to_string()))?;
    Placement {
        hosts: [(args.host.clone(), vec![0])].into(),
    }
    .validate(1)
    .map_err(|e| cli_error("--host", e))?;
    if let Some(f) = &args.zenoh_config
        && !f.is_file()
    {
        return Err(cli_error(
            "--zenoh-config",
            format!("{} is not a readable file", f.display()),
        ));
    }
    let term = crate::engine::interrupt::flag();
    let opts = AgentOptions {
        zenoh: ZenohSettings {
            listen: Vec::new(),
            connect: args.connect.clone(),
            config_file: args.zenoh_config.clone(),
        },
        run_id: args.run_id.clone(),
        host: args.host.clone(),
        node_program: crate::engine::processes::default_node_program(),
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
