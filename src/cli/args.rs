//! The command line's clap types: subcommands, flags and their help text.

use crate::estimators::gossip::ProxScaling;
use crate::estimators::prox::LocalSolver;
use crate::pipeline::Clock;
use crate::pipeline::EngineKind;
use crate::protocol::TransportKind;
use crate::scenario::Mode;
use clap::Parser;
use clap::Subcommand;
use std::path::PathBuf;

/// Emulated distributed multistatic sonar network: asynchronous Douglas-Rachford
/// gossip with exact GTRS local steps.
#[derive(Debug, Parser)]
#[command(name = "sonarnet", version, about, long_about = None)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
// Parsed once per process: the size of the `run` variant costs nothing.
// `[expect]`: see the note above `ReportArgs` (clap's --help text).
#[allow(clippy::large_enum_variant, rustdoc::broken_intra_doc_links)]
pub enum Command {
    /// Run a scenario and write a results directory.
    Run(RunArgs),
    /// Check scenario files (and the trace, truth and schedule files they name).
    Validate {
        /// Scenario files.
        #[arg(required = true)]
        scenarios: Vec<PathBuf>,
    },
    /// Write the plots and a self-contained HTML report of a results
    /// directory (DIR/report.html), or compare two runs (DIR DIR2).
    Report(ReportArgs),
    /// Measure the multi-process engine: overhead over in-process, start-up,
    /// throughput and memory at scale, realtime throughput.
    Bench(BenchArgs),
    /// Write a commented scenario file from a few layout words; it validates
    /// and runs as written.
    New(NewArgs),
    /// The scenarios built into sonarnet (or the files of --dir), each with
    /// its description and variants.
    List {
        /// List the scenario files of this directory instead.
        #[arg(long)]
        dir: Option<PathBuf>,
    },
    /// What a scenario file runs, in words: nodes, links, samples, noise,
    /// mode, solver, baselines, bounds, faults, channel, [expect].
    Describe {
        /// The scenario TOML file.
        scenario: PathBuf,
        /// Only this variant (repeatable; default: every variant).
        #[arg(long, value_name = "NAME")]
        variant: Vec<String>,
        /// Overrides, as `sonarnet run --set`.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
    },
    /// Run a scenario over a grid of values and seeds, in parallel, into one
    /// directory: sweep.csv, sweep-summary.csv, sweep.svg, report.html.
    Sweep(SweepArgs),
    /// Run DIR/scenario.toml again, as recorded in DIR/run.json, into a
    /// temporary directory and compare the results file by file: exit 0 if
    /// equal, 1 naming the first differing file and row.
    Replay(ReplayArgs),
    /// Start and reap this host's nodes of a run spread over hosts: connect
    /// to the coordinator (`sonarnet run --transport zenoh` with a placement)
    /// and run the nodes it assigns to --host.
    Agent(AgentArgs),
    /// Write a fresh fleet key to FILE (mode 600; never overwritten): the
    /// secret the coordinator (`sonarnet run --fleet-key`) and every agent
    /// (`sonarnet agent --fleet-key`) of runs spread over hosts share.
    FleetKey {
        /// The key file to create.
        #[arg(value_name = "FILE")]
        file: PathBuf,
    },
}

/// `sonarnet agent`.
#[derive(Debug, clap::Args)]
pub struct AgentArgs {
    /// The coordinator's endpoint, e.g. `tcp/10.0.0.1:7447` (repeatable).
    #[arg(long, required = true, value_name = "ENDPOINT")]
    pub connect: Vec<String>,
    /// The run to join, as the coordinator printed it (`--run-id` of `sonarnet
    /// run`): without it the coordinator admits nothing.
    #[arg(long, value_name = "ID")]
    pub run_id: String,
    /// This host's name in the run's placement (`[deploy] hosts`, `--place`).
    #[arg(long, value_name = "NAME")]
    pub host: String,
    /// The fleet's key file, the same as the coordinator's `--fleet-key`
    /// (`sonarnet fleet-key FILE` makes one; readable by its owner only).
    #[arg(long, value_name = "FILE")]
    pub fleet_key: PathBuf,
    /// A zenoh configuration file (JSON5) to start from: TLS, access control.
    #[arg(long, value_name = "FILE")]
    pub zenoh_config: Option<PathBuf>,
    /// Seconds to wait for the coordinator (0.1 to 3600).
    #[arg(long, value_name = "SECONDS", default_value_t = 60.0, value_parser = seconds_up_to_an_hour)]
    pub wait: f64,
    /// Log what the agent does to stderr.
    #[arg(long, short)]
    pub verbose: bool,
}

/// Seconds in [0.1, 3600].
pub(crate) fn seconds_up_to_an_hour(v: &str) -> Result<f64, String> {
    let t: f64 = v
        .parse()
        .map_err(|e| format!("not a number of seconds: {e}"))?;
    if (0.1..=3600.0).contains(&t) {
        Ok(t)
    } else {
        Err(format!("{t} s is outside [0.1, 3600]"))
    }
}

/// `sonarnet new`.
#[derive(Debug, clap::Args)]
pub struct NewArgs {
    /// The scenario file to write.
    pub file: PathBuf,
    /// Receivers: circle:N:RADIUS, line:N:X0,Y0:X1,Y1, grid:RxC:SPACING or
    /// random:N:XMIN,YMIN:XMAX,YMAX (metres; random drawn from --seed).
    #[arg(long, value_name = "LAYOUT", required_unless_present = "from")]
    pub receivers: Option<String>,
    /// Copy the built-in scenario NAME instead (`sonarnet list` names them).
    #[arg(long, value_name = "NAME", conflicts_with_all = ["receivers", "transmitters", "network", "motion", "name", "seed"])]
    pub from: Option<String>,
    /// Transmitters, in the same forms [default: two, a quarter of the
    /// scene either side of its centre].
    #[arg(long, value_name = "LAYOUT")]
    pub transmitters: Option<String>,
    /// The gossip graph: ring, grid (with grid receivers), rgg:RADIUS
    /// (receivers closer than RADIUS metres), or edges (an explicit list to
    /// edit: each receiver to its two nearest).
    #[arg(long, default_value = "ring")]
    pub network: String,
    /// The target's track: spiral, line, waypoints or static.
    #[arg(long, default_value = "spiral")]
    pub motion: String,
    /// Scenario name [default: the file's stem].
    #[arg(long)]
    pub name: Option<String>,
    /// The scenario's seed: an integer in [0, 2^64).
    #[arg(long, default_value_t = 0, value_parser = parse_seed, allow_hyphen_values = true)]
    pub seed: u64,
    /// Overwrite an existing file.
    #[arg(long)]
    pub force: bool,
}

/// `sonarnet sweep`.
#[derive(Debug, clap::Args)]
// `[[variants]]`, `<name>`: see the note above `ReportArgs`.
#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)]
pub struct SweepArgs {
    /// The scenario TOML file.
    pub scenario: PathBuf,
    /// A grid axis, repeatable: a scenario key and its values, each a TOML
    /// value (e.g. `--grid algorithm.gamma=1e-9,1e-8,1e-7`, `--grid
    /// algorithm.mode=sync,async`). Runs the cartesian product of the axes.
    #[arg(long, value_name = "KEY=V1,V2,...", required = true)]
    pub grid: Vec<String>,
    /// Seeds run at every grid point: A..B (A to B inclusive: 0..9 is ten
    /// seeds) or a list 1,5,9 [default: the scenario's seed].
    #[arg(long, value_name = "SEEDS")]
    pub seeds: Option<String>,
    /// Overrides applied before the grid's (as `sonarnet run --set`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Only these variants of a scenario with [[variants]] (repeatable;
    /// default: every variant, as one more grid key).
    #[arg(long, value_name = "NAME")]
    pub variant: Vec<String>,
    /// The engine of every run.
    #[arg(long, value_enum, default_value = "inprocess")]
    pub engine: EngineKind,
    /// Runs at once [default: the number of CPUs; 1 with --engine processes].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=256))]
    pub jobs: Option<u64>,
    /// The metric of sweep.svg and the summary (a metrics.json name; a bare
    /// name means theta_bar's, e.g. rmse_after_burn_in, ctte, ml.rmse).
    #[arg(long, default_value = "rmse_after_burn_in")]
    pub metric: String,
    /// Sweep directory [default: results/<name>-sweep-<grid keys>].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Also draw every run's plots into its directory, as `sonarnet run`
    /// does (off by default: a large sweep spends its time on the runs;
    /// `sonarnet report DIR/runs/<run>` draws one run's later).
    #[arg(long)]
    pub plots: bool,
    /// Hide the progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// `sonarnet replay`.
#[derive(Debug, clap::Args)]
pub struct ReplayArgs {
    /// The results directory of the run to reproduce.
    pub dir: PathBuf,
    /// Keep the replay's results directory (it is kept anyway when they differ).
    #[arg(long)]
    pub keep: bool,
}

// The field docs below are clap's `--help` text, not rustdoc prose: `[expect]`,
// `[[variants]]` and `<DIR2 name>` are the scenario-file and placeholder syntax
// a user types, and escaping them for rustdoc would show the backslashes in
// `--help`. So rustdoc is told they are not links or HTML.
/// `sonarnet report`.
#[derive(Debug, clap::Args)]
#[allow(rustdoc::invalid_html_tags)]
pub struct ReportArgs {
    /// Results directory (and a second one to compare against).
    #[arg(required = true, num_args = 1..=2, value_name = "DIR")]
    pub dirs: Vec<PathBuf>,
    /// Also write every plot as PNG.
    #[arg(long)]
    pub png: bool,
    /// Where to write the comparison page [default: DIR/compare-<DIR2 name>.html].
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

/// `sonarnet bench`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Directory holding mourya2017-spiral.toml.
    #[arg(long, default_value = "scenarios")]
    pub scenarios: PathBuf,
    /// Node counts of the scale runs (comma separated, each in [2, 4096];
    /// e.g. 64,256,1024,2048).
    #[arg(long, alias = "nodes", value_delimiter = ',', default_value = "64,256")]
    pub scale: Vec<usize>,
    /// Repeats of each overhead figure (the best is kept).
    #[arg(long, default_value_t = 5)]
    pub repeats: usize,
    /// Where bench.json goes.
    #[arg(long, default_value = "results/bench")]
    pub out: PathBuf,
}

/// The library's named enums ([`crate::named_enum!`]) on the command line:
/// their names (with `-` for `_` as an alias) and their doc comments as help.
macro_rules! value_enum {
    ($($t:ty),+) => {$(
        impl clap::ValueEnum for $t {
            fn value_variants<'a>() -> &'a [Self] {
                <$t>::ALL
            }
            fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
                let name = self.as_str();
                let v = clap::builder::PossibleValue::new(name).help(self.help());
                Some(if name.contains('_') {
                    v.alias(name.replace('_', "-"))
                } else {
                    v
                })
            }
        }
    )+};
}
value_enum!(
    Mode,
    ProxScaling,
    EngineKind,
    Clock,
    TransportKind,
    LocalSolver
);

impl RunArgs {
    /// `--mode`.
    pub fn mode(&self) -> Option<Mode> {
        self.mode
    }
    /// `--engine`.
    pub fn engine(&self) -> Option<EngineKind> {
        self.engine
    }
    /// `--clock` (logical when not given).
    pub fn clock(&self) -> Clock {
        self.clock.unwrap_or(Clock::Logical)
    }
}

/// `sonarnet run`.
#[derive(Debug, clap::Args)]
// `[expect]`, `[[variants]]`, `<name>`: see the note above `ReportArgs`.
#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)]
pub struct RunArgs {
    /// The scenario TOML file.
    pub scenario: PathBuf,
    /// Override any scenario key by its dotted path, repeatable: the value is
    /// TOML, validated as the file is (e.g. `--set algorithm.gamma=1e-7`,
    /// `--set target.samples=20`, `--set 'geometry.receivers=[[0,0],[1,1]]'`,
    /// `--set faults[0].at_s=12`). Applied after a variant's own keys.
    #[arg(help_heading = "Scenario", long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Gossip mode (overrides algorithm.mode).
    #[arg(help_heading = "Algorithm", long, value_enum)]
    pub mode: Option<Mode>,
    /// Prox scaling of async gossip (overrides algorithm.prox_scaling): none
    /// (eq. 11) or inverse_probability (eq. 5, each node's step gamma / p_v;
    /// `inverse-probability` is accepted too).
    #[arg(help_heading = "Algorithm", long, value_enum)]
    pub prox_scaling: Option<ProxScaling>,
    /// Local prox (overrides algorithm.local_solver).
    #[arg(help_heading = "Algorithm", long, value_enum)]
    pub local_solver: Option<LocalSolver>,
    /// Outlier budget of gtrs_l0: rows of each node's local cost that may be
    /// separated as outliers (overrides algorithm.kappa; must be below every
    /// node's row count; ignored by gtrs and relaxed).
    #[arg(help_heading = "Algorithm", long, value_name = "K")]
    pub kappa: Option<usize>,
    /// Run seed (overrides the scenario's seed): an integer in [0, 2^64).
    #[arg(help_heading = "Scenario", long, value_parser = parse_seed, allow_hyphen_values = true)]
    pub seed: Option<u64>,
    /// Douglas-Rachford iterations per sample (overrides the scenario).
    #[arg(help_heading = "Algorithm", long)]
    pub iterations_per_sample: Option<usize>,
    /// A fault to inject, repeatable, after the scenario's [[faults]]:
    /// KIND:KEY=VALUE,... with the keys of a [[faults]] entry, e.g.
    /// `pause:node=3,at_s=20,for_s=10` or
    /// `partition:groups=[[0,1,2],[3,4,5]],at_sample=30,for_samples=20`
    /// (the book's scenario reference, [[faults]]).
    #[arg(
        help_heading = "Faults",
        long = "fault",
        value_name = "KIND:KEY=VALUE,..."
    )]
    pub faults: Vec<String>,
    /// Random faults drawn from the run seed: a comma-separated list of
    /// kinds (pause, crash, restart, partition, link_loss, delay,
    /// clock_drift), one every --nemesis-interval-s emulated seconds.
    #[arg(help_heading = "Faults", long, value_name = "KINDS")]
    pub nemesis: Option<String>,
    /// Emulated seconds between two nemesis faults.
    #[arg(
        help_heading = "Faults",
        long,
        value_name = "SECONDS",
        default_value_t = 30.0
    )]
    pub nemesis_interval_s: f64,
    /// Number of samples to run (overrides target.samples; with a trace, at
    /// most its length; must exceed algorithm.burn_in).
    #[arg(help_heading = "Scenario", long)]
    pub samples: Option<usize>,
    /// Results directory [default: results/<name>-<mode>-<engine>-seed<seed>,
    /// plus every override given (solver, kappa, poll, --set keys, ...; a
    /// short hash when long)]. A previous run's files in it are replaced; a
    /// directory holding other files is refused.
    #[arg(help_heading = "Output", long)]
    pub out: Option<PathBuf>,
    /// Which engine runs the nodes: one OS process per receiver over iceoryx2
    /// shared memory, all nodes in this process, or one thread per node over
    /// the in-memory transport (exact same numbers) [default: processes;
    /// inprocess for Monte Carlo runs and on the acoustic channel].
    #[arg(help_heading = "Engine and clock", long, value_enum)]
    pub engine: Option<EngineKind>,
    /// Run only this variant of a scenario with [[variants]] (repeatable;
    /// default: every variant, one results directory each).
    #[arg(help_heading = "Scenario", long, value_name = "NAME")]
    pub variant: Vec<String>,
    /// Monte Carlo: repeat the run with seeds seed..seed+N in parallel
    /// (in-process); overrides [monte_carlo] trials. 1 = a single run.
    #[arg(help_heading = "Evaluation", long, value_name = "N")]
    pub trials: Option<usize>,
    /// Centralised baselines to score next to the distributed track, with
    /// default parameters, replacing the scenario's [[baselines]]
    /// (comma separated: ogd, onm, ml, ls, l0os, lq_irls, lad, pocs, lls,
    /// sdp, distributed; l0os needs p or kappa, so give it in the file).
    #[arg(
        help_heading = "Evaluation",
        long,
        value_delimiter = ',',
        value_name = "KINDS"
    )]
    pub baselines: Option<Vec<String>>,
    /// Exit with code 1 when an [expect] check of the scenario fails.
    #[arg(help_heading = "Evaluation", long)]
    pub check: bool,
    /// Clock of async runs: `logical` (the coordinator draws every pair;
    /// exact, reproducible) or `realtime` (free-running nodes on Poisson
    /// clocks, [realtime] table of the scenario: wall time with --engine
    /// processes, virtual time with --engine inprocess) [default: the
    /// scenario's algorithm.clock, else realtime on the acoustic channel, else
    /// logical].
    #[arg(help_heading = "Engine and clock", long, value_enum)]
    pub clock: Option<Clock>,
    /// Record every node's theta after every iteration into iterations.csv
    /// (used by consensus.svg).
    #[arg(help_heading = "Engine and clock", long)]
    pub trace_iterations: bool,
    /// Multi-process engine: let each node process poll its inbox for up to N
    /// microseconds (yielding the CPU between checks) before it blocks. Trades CPU
    /// for latency while gossip messages are due within microseconds; 0, the
    /// default, blocks at once (idle nodes use ~0 % CPU either way, after N us).
    #[arg(help_heading = "Engine and clock", long, value_name = "N", default_value_t = 0, value_parser = clap::value_parser!(u64).range(0..=1_000_000))]
    pub poll_us: u64,
    /// Liveness watchdog, in seconds (0.1 to 3600). Logical clocks: when no
    /// node has reported for half of it, every node is pinged, and a node
    /// that does not answer within the other half (stopped, wedged) ends the
    /// run, named, with the partial results written. Realtime: a node that
    /// has not answered a snapshot within it is left out like a dead node.
    #[arg(help_heading = "Engine and clock", long, value_name = "SECONDS", default_value_t = 5.0, value_parser = stall_timeout)]
    pub stall_timeout: f64,
    /// Transport between the node processes: iceoryx2 (shared memory, every
    /// node on this host) or zenoh (TCP; nodes here or on other hosts). Needs
    /// --engine processes (the default with zenoh).
    #[arg(help_heading = "Across hosts (zenoh)", hide = !cfg!(feature = "zenoh"), long, value_enum, default_value_t = TransportKind::Iceoryx2)]
    pub transport: TransportKind,
    /// zenoh: the endpoint the coordinator listens on (repeatable)
    /// [default: a free loopback port; with a placement, tcp/0.0.0.0:7447].
    #[arg(help_heading = "Across hosts (zenoh)", hide = !cfg!(feature = "zenoh"), long, value_name = "ENDPOINT")]
    pub listen: Vec<String>,
    /// zenoh: place nodes on hosts, HOST=NODES (repeatable; ranges allowed:
    /// `a=0-2 b=3,4,5`), replacing the scenario's [deploy]. Host `local` is
    /// this one; every other host needs `sonarnet agent`.
    #[arg(help_heading = "Across hosts (zenoh)", hide = !cfg!(feature = "zenoh"), long = "place", value_name = "HOST=NODES")]
    pub place: Vec<String>,
    /// zenoh: the run id the agents give (`sonarnet agent --run-id`)
    /// [default: a fresh one with a 64-bit random secret, printed].
    #[arg(help_heading = "Across hosts (zenoh)", hide = !cfg!(feature = "zenoh"), long, value_name = "ID")]
    pub run_id: Option<String>,
    /// zenoh: a zenoh configuration file (JSON5) to start from: TLS
    /// certificates, your own access control (the book, "Across hosts").
    #[arg(help_heading = "Across hosts (zenoh)", hide = !cfg!(feature = "zenoh"), long, value_name = "FILE")]
    pub zenoh_config: Option<PathBuf>,
    /// zenoh: the fleet's key file, which the agents of a placement log in
    /// with (`sonarnet fleet-key FILE` makes one; copy it to every host,
    /// readable by its owner only). Needed when nodes are on other hosts.
    #[arg(help_heading = "Across hosts (zenoh)", hide = !cfg!(feature = "zenoh"), long, value_name = "FILE")]
    pub fleet_key: Option<PathBuf>,
    /// zenoh: seconds to wait for the agents of a placement (0.1 to 3600).
    #[arg(help_heading = "Across hosts (zenoh)", hide = !cfg!(feature = "zenoh"), long, value_name = "SECONDS", default_value_t = 30.0, value_parser = seconds_up_to_an_hour)]
    pub agent_wait: f64,
    /// Log coordinator and node events (with node ids) to stderr.
    #[arg(help_heading = "Output", long, short)]
    pub verbose: bool,
    /// Hide the progress bar.
    #[arg(help_heading = "Output", long)]
    pub quiet: bool,
    /// Also write report.html into the results directory.
    #[arg(help_heading = "Output", long)]
    pub report: bool,
    /// Also write every plot as PNG, beside its SVG.
    #[arg(long, help_heading = "Output")]
    pub png: bool,
}

/// `--stall-timeout`: seconds in [`STALL_TIMEOUT_RANGE_S`](crate::protocol::plan::STALL_TIMEOUT_RANGE_S).
fn stall_timeout(v: &str) -> Result<f64, String> {
    let r = crate::protocol::plan::STALL_TIMEOUT_RANGE_S;
    let t: f64 = v
        .parse()
        .map_err(|e| format!("not a number of seconds: {e}"))?;
    if r.contains(&t) {
        Ok(t)
    } else {
        Err(format!("must be in [{}, {}] seconds", r.start(), r.end()))
    }
}

/// A `--seed` value: an integer in [0, 2^64), with a reason a user can act on
/// (clap's own says `invalid digit found in string`, or suggests `-- -1`).
pub fn parse_seed(text: &str) -> Result<u64, String> {
    let t = text.trim();
    t.parse::<u64>().map_err(|_| {
        let why = if t.starts_with('-') {
            "it is negative"
        } else if t.is_empty() {
            "it is empty"
        } else if t.parse::<f64>().is_ok_and(f64::is_finite) && t.parse::<u128>().is_err() {
            if t.contains(['.', 'e', 'E']) {
                "write it as a whole number in digits"
            } else {
                "it is 2^64 or more"
            }
        } else if t.parse::<u128>().is_ok() {
            "it is 2^64 or more"
        } else {
            "it is not a number"
        };
        format!("a seed is an integer in [0, 2^64), e.g. 0 or 42; {text:?} is not one: {why}")
    })
}
