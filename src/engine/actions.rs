//! The coordinator's actions, carried out once for every engine.
//!
//! The [`Coordinator`](crate::protocol::coordinator::Coordinator) is I/O-free:
//! it returns [`Action`]s. What each action means is the same on every
//! engine and is decided here ([`carry_out`]): in order; a message that
//! cannot be sent ends the run with that error; [`Action::Done`] (always the
//! last of a batch) ends it with the coordinator's result. What an engine
//! supplies is how to send, flush, keep a timer, log and make sure an
//! abandoned node is gone ([`Actuator`]): the discrete-event engine
//! schedules events in virtual time, [`crate::engine::drive`] talks to a
//! [`crate::engine::Network`] on the wall clock.

use crate::engine::Progress;
use crate::protocol::EngineError;
use crate::protocol::codec::Control;
use crate::protocol::coordinator::{Action, Timer};
use std::time::Duration;

/// An engine's side of the coordinator: what its actions do there.
pub trait Actuator {
    /// Queue `msg` for node `node`.
    fn send(&mut self, node: u32, msg: Control) -> Result<(), EngineError>;
    /// Deliver everything queued.
    fn flush(&mut self) -> Result<(), EngineError>;
    /// Deliver `timer` to the coordinator at `at` (from the start of the run).
    fn set_timer(&mut self, at: Duration, timer: Timer);
    /// `samples` samples are complete.
    fn sample_done(&mut self, samples: usize);
    /// A line of the coordinator's verbose log.
    fn log(&mut self, line: &str);
    /// The coordinator gave up on `node`: make sure it is gone.
    fn abandon(&mut self, node: u32);
}

/// Carry out `actions` (drained, in order) on `engine`, telling `progress`
/// of every completed sample. `Some(result)` when the run is over: the
/// coordinator said so ([`Action::Done`]), or an action could not be carried
/// out (the actions after it are dropped).
pub fn carry_out(
    actions: &mut Vec<Action>,
    engine: &mut dyn Actuator,
    progress: Progress<'_>,
) -> Option<Result<(), EngineError>> {
    for a in actions.drain(..) {
        let r = match a {
            Action::Send { node, msg } => engine.send(node, msg),
            Action::Flush => engine.flush(),
            Action::SetTimer { at, timer } => {
                engine.set_timer(at, timer);
                Ok(())
            }
            Action::Progress {
                samples,
                iterations,
            } => {
                engine.sample_done(samples);
                progress(samples, iterations);
                Ok(())
            }
            Action::Log(line) => {
                engine.log(&line);
                Ok(())
            }
            Action::Abandon { node } => {
                engine.abandon(node);
                Ok(())
            }
            Action::Done(r) => return Some(r),
        };
        if let Err(e) = r {
            return Some(Err(e));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::{Actuator, carry_out};
    use crate::protocol::EngineError;
    use crate::protocol::codec::Control;
    use crate::protocol::coordinator::{Action, Timer};
    use std::time::Duration;

    /// Writes down what it is asked; sends to node 9 fail.
    #[derive(Default)]
    struct Log(Vec<String>);

    impl Actuator for Log {
        fn send(&mut self, node: u32, msg: Control) -> Result<(), EngineError> {
            if node == 9 {
                return Err(EngineError::Stalled("node 9 is gone".into()));
            }
            self.0.push(format!("send {node} {msg:?}"));
            Ok(())
        }
        fn flush(&mut self) -> Result<(), EngineError> {
            self.0.push("flush".into());
            Ok(())
        }
        fn set_timer(&mut self, at: Duration, timer: Timer) {
            self.0.push(format!("timer {at:?} {timer:?}"));
        }
        fn sample_done(&mut self, samples: usize) {
            self.0.push(format!("samples {samples}"));
        }
        fn log(&mut self, line: &str) {
            self.0.push(format!("log {line}"));
        }
        fn abandon(&mut self, node: u32) {
            self.0.push(format!("abandon {node}"));
        }
    }

    #[test]
    fn actions_are_carried_out_in_order_and_progress_is_told_of_every_sample() {
        let mut engine = Log::default();
        let mut seen = Vec::new();
        let mut actions = vec![
            Action::Send {
                node: 1,
                msg: Control::Stop,
            },
            Action::Flush,
            Action::Progress {
                samples: 3,
                iterations: 30,
            },
            Action::Log("hello".into()),
            Action::Abandon { node: 2 },
        ];
        let r = carry_out(&mut actions, &mut engine, &mut |s, i| seen.push((s, i)));
        assert!(r.is_none(), "the run goes on");
        assert!(actions.is_empty());
        assert_eq!(
            engine.0,
            vec![
                "send 1 Stop",
                "flush",
                "samples 3",
                "log hello",
                "abandon 2"
            ]
        );
        assert_eq!(seen, vec![(3, 30)]);
    }

    #[test]
    fn done_ends_the_run_with_the_coordinators_result() {
        let mut engine = Log::default();
        let mut actions = vec![Action::Flush, Action::Done(Ok(()))];
        let r = carry_out(&mut actions, &mut engine, &mut |_, _| {});
        assert!(matches!(r, Some(Ok(()))));
        assert_eq!(engine.0, vec!["flush"]);
    }

    #[test]
    fn a_message_that_cannot_be_sent_ends_the_run_and_drops_the_rest() {
        let mut engine = Log::default();
        let mut actions = vec![
            Action::Send {
                node: 9,
                msg: Control::Stop,
            },
            Action::Flush,
        ];
        let r = carry_out(&mut actions, &mut engine, &mut |_, _| {});
        assert!(matches!(r, Some(Err(EngineError::Stalled(_)))));
        assert!(engine.0.is_empty(), "{:?}", engine.0);
        assert!(actions.is_empty());
    }
}
