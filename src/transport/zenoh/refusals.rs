//! A line on standard error for each peer the coordinator's router refuses
//! at the handshake: zenoh reports the refusal only in its own debug log
//! (target [`TARGET`]), which this layer reads whatever `RUST_LOG` says.

use tracing_core::field::{Field, Visit};
use tracing_core::{Event, Subscriber};
use tracing_subscriber::Layer;
use tracing_subscriber::filter::{LevelFilter, Targets};
use tracing_subscriber::layer::Context;

/// Where zenoh logs a handshake it refused, at debug level.
pub const TARGET: &str = "zenoh_transport::unicast::establishment::accept";

/// Why zenoh refused a peer, from its log `message`; `None` if the message
/// is no refusal for credentials.
pub fn reason(message: &str) -> Option<&'static str> {
    if !message.contains("UsrPwd") {
        return None;
    }
    Some(if message.contains("Invalid password") {
        "with a wrong password for its user"
    } else if message.contains("Invalid user") {
        "with a user this run does not have"
    } else if message.contains("Expected extension") {
        "without credentials"
    } else {
        "whose credentials did not check"
    })
}

struct Message(String);

impl Visit for Message {
    fn record_debug(&mut self, field: &Field, value: &dyn std::fmt::Debug) {
        if field.name() == "message" {
            self.0 = format!("{value:?}");
        }
    }
}

struct Refusals;

impl<S: Subscriber> Layer<S> for Refusals {
    fn on_event(&self, event: &Event<'_>, _ctx: Context<'_, S>) {
        let mut m = Message(String::new());
        event.record(&mut m);
        if let Some(why) = reason(&m.0) {
            eprintln!("warning: refused a zenoh peer {why} (it is not a party of this run)");
        }
    }
}

/// The layer, reading only [`TARGET`]'s debug events.
pub fn layer<S>() -> impl Layer<S>
where
    S: Subscriber + for<'a> tracing_subscriber::registry::LookupSpan<'a>,
{
    Refusals.with_filter(Targets::new().with_target(TARGET, LevelFilter::DEBUG))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zenohs_refusals_read_as_their_reason_and_other_lines_as_none() {
        assert_eq!(
            reason("UsrPwd extension - Recv OpenSyn. Invalid password."),
            Some("with a wrong password for its user")
        );
        assert_eq!(
            reason("UsrPwd extension - Recv OpenSyn. Invalid user."),
            Some("with a user this run does not have")
        );
        assert_eq!(
            reason("UsrPwd extension - Recv InitSyn. Expected extension."),
            Some("without credentials")
        );
        assert_eq!(reason("Received a close message"), None);
    }
}
