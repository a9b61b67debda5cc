//! The gossip mode of the Douglas-Rachford algorithm (seed 002 Sec. II-B).

use serde::{Deserialize, Serialize};

/// Gossip mode of the Douglas-Rachford engine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// Every node updates every iteration; positions averaged over all nodes.
    Sync,
    /// One random edge `(v, w)` per iteration (seed 002 eq. 11).
    Async,
}

impl Mode {
    /// Lower-case name as used in files.
    pub fn as_str(self) -> &'static str {
        match self {
            Mode::Sync => "sync",
            Mode::Async => "async",
        }
    }
}
