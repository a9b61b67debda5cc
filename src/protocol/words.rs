//! Protocol messages in words, for the verbose log (`--verbose`): one line
//! per event, `[node 3] sample 12: 3 measurements`, never a `Debug` dump.

use super::messages::{Command, Counters, Report};

impl Command {
    /// What this command asks, in words.
    pub fn in_words(&self) -> String {
        match self {
            Command::Sample { sample, meas, .. } => format!(
                "sample {sample}: {} measurements",
                meas.bistatic.len() + meas.doa.is_some() as usize + meas.range.is_some() as usize
            ),
            Command::SyncRounds {
                sample,
                first_round,
                rounds,
            } => format!("sample {sample}: {rounds} synchronous rounds from round {first_round}"),
            Command::AsyncPlan { sample, steps } => {
                let partners: std::collections::BTreeSet<u32> = steps.iter().map(|s| s.1).collect();
                format!(
                    "sample {sample}: plan of {} pair steps with nodes {}",
                    steps.len(),
                    partners
                        .iter()
                        .map(u32::to_string)
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            }
            Command::Tick => "clock tick: starts an exchange".into(),
            Command::ExchangeTimeout { seq } => format!("exchange {seq} timed out: gives it up"),
            Command::RoundTimeout { seq } => format!("round/iteration {seq} timed out: goes on"),
            Command::Snapshot { sample } => format!("snapshot for sample {sample}"),
            Command::NodeUp { node } => format!("node {node} is up again"),
            Command::NodeDown { node } => format!("node {node} is down: never picked again"),
        }
    }
}

impl Counters {
    /// The counters in words.
    pub fn in_words(&self) -> String {
        format!(
            "{} prox solves, {} messages out, {} in, {} declines, {} timeouts",
            self.prox_solves, self.messages_out, self.messages_in, self.declines, self.timeouts
        )
    }
}

impl Report {
    /// What this report says, in words.
    pub fn in_words(&self) -> String {
        // The position part of theta: (x, y) in 2-D, (x, y, z) in 3-D.
        let xy = |t: &crate::model::coords::Coords| {
            let p: Vec<String> = t
                .position()
                .as_slice()
                .iter()
                .map(|v| format!("{v:.2}"))
                .collect();
            format!("({})", p.join(", "))
        };
        match self {
            Report::SampleDone {
                sample,
                theta,
                counters,
                ..
            } => format!(
                "sample {sample} done at {}; {}",
                xy(theta),
                counters.in_words()
            ),
            Report::IterationDone {
                iteration, theta, ..
            } => format!("iteration {iteration} done at {}", xy(theta)),
            Report::Snapshot {
                sample,
                theta,
                counters,
                ..
            } => format!(
                "snapshot of sample {sample} at {}; {}",
                xy(theta),
                counters.in_words()
            ),
            Report::Failed { sample, reason, .. } => format!("failed at sample {sample}: {reason}"),
        }
    }
}

/// Write `[who] text` to stderr as one whole line, in a single write: lines
/// of concurrent processes never interleave within a line.
pub fn log_line(who: &str, text: &str) {
    use std::io::Write;
    let line = format!("[{who}] {text}\n");
    let _ = std::io::stderr().lock().write_all(line.as_bytes());
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::coords::Coords;

    #[test]
    fn every_command_and_report_reads_as_one_line_of_words() {
        let c = Counters::default();
        let cmds = [
            Command::AsyncPlan {
                sample: 3,
                steps: vec![(1, 2), (4, 5), (6, 2)],
            },
            Command::SyncRounds {
                sample: 1,
                first_round: 10,
                rounds: 5,
            },
            Command::Tick,
            Command::NodeDown { node: 4 },
        ];
        let reports = [
            Report::SampleDone {
                node: 1,
                sample: 2,
                theta: Coords::from([1.0, 2.0, 0.0]),
                counters: c,
            },
            Report::Failed {
                node: 1,
                sample: 2,
                failure: crate::estimators::prox::gtrs::ProxFailure::Degenerate,
                reason: "prox".into(),
            },
        ];
        let lines: Vec<String> = cmds
            .iter()
            .map(Command::in_words)
            .chain(reports.iter().map(Report::in_words))
            .collect();
        assert_eq!(lines[0], "sample 3: plan of 3 pair steps with nodes 2, 5");
        assert_eq!(
            lines[4],
            "sample 2 done at (1.00, 2.00); 0 prox solves, 0 messages out, 0 in, 0 declines, 0 timeouts"
        );
        for l in &lines {
            assert!(
                !l.contains('\n') && !l.contains('{') && !l.contains("::"),
                "{l}"
            );
        }
    }
}
