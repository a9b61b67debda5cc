//! The emulated world every engine runs in, I/O-free: what happens to the
//! nodes and the links between them, apart from the protocol itself.
//!
//! - [`medium`]: the channel between the nodes (ideal or acoustic): every
//!   frame's route, delay, fate and record.
//! - [`faults`]: the fault schedule and the state it leaves the nodes in.
//! - [`time`]: emulated time as the engines order it.
//!
//! The engines (`crate::engine`) carry the world out in their own media:
//! virtual time and node cores in the discrete-event engine, wall time,
//! signals and processes in the processes engine. Neither re-implements a
//! route or a fault.

pub mod faults;
pub mod medium;
pub mod time;
