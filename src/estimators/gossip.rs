//! The Douglas-Rachford gossip itself (Mourya 2017 Sec. II-B, eq. 7 and 11):
//! its [`Mode`], the consensus averages and the update of `u`. Every node
//! core computes them here, so both ends of an exchange and every engine give
//! bit-identical values.

use crate::model::coords::Coords;

crate::named_enum! {
    /// Gossip mode of the Douglas-Rachford engine.
    pub enum Mode {
        /// Every node updates every iteration; positions averaged over all nodes.
        Sync = "sync",
        /// One random edge `(v, w)` per iteration (Mourya 2017 eq. 11).
        Async = "async",
    }
}

/// The average `a = (r_v[0:D] + r_w[0:D]) / 2` of a pairwise exchange
/// (Mourya 2017 eq. 11, second line), in `D` = 2 or 3 dimensions (`r` holds
/// `D + 1` numbers). IEEE addition is commutative, so both ends compute
/// bit-identical values.
pub fn pair_average(r_a: &Coords, r_b: &Coords) -> Coords {
    r_a.position().zip(&r_b.position(), |a, b| (a + b) / 2.0)
}

/// The sync consensus average: the mean of the position parts of all
/// reflected points, summed in node-id order (each coordinate summed from
/// zero, then divided by the count).
pub fn mean_position<'a>(rs: impl Iterator<Item = &'a Coords>) -> Coords {
    let mut ps = rs.map(Coords::position).peekable();
    let mut s = Coords::zeros(ps.peek().map_or(2, Coords::len));
    let mut n = 0usize;
    for p in ps {
        s = s.zip(&p, |a, b| a + b);
        n += 1;
    }
    let n = n.max(1) as f64;
    s.map(|a| a / n)
}

/// The DR update `u += z - theta` with `z = (a, r[D])` (Mourya 2017 eq. 7 / 11).
pub fn dr_update(u: &mut Coords, theta: &Coords, r: &Coords, a: Coords) {
    let d = u.len() - 1;
    let z = |i: usize| if i < d { a[i] } else { r[d] };
    *u = Coords::from_fn(u.len(), |i| u[i] + (z(i) - theta[i]));
}

crate::named_enum! {
    /// How a computing node scales its prox (Mourya 2017 eq. 5 against eq. 11).
    pub enum ProxScaling {
        /// `prox_{gamma f_v}`: eq. (11), the paper's experiments (default).
        None = "none",
        /// `prox_{gamma p_v^-1 f_v}` of eq. (5), `p_v = P(v computes)`: the
        /// prox of `f_v` with step `gamma / p_v`, so a node that computes
        /// rarely weighs its own data more.
        InverseProbability = "inverse_probability",
    }
    default None
}

/// `p_v = P(v computes)` of every node under the schedule of Mourya 2017
/// Sec. II-B: `v` uniform over the `N` nodes, then `w` uniform over `v`'s
/// neighbours, both compute. So
/// `p_v = 1/N + sum_{w in N(v)} 1 / (N deg(w))` (and `sum_v p_v = 2`). A node
/// without neighbours is never drawn into an exchange: its `p_v` is `1/N`.
pub fn computing_probabilities(graph: &crate::model::graph::Graph) -> Vec<f64> {
    let n = graph.len() as f64;
    (0..graph.len())
        .map(|v| {
            1.0 / n
                + graph
                    .neighbours(v)
                    .iter()
                    .map(|&w| 1.0 / (n * graph.degree(w) as f64))
                    .sum::<f64>()
        })
        .collect()
}

/// The empirical `p_v` of a replayed schedule: the fraction of its
/// iterations `(v, w)` in which node `v` takes part, over the whole schedule.
/// A node that never takes part gets 0 (it never computes, so its prox step
/// is never used).
pub fn empirical_probabilities(schedule: &[(usize, usize)], n: usize) -> Vec<f64> {
    let mut count = vec![0usize; n];
    for &(v, w) in schedule {
        for x in [v, w] {
            if let Some(c) = count.get_mut(x) {
                *c += 1;
            }
        }
    }
    let total = schedule.len().max(1) as f64;
    count.into_iter().map(|c| c as f64 / total).collect()
}

/// Each node's prox step under `scaling`: `gamma`, or `gamma / p_v` where
/// `p_v > 0` (Mourya 2017 eq. 5). `p` is `None` in sync mode, where every node
/// computes every round (`p_v = 1`).
pub fn prox_steps(gamma: f64, scaling: ProxScaling, p: Option<&[f64]>, n: usize) -> Vec<f64> {
    match (scaling, p) {
        (ProxScaling::InverseProbability, Some(p)) => (0..n)
            .map(|v| match p.get(v) {
                Some(&pv) if pv > 0.0 => gamma / pv,
                _ => gamma,
            })
            .collect(),
        _ => vec![gamma; n],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::graph::Graph;
    use crate::model::rng::{Stream, stream_rng};
    use approx::assert_relative_eq;
    use rand::RngExt;

    #[test]
    fn the_computing_probabilities_match_the_frequencies_of_the_drawn_schedule() {
        // The spiral's graph: a star at node 3 with a square 0-1-3-2.
        let g = Graph::new(6, &[(0, 1), (0, 2), (1, 3), (2, 3), (3, 4), (3, 5)]).unwrap();
        let p = computing_probabilities(&g);
        assert_relative_eq!(p.iter().sum::<f64>(), 2.0, epsilon = 1e-12);
        // Closed form at node 4 (degree 1, neighbour 3 of degree 4):
        // 1/6 + 1/(6 * 4).
        assert_relative_eq!(p[4], 1.0 / 6.0 + 1.0 / 24.0, epsilon = 1e-15);
        // Against 400 000 draws of the schedule itself (v uniform, then w).
        let mut rng = stream_rng(11, Stream::Schedule, 0);
        let draws = 400_000;
        let sched: Vec<(usize, usize)> = (0..draws)
            .map(|_| {
                let v = rng.random_range(0..6);
                let nb = g.neighbours(v);
                (v, nb[rng.random_range(0..nb.len())])
            })
            .collect();
        let e = empirical_probabilities(&sched, 6);
        for v in 0..6 {
            // 4 standard deviations of a binomial frequency.
            let sd = (p[v] * (1.0 - p[v]) / draws as f64).sqrt();
            assert!(
                (e[v] - p[v]).abs() < 4.0 * sd,
                "node {v}: {} vs {}",
                e[v],
                p[v]
            );
        }
    }

    #[test]
    fn prox_steps_divide_gamma_by_p_v_only_when_asked_and_where_p_v_is_positive() {
        let p = [0.5, 0.25, 0.0];
        assert_eq!(
            prox_steps(1.0, ProxScaling::None, Some(&p), 3),
            vec![1.0; 3]
        );
        assert_eq!(
            prox_steps(1.0, ProxScaling::InverseProbability, Some(&p), 3),
            vec![2.0, 4.0, 1.0]
        );
        assert_eq!(
            prox_steps(1.0, ProxScaling::InverseProbability, None, 3),
            vec![1.0; 3],
            "sync: p_v = 1"
        );
        assert_eq!(
            empirical_probabilities(&[(0, 1), (1, 2)], 4),
            vec![0.5, 1.0, 0.5, 0.0]
        );
    }
}
