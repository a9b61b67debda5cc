//! `[deploy]`: which host runs which node. Nodes on a host other
//! than [`LOCAL_HOST`] are started by that host's agent (`sonarnet agent`)
//! and talk over zenoh.

use std::collections::BTreeMap;

/// The host name of nodes the coordinator starts itself in a `[deploy]` table.
pub const LOCAL_HOST: &str = "local";

/// Which host runs which nodes (`[deploy] hosts`, or `--place`): every node
/// on exactly one host. A host named [`LOCAL_HOST`] is the coordinator's
/// own; every other is an agent's.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Placement {
    /// Host name to its nodes.
    pub hosts: BTreeMap<String, Vec<u32>>,
}

/// Longest accepted host name.
pub const MAX_HOST_NAME: usize = 64;

impl Placement {
    /// Checks the placement against a network of `n` nodes: host names of 1
    /// to [`MAX_HOST_NAME`] characters from `[A-Za-z0-9_-]`, and every node
    /// `0..n` on exactly one host. The error is one sentence.
    pub fn validate(&self, n: usize) -> Result<(), String> {
        if self.hosts.is_empty() {
            return Err("no host is given".into());
        }
        let mut host_of: Vec<Option<&str>> = vec![None; n];
        for (h, nodes) in &self.hosts {
            if h.is_empty()
                || h.len() > MAX_HOST_NAME
                || !h
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
            {
                return Err(format!(
                    "host name {h:?} must have 1 to {MAX_HOST_NAME} characters from [A-Za-z0-9_-]"
                ));
            }
            if nodes.is_empty() {
                return Err(format!("host {h} has no nodes"));
            }
            for &i in nodes {
                let Some(slot) = host_of.get_mut(i as usize) else {
                    return Err(format!(
                        "host {h} lists node {i}, but the network has nodes 0 to {}",
                        n.saturating_sub(1)
                    ));
                };
                if let Some(other) = slot {
                    return Err(format!("node {i} is placed on both {other} and {h}"));
                }
                *slot = Some(h);
            }
        }
        let unplaced: Vec<usize> = (0..n).filter(|&i| host_of[i].is_none()).collect();
        if !unplaced.is_empty() {
            return Err(format!("nodes {unplaced:?} are on no host"));
        }
        Ok(())
    }

    /// The host of node `i`.
    pub fn host_of(&self, i: u32) -> Option<&str> {
        self.hosts
            .iter()
            .find(|(_, nodes)| nodes.contains(&i))
            .map(|(h, _)| h.as_str())
    }

    /// The hosts that need an agent (every one but [`LOCAL_HOST`]).
    pub fn agents(&self) -> Vec<&str> {
        self.hosts
            .keys()
            .map(String::as_str)
            .filter(|h| *h != LOCAL_HOST)
            .collect()
    }

    /// Parses `--place HOST=NODES` values: NODES is a comma-separated list
    /// of node ids and ranges `A-B` (inclusive), e.g. `a=0-2` `b=3,4,5`.
    pub fn parse(values: &[String]) -> Result<Self, String> {
        let mut hosts: BTreeMap<String, Vec<u32>> = BTreeMap::new();
        for v in values {
            let (h, list) = v
                .split_once('=')
                .ok_or_else(|| format!("--place {v}: expected HOST=NODES, e.g. a=0-2,5"))?;
            let nodes = hosts.entry(h.trim().to_string()).or_default();
            for part in list.split(',').map(str::trim).filter(|p| !p.is_empty()) {
                let num = |s: &str| {
                    s.trim()
                        .parse::<u32>()
                        .map_err(|_| format!("--place {v}: {s:?} is not a node id"))
                };
                match part.split_once('-') {
                    Some((a, b)) => {
                        let (a, b) = (num(a)?, num(b)?);
                        if b < a || b - a > 1 << 16 {
                            return Err(format!("--place {v}: bad range {part}"));
                        }
                        nodes.extend(a..=b);
                    }
                    None => nodes.push(num(part)?),
                }
            }
        }
        Ok(Placement { hosts })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn place(v: &[&str]) -> Result<Placement, String> {
        Placement::parse(&v.iter().map(|s| s.to_string()).collect::<Vec<_>>())
    }

    #[test]
    fn a_placement_puts_every_node_on_exactly_one_host() {
        let p = place(&["a=0-2", "b=3,4,5"]).unwrap();
        assert!(p.validate(6).is_ok());
        assert_eq!(p.host_of(4), Some("b"));
        assert_eq!(p.agents(), vec!["a", "b"]);
        let e = p.validate(7).unwrap_err();
        assert!(e.contains("[6]"), "{e}");
        let e = place(&["a=0-2", "b=2-5"]).unwrap().validate(6).unwrap_err();
        assert!(e.contains("node 2") && e.contains("both"), "{e}");
        let e = p.validate(4).unwrap_err();
        assert!(e.contains("node 4"), "{e}");
        let e = place(&["a b=0-5"]).unwrap().validate(6).unwrap_err();
        assert!(e.contains("host name"), "{e}");
        assert!(place(&["a"]).unwrap_err().contains("HOST=NODES"));
        assert!(place(&["a=x"]).unwrap_err().contains("not a node id"));
        assert!(place(&["a=5-2"]).unwrap_err().contains("bad range"));
        let local = place(&["local=0,1", "b=2"]).unwrap();
        assert_eq!(local.agents(), vec!["b"]);
    }
}
