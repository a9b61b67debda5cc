//! `sonarnet`: thin entry point; see `sonarnet::cli`.

use clap::Parser;
use std::process::ExitCode;

// The node program, compiled in so that `sonarnet __node` can stand in for
// `sonarnet-node` when only this binary was built (`cargo run`).
#[path = "../nodes/main.rs"]
#[allow(dead_code)]
mod node_program;

fn main() -> ExitCode {
    let mut argv = std::env::args_os();
    if std::env::args_os().nth(1).is_some_and(|a| a == "__node") {
        let prog = argv.next().unwrap_or_default();
        let rest = argv.skip(1);
        return node_program::node_main(std::iter::once(prog).chain(rest));
    }
    quiet_on_a_closed_pipe();
    let cli = sonarnet::cli::Cli::parse();
    match sonarnet::cli::dispatch(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprint!("{}", sonarnet::cli::error_report(&e));
            ExitCode::from(e.exit_code())
        }
    }
}

/// `sonarnet list | head` closes standard output early: like any Unix tool,
/// stop quietly then instead of panicking in `println!`. SIGPIPE itself stays
/// ignored (as Rust sets it), so that a closed socket to a node is an error
/// the engine handles, not the end of the coordinator.
fn quiet_on_a_closed_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let msg = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if msg.starts_with("failed printing to stdout") && msg.contains("Broken pipe") {
            std::process::exit(0);
        }
        default(info);
    }));
}
