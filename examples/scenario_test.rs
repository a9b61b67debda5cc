//! A scenario-driven check as a user writes it in their own crate: load a
//! shipped scenario, run it for a few seeds in this process, and judge the
//! distributed track against the centralised ML estimate and the scenario's
//! own `[expect]` block. Nothing is written to disk.
//!
//! `cargo run --release --example scenario_test`

use sonarnet::pipeline::{EngineKind, RunOptions};
use sonarnet::scenario::Scenario;
use std::process::ExitCode;

fn main() -> ExitCode {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/mourya2017-spiral.toml"
    );
    let base = match Scenario::from_file(path) {
        Ok(sc) => sc,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let opts = RunOptions::inprocess();
    let mut ok = true;
    println!("seed  theta_bar rmse_after_burn_in  ml rmse  [expect]");
    for seed in 0..4 {
        let out = base.clone().with_seed(seed).run(&opts);
        if let Some(e) = &out.run.error {
            eprintln!("seed {seed}: the run stopped: {e}");
            ok = false;
            continue;
        }
        let flat = out.flat();
        let rmse = out.metrics.rmse_after_burn_in.unwrap_or(f64::NAN);
        let ml = flat.get("ml.rmse").copied().unwrap_or(f64::NAN);
        let held = out.metrics.expect.iter().filter(|c| c.holds).count();
        println!(
            "{seed:>4}  {rmse:>27.3}  {ml:>7.3}  {held}/{}",
            out.metrics.expect.len()
        );
        ok &= held == out.metrics.expect.len();
    }
    // The same numbers from the node program's loop on threads.
    let threads = base.run(&opts.clone().with_engine(EngineKind::Threads));
    let inproc = base.run(&opts);
    let same = threads.run.record.thetas == inproc.run.record.thetas;
    println!("threads engine gives the in-process thetas: {same}");
    ok &= same;
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
