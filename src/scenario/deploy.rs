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

/// Why a placement is refused (`[deploy] hosts` or `--place`).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PlacementError {
    /// The table is empty.
    #[error("no host is given")]
    NoHost,
    /// A host name outside `[A-Za-z0-9_-]{1,MAX_HOST_NAME}`.
    #[error("host name {0:?} must have 1 to {MAX_HOST_NAME} characters from [A-Za-z0-9_-]")]
    HostName(String),
    /// A host with an empty node list.
    #[error("host {0} has no nodes")]
    NoNodes(String),
    /// A node id the network does not have.
    #[error("host {host} lists node {node}, but the network has nodes 0 to {last}")]
    NoSuchNode {
        /// The host.
        host: String,
        /// The node id.
        node: u32,
        /// The network's last node id.
        last: usize,
    },
    /// A node on two hosts.
    #[error("node {node} is placed on both {first} and {second}")]
    Twice {
        /// The node id.
        node: u32,
        /// The first host listing it.
        first: String,
        /// The second.
        second: String,
    },
    /// Nodes on no host.
    #[error("nodes {0:?} are on no host")]
    Unplaced(Vec<usize>),
    /// A `--place` value that is not `HOST=NODES`.
    #[error("--place {0}: expected HOST=NODES, e.g. a=0-2,5")]
    Form(String),
    /// A node id that is not a number.
    #[error("--place {value}: {part:?} is not a node id")]
    NotANode {
        /// The `--place` value.
        value: String,
        /// The part that is not a node id.
        part: String,
    },
    /// A range `A-B` with `B < A` or too long.
    #[error("--place {value}: bad range {part}")]
    Range {
        /// The `--place` value.
        value: String,
        /// The range.
        part: String,
    },
}

/// Longest accepted host name.
pub const MAX_HOST_NAME: usize = 64;

impl Placement {
    /// Checks the placement against a network of `n` nodes: host names of 1
    /// to [`MAX_HOST_NAME`] characters from `[A-Za-z0-9_-]`, and every node
    /// `0..n` on exactly one host. The error is one sentence.
    pub fn validate(&self, n: usize) -> Result<(), PlacementError> {
        if self.hosts.is_empty() {
            return Err(PlacementError::NoHost);
        }
        let mut host_of: Vec<Option<&str>> = vec![None; n];
        for (h, nodes) in &self.hosts {
            if h.is_empty()
                || h.len() > MAX_HOST_NAME
                || !h
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
            {
                return Err(PlacementError::HostName(h.clone()));
            }
            if nodes.is_empty() {
                return Err(PlacementError::NoNodes(h.clone()));
            }
            for &i in nodes {
                let Some(slot) = host_of.get_mut(i as usize) else {
                    return Err(PlacementError::NoSuchNode {
                        host: h.clone(),
                        node: i,
                        last: n.saturating_sub(1),
                    });
                };
                if let Some(other) = slot {
                    return Err(PlacementError::Twice {
                        node: i,
                        first: (*other).to_string(),
                        second: h.clone(),
                    });
                }
                *slot = Some(h);
            }
        }
        let unplaced: Vec<usize> = (0..n).filter(|&i| host_of[i].is_none()).collect();
        if !unplaced.is_empty() {
            return Err(PlacementError::Unplaced(unplaced));
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
    pub fn parse(values: &[String]) -> Result<Self, PlacementError> {
        let mut hosts: BTreeMap<String, Vec<u32>> = BTreeMap::new();
        for v in values {
            let (h, list) = v
                .split_once('=')
                .ok_or_else(|| PlacementError::Form(v.clone()))?;
            let nodes = hosts.entry(h.trim().to_string()).or_default();
            for part in list.split(',').map(str::trim).filter(|p| !p.is_empty()) {
                let num = |s: &str| {
                    s.trim()
                        .parse::<u32>()
                        .map_err(|_| PlacementError::NotANode {
                            value: v.clone(),
                            part: s.to_string(),
                        })
                };
                match part.split_once('-') {
                    Some((a, b)) => {
                        let (a, b) = (num(a)?, num(b)?);
                        if b < a || b - a > 1 << 16 {
                            return Err(PlacementError::Range {
                                value: v.clone(),
                                part: part.to_string(),
                            });
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

    fn place(v: &[&str]) -> Result<Placement, PlacementError> {
        Placement::parse(&v.iter().map(|s| s.to_string()).collect::<Vec<_>>())
    }

    #[test]
    fn a_placement_puts_every_node_on_exactly_one_host() {
        let p = place(&["a=0-2", "b=3,4,5"]).unwrap();
        assert!(p.validate(6).is_ok());
        assert_eq!(p.host_of(4), Some("b"));
        assert_eq!(p.agents(), vec!["a", "b"]);
        assert_eq!(p.validate(7), Err(PlacementError::Unplaced(vec![6])));
        let e = place(&["a=0-2", "b=2-5"]).unwrap().validate(6).unwrap_err();
        assert!(matches!(e, PlacementError::Twice { node: 2, .. }), "{e}");
        let e = p.validate(4).unwrap_err();
        assert!(
            matches!(
                e,
                PlacementError::NoSuchNode {
                    node: 4,
                    last: 3,
                    ..
                }
            ),
            "{e}"
        );
        let e = place(&["a b=0-5"]).unwrap().validate(6).unwrap_err();
        assert_eq!(e, PlacementError::HostName("a b".into()));
        assert!(e.to_string().starts_with("host name \"a b\""), "{e}");
        assert!(
            place(&["a"])
                .unwrap_err()
                .to_string()
                .contains("HOST=NODES")
        );
        assert!(matches!(
            place(&["a=x"]),
            Err(PlacementError::NotANode { .. })
        ));
        assert!(matches!(
            place(&["a=5-2"]),
            Err(PlacementError::Range { .. })
        ));
        let local = place(&["local=0,1", "b=2"]).unwrap();
        assert_eq!(local.agents(), vec!["b"]);
    }
}
