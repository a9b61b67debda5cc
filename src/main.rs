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
    let cli = sonarnet::cli::Cli::parse();
    match sonarnet::cli::dispatch(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprint!("{}", sonarnet::cli::error_report(&e));
            ExitCode::from(e.exit_code())
        }
    }
}
