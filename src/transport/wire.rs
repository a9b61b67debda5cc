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

/// The kind of a frame a transport that knows who sent it found to come
/// from a process other than the node it claims (`from`: the node the
/// process is, `u32::MAX` if none; `aux`: the claimed sender). No sender
/// writes it.
pub const IMPOSTOR: u32 = 0xFFFF_FFF0;

/// Bytes of one [`Frame`] on a byte stream (little-endian, field order).
pub const FRAME_BYTES: usize = 64;

impl Frame {
    /// This frame as it came from `real`, the sender a transport knows it
    /// came from (`None`: no endpoint of the run): itself if that is the
    /// sender it names, or the coordinator (which relays the nodes' gossip
    /// in their names, under link faults and on the acoustic channel); else
    /// an [`IMPOSTOR`] frame naming the real sender (`from`, `u32::MAX` for
    /// none) and the claimed one (`aux`).
    pub fn as_sent_by(self, real: Option<u32>) -> Frame {
        if real == Some(self.from) || real == Some(COORDINATOR_ID) {
            return self;
        }
        Frame {
            kind: IMPOSTOR,
            from: real.unwrap_or(u32::MAX),
            aux: self.from,
            ..self
        }
    }

    /// Appends the frame's [`FRAME_BYTES`] little-endian bytes to `out`
    /// (byte transports such as zenoh; shared memory moves the record itself).
    pub fn put_bytes(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.kind.to_le_bytes());
        out.extend_from_slice(&self.from.to_le_bytes());
        out.extend_from_slice(&self.sample.to_le_bytes());
        out.extend_from_slice(&self.aux.to_le_bytes());
        out.extend_from_slice(&self.seq.to_le_bytes());
        for x in &self.data {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }

    /// The frames of `bytes` as written by [`Frame::put_bytes`]; `None` if
    /// its length is not a multiple of [`FRAME_BYTES`].
    pub fn from_bytes(bytes: &[u8]) -> Option<Vec<Frame>> {
        if !bytes.len().is_multiple_of(FRAME_BYTES) {
            return None;
        }
        let u32_at = |b: &[u8], i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
        let u64_at = |b: &[u8], i: usize| {
            let mut a = [0u8; 8];
            a.copy_from_slice(&b[i..i + 8]);
            u64::from_le_bytes(a)
        };
        Some(
            bytes
                .chunks_exact(FRAME_BYTES)
                .map(|b| Frame {
                    kind: u32_at(b, 0),
                    from: u32_at(b, 4),
                    sample: u32_at(b, 8),
                    aux: u32_at(b, 12),
                    seq: u64_at(b, 16),
                    data: std::array::from_fn(|k| f64::from_bits(u64_at(b, 24 + 8 * k))),
                })
                .collect(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn a_frame_is_taken_from_its_own_sender_or_the_relaying_coordinator_and_else_marked() {
        let f = Frame {
            kind: 7,
            from: 2,
            seq: 9,
            ..Frame::default()
        };
        assert_eq!(f.as_sent_by(Some(2)), f);
        assert_eq!(f.as_sent_by(Some(COORDINATOR_ID)), f);
        let posed = f.as_sent_by(Some(1));
        assert_eq!(
            (posed.kind, posed.from, posed.aux, posed.seq),
            (IMPOSTOR, 1, 2, 9)
        );
        let stranger = f.as_sent_by(None);
        assert_eq!(
            (stranger.kind, stranger.from, stranger.aux),
            (IMPOSTOR, u32::MAX, 2)
        );
    }

    proptest! {
        /// Every bit survives the byte form, NaN payloads and signed zeros included.
        #[test]
        fn a_frame_survives_its_byte_form_bit_for_bit(
            kind: u32, from: u32, sample: u32, aux: u32, seq: u64,
            bits in proptest::array::uniform5(any::<u64>()),
        ) {
            let f = Frame { kind, from, sample, aux, seq, data: bits.map(f64::from_bits) };
            let mut b = Vec::new();
            f.put_bytes(&mut b);
            f.put_bytes(&mut b);
            prop_assert_eq!(b.len(), 2 * FRAME_BYTES);
            let back = Frame::from_bytes(&b).unwrap();
            prop_assert_eq!(back.len(), 2);
            for g in back {
                prop_assert_eq!((g.kind, g.from, g.sample, g.aux, g.seq), (kind, from, sample, aux, seq));
                prop_assert_eq!(g.data.map(f64::to_bits), bits);
            }
        }
    }

    #[test]
    fn a_byte_string_that_is_not_whole_frames_is_refused() {
        assert!(Frame::from_bytes(&[0u8; 63]).is_none());
        assert_eq!(Frame::from_bytes(&[]).map(|v| v.len()), Some(0));
    }
}
