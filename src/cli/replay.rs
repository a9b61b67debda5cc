//! `sonarnet replay`: run a results directory's scenario again as it ran,
//! and compare the results.

use super::args::{Cli, Command, ReplayArgs};
use super::errors::CliError;
use crate::pipeline::RunStatus;
use clap::Parser;

/// The longest `run.json` replay reads (a real one is a few kB).
const MAX_RUN_JSON_BYTES: u64 = 16 << 20;

/// `sonarnet replay DIR`: run `DIR/scenario.toml` with the engine, clock,
/// polling and watchdog of `DIR/run.json` into a temporary directory, and
/// compare ([`crate::pipeline::replay::compare_results`]).
pub(super) fn replay_command(args: &ReplayArgs) -> Result<(), CliError> {
    let dir = &args.dir;
    let bad =
        |reason: String| -> CliError { crate::model::error::InputError::file(dir, reason).into() };
    let scenario = dir.join("scenario.toml");
    if !scenario.is_file() {
        return Err(bad(
            "has no scenario.toml: not a results directory, or written by a sonarnet older than replay"
                .into(),
        ));
    }
    let run_json = dir.join("run.json");
    let too_long = std::fs::metadata(&run_json).is_ok_and(|m| m.len() > MAX_RUN_JSON_BYTES);
    if too_long {
        return Err(bad(format!(
            "run.json is longer than the {MAX_RUN_JSON_BYTES} bytes sonarnet ever writes there"
        )));
    }
    let rj: crate::pipeline::RunJson = std::fs::read_to_string(&run_json)
        .map_err(|e| bad(format!("cannot read run.json: {e}")))
        .and_then(|t| serde_json::from_str(&t).map_err(|e| bad(format!("run.json: {e}"))))?;
    let engine = rj.engine.as_deref().unwrap_or("inprocess");
    let clock = rj.clock.as_deref().unwrap_or("logical");
    if engine == "processes" && clock == "realtime" {
        return Err(bad(
            "is a realtime run of node processes, which depends on wall-clock timing and cannot be \
             reproduced exactly; runs on the logical clock, or in virtual time (--engine inprocess), replay"
                .into(),
        ));
    }
    if rj.status == Some(RunStatus::Interrupted) {
        return Err(bad(
            "was interrupted: there is no complete run to reproduce".into(),
        ));
    }
    let out = std::env::temp_dir().join(format!(
        "sonarnet-replay-{}-{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos())
    ));
    let mut argv: Vec<String> = ["sonarnet", "run"].map(String::from).to_vec();
    argv.push(scenario.display().to_string());
    for (flag, v) in [
        ("--engine", Some(engine.to_string())),
        ("--clock", Some(clock.to_string())),
        ("--poll-us", rj.poll_us.map(|p| p.to_string())),
        ("--stall-timeout", rj.stall_timeout_s.map(|s| s.to_string())),
        ("--out", Some(out.display().to_string())),
    ] {
        if let Some(v) = v {
            argv.push(flag.into());
            argv.push(v);
        }
    }
    argv.push("--quiet".into());
    let Command::Run(run_args) = Cli::try_parse_from(&argv)
        .map_err(|e| bad(format!("run.json does not make a valid run command: {e}")))?
        .command
    else {
        return Err(bad("run.json does not make a run command".into()));
    };
    println!(
        "replaying {} ({engine}, {clock} clock) into {}",
        dir.display(),
        out.display()
    );
    match super::run_command(run_args) {
        Ok(()) => {}
        // A failed run is reproduced too: its partial results are compared.
        Err(CliError::RunFailed { .. }) if rj.status == Some(RunStatus::Failed) => {}
        Err(e) => return Err(e),
    }
    let diff = crate::pipeline::replay::compare_results(dir, &out)
        .map_err(|e| bad(format!("cannot compare: {}", super::one_line(&e))))?;
    match diff {
        Some(diff) => Err(CliError::ReplayDiffers {
            original: dir.clone(),
            replay: out,
            diff: Box::new(diff),
        }),
        None => {
            println!("replay of {}: identical results", dir.display());
            if args.keep {
                println!("the replay's results are in {}", out.display());
            } else {
                let _ = std::fs::remove_dir_all(&out);
            }
            Ok(())
        }
    }
}
