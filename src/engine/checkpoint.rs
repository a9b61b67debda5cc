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

use crate::model::coords::Coords;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The longest checkpoint file read (a real one is under 1 kB).
pub const MAX_CHECKPOINT_BYTES: u64 = 64 * 1024;

/// One node's checkpoint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Checkpoint {
    /// The node.
    pub node: u32,
    /// The sample whose arrival wrote it.
    pub sample: u32,
    /// `u`, readable (not read back): 3 numbers in 2-D, 4 in 3-D.
    pub u: Vec<f64>,
    /// `theta`, readable (not read back).
    pub theta: Vec<f64>,
    /// `u`'s exact bits.
    pub u_bits: Vec<u64>,
    /// `theta`'s exact bits.
    pub theta_bits: Vec<u64>,
}

impl Checkpoint {
    /// The checkpoint of node `node` at sample `sample`.
    pub fn new(node: u32, sample: u32, u: &Coords, theta: &Coords) -> Checkpoint {
        let arr = |v: &Coords| v.as_slice().to_vec();
        let bits = |v: &Coords| v.as_slice().iter().map(|x| x.to_bits()).collect();
        Checkpoint {
            node,
            sample,
            u: arr(u),
            theta: arr(theta),
            u_bits: bits(u),
            theta_bits: bits(theta),
        }
    }

    /// `(u, theta)`, exactly as saved, or why they are not a node's state
    /// of a `dim`-dimensional run (`dim + 1` numbers each).
    pub fn state(&self, dim: usize) -> Result<(Coords, Coords), String> {
        let v = |what: &str, b: &[u64]| {
            if b.len() != dim + 1 {
                return Err(format!(
                    "{what} holds {} numbers, not the {} of a {dim}-D run",
                    b.len(),
                    dim + 1
                ));
            }
            let x: Vec<f64> = b.iter().map(|&b| f64::from_bits(b)).collect();
            Coords::from_slice(&x).ok_or_else(|| format!("{what}: not a state"))
        };
        Ok((
            v("u_bits", &self.u_bits)?,
            v("theta_bits", &self.theta_bits)?,
        ))
    }

    /// Write it to `path` atomically (`path.tmp`, then a rename).
    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        let tmp = path.with_extension("json.tmp");
        let text = serde_json::to_string(self).map_err(std::io::Error::other)?;
        std::fs::write(&tmp, text + "\n")?;
        std::fs::rename(&tmp, path)
    }

    /// Read node `node`'s checkpoint of a `dim`-dimensional run from
    /// `path`: `Ok(None)` if there is none yet; an error if the file is not a
    /// checkpoint of that node and dimension or holds a non-finite value.
    /// A file over [`MAX_CHECKPOINT_BYTES`] is refused before it is read.
    pub fn read(path: &Path, node: u32, dim: usize) -> Result<Option<Checkpoint>, String> {
        use std::io::Read;
        let file = match std::fs::File::open(path) {
            Ok(f) => f,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(format!("{}: {e}", path.display())),
        };
        let mut bytes = Vec::new();
        file.take(MAX_CHECKPOINT_BYTES + 1)
            .read_to_end(&mut bytes)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        Checkpoint::parse(&bytes, path, node, dim).map(Some)
    }

    /// [`Checkpoint::read`] of the contents `bytes` of the file `path`.
    pub fn parse(bytes: &[u8], path: &Path, node: u32, dim: usize) -> Result<Checkpoint, String> {
        if bytes.len() as u64 > MAX_CHECKPOINT_BYTES {
            return Err(format!(
                "{}: longer than the {MAX_CHECKPOINT_BYTES} bytes a checkpoint takes at most",
                path.display()
            ));
        }
        let ck: Checkpoint = serde_json::from_slice(bytes)
            .map_err(|e| format!("{}: not a checkpoint: {e}", path.display()))?;
        if ck.node != node {
            return Err(format!(
                "{}: the checkpoint of node {}, not of node {node}",
                path.display(),
                ck.node
            ));
        }
        let (u, theta) = ck
            .state(dim)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        if !(u.is_finite() && theta.is_finite()) {
            return Err(format!("{}: a non-finite value", path.display()));
        }
        Ok(ck)
    }
}

/// Node `node`'s checkpoint file in the directory `dir`.
pub fn path(dir: &Path, node: u32) -> PathBuf {
    dir.join(format!("node-{node}.json"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(v: &[f64]) -> Coords {
        Coords::from_slice(v).unwrap()
    }

    #[test]
    fn a_checkpoint_file_reads_back_bit_for_bit_and_names_its_node() {
        let dir = std::env::temp_dir().join(format!("sonarnet-ck-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = path(&dir, 3);
        assert_eq!(Checkpoint::read(&p, 3, 2), Ok(None));
        // Values whose shortest decimal form does not round-trip through
        // every parser: the bits do.
        let u = c(&[0.1 + 0.2, -1.0 / 3.0, 1e-310]);
        let theta = c(&[f64::MAX, 2.0f64.sqrt(), -0.0]);
        Checkpoint::new(3, 12, &u, &theta).write(&p).unwrap();
        let ck = Checkpoint::read(&p, 3, 2).unwrap().unwrap();
        assert_eq!(ck.sample, 12);
        let (u2, t2) = ck.state(2).unwrap();
        let bits = |v: &Coords| v.as_slice().iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!((bits(&u), bits(&theta)), (bits(&u2), bits(&t2)));
        assert!(!p.with_extension("json.tmp").exists(), "renamed into place");
        let other = Checkpoint::read(&p, 4, 2).unwrap_err();
        assert!(other.contains("node 3, not of node 4"), "{other}");
        let wrong_dim = Checkpoint::read(&p, 3, 3).unwrap_err();
        assert!(wrong_dim.contains("not the 4 of a 3-D run"), "{wrong_dim}");
        std::fs::write(&p, "{}").unwrap();
        assert!(
            Checkpoint::read(&p, 3, 2)
                .unwrap_err()
                .contains("not a checkpoint")
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_3d_checkpoint_holds_four_numbers_each() {
        let dir = std::env::temp_dir().join(format!("sonarnet-ck3-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = path(&dir, 0);
        let u = c(&[1.0, -2.0, -300.5, 1e-310]);
        let theta = c(&[0.1, 0.2, -0.3, 4.0]);
        Checkpoint::new(0, 5, &u, &theta).write(&p).unwrap();
        let ck = Checkpoint::read(&p, 0, 3).unwrap().unwrap();
        assert_eq!(ck.state(3).unwrap(), (u, theta));
        assert!(Checkpoint::read(&p, 0, 2).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
