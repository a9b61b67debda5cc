//! A node process's checkpoint file (`restart` with
//! `state = "checkpoint"`): the node's `u` and `theta` when every
//! `checkpoint_every`-th sample arrived ([`crate::protocol::Output::Checkpoint`]),
//! in `checkpoints/node-<i>.json` of the run's results directory. It is
//! written atomically (a temporary file in the same directory, then a
//! rename), so a node killed mid-write leaves the previous checkpoint whole.
//! A restarted node reads it back exactly: the values are stored as their
//! IEEE-754 bits next to the readable numbers.
//!
//! The discrete-event engine keeps checkpoints in memory; only node
//! processes, which die for real, need the file.

use crate::model::geometry::Vec3;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// One node's checkpoint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Checkpoint {
    /// The node.
    pub node: u32,
    /// The sample whose arrival wrote it.
    pub sample: u32,
    /// `u`, readable (not read back).
    pub u: [f64; 3],
    /// `theta`, readable (not read back).
    pub theta: [f64; 3],
    /// `u`'s exact bits.
    pub u_bits: [u64; 3],
    /// `theta`'s exact bits.
    pub theta_bits: [u64; 3],
}

impl Checkpoint {
    /// The checkpoint of node `node` at sample `sample`.
    pub fn new(node: u32, sample: u32, u: &Vec3, theta: &Vec3) -> Checkpoint {
        let arr = |v: &Vec3| [v[0], v[1], v[2]];
        let bits = |v: &Vec3| [v[0].to_bits(), v[1].to_bits(), v[2].to_bits()];
        Checkpoint {
            node,
            sample,
            u: arr(u),
            theta: arr(theta),
            u_bits: bits(u),
            theta_bits: bits(theta),
        }
    }

    /// `(u, theta)`, exactly as saved.
    pub fn state(&self) -> (Vec3, Vec3) {
        let v = |b: &[u64; 3]| {
            Vec3::new(
                f64::from_bits(b[0]),
                f64::from_bits(b[1]),
                f64::from_bits(b[2]),
            )
        };
        (v(&self.u_bits), v(&self.theta_bits))
    }

    /// Write it to `path` atomically (`path.tmp`, then a rename).
    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        let tmp = path.with_extension("json.tmp");
        let text = serde_json::to_string(self).map_err(std::io::Error::other)?;
        std::fs::write(&tmp, text + "\n")?;
        std::fs::rename(&tmp, path)
    }

    /// Read node `node`'s checkpoint from `path`: `Ok(None)` if there is
    /// none yet; an error if the file is not a checkpoint of that node or
    /// holds a non-finite value.
    pub fn read(path: &Path, node: u32) -> Result<Option<Checkpoint>, String> {
        let text = match std::fs::read_to_string(path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(format!("{}: {e}", path.display())),
        };
        let ck: Checkpoint = serde_json::from_str(&text)
            .map_err(|e| format!("{}: not a checkpoint: {e}", path.display()))?;
        if ck.node != node {
            return Err(format!(
                "{}: the checkpoint of node {}, not of node {node}",
                path.display(),
                ck.node
            ));
        }
        let (u, theta) = ck.state();
        if !u.iter().chain(theta.iter()).all(|x| x.is_finite()) {
            return Err(format!("{}: a non-finite value", path.display()));
        }
        Ok(Some(ck))
    }
}

/// Node `node`'s checkpoint file in the directory `dir`.
pub fn path(dir: &Path, node: u32) -> PathBuf {
    dir.join(format!("node-{node}.json"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_checkpoint_file_reads_back_bit_for_bit_and_names_its_node() {
        let dir = std::env::temp_dir().join(format!("sonarnet-ck-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = path(&dir, 3);
        assert_eq!(Checkpoint::read(&p, 3), Ok(None));
        // Values whose shortest decimal form does not round-trip through
        // every parser: the bits do.
        let u = Vec3::new(0.1 + 0.2, -1.0 / 3.0, 1e-310);
        let theta = Vec3::new(f64::MAX, 2.0f64.sqrt(), -0.0);
        Checkpoint::new(3, 12, &u, &theta).write(&p).unwrap();
        let ck = Checkpoint::read(&p, 3).unwrap().unwrap();
        assert_eq!(ck.sample, 12);
        let (u2, t2) = ck.state();
        for (a, b) in u.iter().chain(theta.iter()).zip(u2.iter().chain(t2.iter())) {
            assert_eq!(a.to_bits(), b.to_bits());
        }
        assert!(!p.with_extension("json.tmp").exists(), "renamed into place");
        let other = Checkpoint::read(&p, 4).unwrap_err();
        assert!(other.contains("node 3, not of node 4"), "{other}");
        std::fs::write(&p, "{}").unwrap();
        assert!(
            Checkpoint::read(&p, 3)
                .unwrap_err()
                .contains("not a checkpoint")
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
