//! The fixed-size frame every message travels in between processes.
//!
//! This module is I/O-free: it only defines the plain `#[repr(C)]` record.
//! The protocol module encodes its messages into frames and decodes them back;
//! the transport module moves frames (and is the only place that knows iceoryx2).

/// One fixed-size, plain-old-data message frame (64 bytes).
///
/// Field meaning depends on `kind` (see the protocol module's codec).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Frame {
    /// Message kind tag.
    pub kind: u32,
    /// Sender id (`u32::MAX` for the coordinator).
    pub from: u32,
    /// Sample index this frame belongs to.
    pub sample: u32,
    /// Kind-specific small integer (partner id, transmitter index, count, ...).
    pub aux: u32,
    /// Iteration or round counter (global, monotone).
    pub seq: u64,
    /// Kind-specific payload (a lifted point `[x, y, d]`, a measurement value, ...).
    pub data: [f64; 5],
}

/// The sender id used by the coordinator.
pub const COORDINATOR_ID: u32 = u32::MAX;
