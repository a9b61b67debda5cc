//! The gossip graph over the receivers.

use std::collections::BTreeSet;

/// An undirected, simple, connected graph over nodes `0..n`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Graph {
    n: usize,
    edges: Vec<(usize, usize)>,
    neighbours: Vec<Vec<usize>>,
}

/// Why a set of edges is not an acceptable gossip graph.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum GraphError {
    /// An edge names a node that does not exist.
    #[error("edge {index} = [{a}, {b}] names a node outside 0..{n}")]
    OutOfRange {
        /// Position of the edge in the list.
        index: usize,
        /// First end.
        a: usize,
        /// Second end.
        b: usize,
        /// Number of nodes.
        n: usize,
    },
    /// An edge joins a node to itself.
    #[error("edge {index} = [{a}, {a}] is a self-loop")]
    SelfLoop {
        /// Position of the edge in the list.
        index: usize,
        /// The node.
        a: usize,
    },
    /// The same edge appears twice.
    #[error("edge {index} = [{a}, {b}] duplicates an earlier edge")]
    Duplicate {
        /// Position of the edge in the list.
        index: usize,
        /// First end.
        a: usize,
        /// Second end.
        b: usize,
    },
    /// Some node cannot be reached from node 0.
    #[error(
        "the graph is disconnected: node {unreachable} cannot be reached from node 0 ({components} components)"
    )]
    Disconnected {
        /// The lowest unreachable node.
        unreachable: usize,
        /// Number of connected components.
        components: usize,
    },
    /// A gossip graph needs at least two nodes.
    #[error("a gossip network needs at least 2 receivers, got {0}")]
    TooSmall(usize),
}

impl Graph {
    /// Validate and build a graph from 0-based edges: rejects out-of-range
    /// nodes, self-loops, duplicate edges and disconnected graphs.
    pub fn new(n: usize, edges: &[(usize, usize)]) -> Result<Graph, GraphError> {
        if n < 2 {
            return Err(GraphError::TooSmall(n));
        }
        let mut seen = BTreeSet::new();
        let mut neighbours = vec![Vec::new(); n];
        let mut list = Vec::with_capacity(edges.len());
        for (index, &(a, b)) in edges.iter().enumerate() {
            if a >= n || b >= n {
                return Err(GraphError::OutOfRange { index, a, b, n });
            }
            if a == b {
                return Err(GraphError::SelfLoop { index, a });
            }
            let key = (a.min(b), a.max(b));
            if !seen.insert(key) {
                return Err(GraphError::Duplicate { index, a, b });
            }
            neighbours[a].push(b);
            neighbours[b].push(a);
            list.push(key);
        }
        for nb in &mut neighbours {
            nb.sort_unstable();
        }
        let g = Graph {
            n,
            edges: list,
            neighbours,
        };
        let comps = g.components();
        if comps.len() > 1 {
            let unreachable = comps[1..].iter().flatten().copied().min().unwrap_or(0);
            return Err(GraphError::Disconnected {
                unreachable,
                components: comps.len(),
            });
        }
        Ok(g)
    }

    /// A ring `0-1-...-(n-1)-0` (a single edge for n = 2).
    pub fn ring_edges(n: usize) -> Vec<(usize, usize)> {
        match n {
            0 | 1 => Vec::new(),
            2 => vec![(0, 1)],
            _ => (0..n).map(|i| (i, (i + 1) % n)).collect(),
        }
    }

    /// A `rows x cols` lattice over nodes in row-major order.
    pub fn grid_edges(rows: usize, cols: usize) -> Vec<(usize, usize)> {
        let mut e = Vec::new();
        for r in 0..rows {
            for c in 0..cols {
                let i = r * cols + c;
                if c + 1 < cols {
                    e.push((i, i + 1));
                }
                if r + 1 < rows {
                    e.push((i, i + cols));
                }
            }
        }
        e
    }

    /// Every pair of points closer than `radius` (a geometric graph).
    pub fn geometric_edges<const D: usize>(
        points: &[crate::model::geometry::Point<D>],
        radius: f64,
    ) -> Vec<(usize, usize)> {
        let mut e = Vec::new();
        for i in 0..points.len() {
            for j in i + 1..points.len() {
                if (points[i] - points[j]).norm() <= radius {
                    e.push((i, j));
                }
            }
        }
        e
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Always false: a valid graph has at least two nodes.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The edges, each as `(min, max)`, in input order.
    pub fn edges(&self) -> &[(usize, usize)] {
        &self.edges
    }

    /// Sorted neighbours of node `v`.
    pub fn neighbours(&self, v: usize) -> &[usize] {
        &self.neighbours[v]
    }

    /// Degree of node `v`.
    pub fn degree(&self, v: usize) -> usize {
        self.neighbours[v].len()
    }

    /// True if `{a, b}` is an edge.
    pub fn has_edge(&self, a: usize, b: usize) -> bool {
        a < self.n && self.neighbours[a].binary_search(&b).is_ok()
    }

    /// Connected components (each sorted), the one holding node 0 first.
    pub fn components(&self) -> Vec<Vec<usize>> {
        self.components_without(&[])
    }

    /// Connected components of the graph with the nodes in `removed` deleted.
    pub fn components_without(&self, removed: &[usize]) -> Vec<Vec<usize>> {
        let mut seen = vec![false; self.n];
        for &r in removed {
            if r < self.n {
                seen[r] = true;
            }
        }
        let mut comps = Vec::new();
        for s in 0..self.n {
            if seen[s] {
                continue;
            }
            let mut comp = vec![s];
            seen[s] = true;
            let mut i = 0;
            while i < comp.len() {
                let v = comp[i];
                for &w in &self.neighbours[v] {
                    if !seen[w] {
                        seen[w] = true;
                        comp.push(w);
                    }
                }
                i += 1;
            }
            comp.sort_unstable();
            comps.push(comp);
        }
        comps
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_paper_graph_is_accepted_with_sorted_neighbours() {
        let g = Graph::new(6, &[(0, 1), (0, 2), (1, 3), (2, 3), (3, 4), (3, 5)]).unwrap();
        assert_eq!(g.neighbours(3), &[1, 2, 4, 5]);
        assert!(g.has_edge(4, 3));
        assert!(!g.has_edge(0, 3));
    }

    #[test]
    fn self_loops_duplicates_and_disconnection_are_rejected() {
        assert!(matches!(
            Graph::new(3, &[(0, 0), (1, 2)]),
            Err(GraphError::SelfLoop { .. })
        ));
        assert!(matches!(
            Graph::new(3, &[(0, 1), (1, 0), (1, 2)]),
            Err(GraphError::Duplicate { index: 1, .. })
        ));
        assert!(matches!(
            Graph::new(4, &[(0, 1), (2, 3)]),
            Err(GraphError::Disconnected {
                unreachable: 2,
                components: 2
            })
        ));
        assert!(matches!(
            Graph::new(3, &[(0, 5)]),
            Err(GraphError::OutOfRange { .. })
        ));
    }

    #[test]
    fn ring_and_grid_generators_give_connected_graphs_of_the_right_size() {
        let r = Graph::new(5, &Graph::ring_edges(5)).unwrap();
        assert_eq!(r.edges().len(), 5);
        let g = Graph::new(12, &Graph::grid_edges(3, 4)).unwrap();
        assert_eq!(g.edges().len(), 3 * 3 + 2 * 4);
        assert_eq!(g.degree(5), 4);
    }

    #[test]
    fn removing_a_cut_vertex_splits_the_graph() {
        let g = Graph::new(6, &[(0, 1), (0, 2), (1, 3), (2, 3), (3, 4), (3, 5)]).unwrap();
        assert_eq!(g.components_without(&[3]).len(), 3);
        assert_eq!(g.components_without(&[0]).len(), 1);
    }
}
