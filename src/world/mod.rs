//! The emulated world every engine runs in, I/O-free: what happens to the
//! nodes and the links between them, apart from the protocol itself.
//!
//! [`faults`] is the fault schedule and the state it leaves the nodes in.
//! The engines (`crate::engine`) carry its steps out in their own media:
//! virtual time and node cores in the discrete-event engine, signals and
//! processes in the processes engine.

pub mod faults;
