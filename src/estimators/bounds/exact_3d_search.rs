//! `upp_exact` in 3-D when the set has spheroids (bistatic ranges): the
//! worst-case error `max_{x in B} ||x - x_hat||` certified to within
//! [`REL_GAP`] by a branch and bound over directions.
//!
//! # The value as a maximum over directions
//!
//! `||x - p|| = max_{||u|| = 1} u . (x - p)`, so the worst case is
//! `M = max_{||u|| = 1} g(u)` with `g(u) = h_B(u) - u . p`, the support
//! function of `B - p`. Every `g(u)` has a certified upper bound `G(u)`: the
//! value the dual variables of the support-function cone program certify
//! (weak duality, as the bounding box of Gholami 2015 eq. (48) is certified),
//! and the program's maximiser `x_u` is a point of `B` to the solver's
//! accuracy, so `||x_u - p||` is a lower bound `m` on `M` to that accuracy
//! (taken from points whose violation of every piece is at most `1e-7 L`,
//! the solver's primal accuracy on thin sets).
//!
//! # Bounding a spherical triangle
//!
//! The sphere of directions starts as an icosahedron's 20 triangles. A
//! direction `u` in the spherical triangle of unit vertices `u_1, u_2, u_3`
//! is `w / ||w||` with `w = sum_i lambda_i u_i`, `lambda` in the simplex.
//! `g` is sublinear (convex and positively homogeneous, a support function),
//! so `g(w) <= sum_i lambda_i g(u_i) <= max_i G(u_i) =: G_max`, and
//! `g(u) = g(w) / ||w||`. `||w||` is at least `d_T = sqrt(1 - c^2 / 3)` for
//! the triangle's longest chord `c` (`||w||^2 = 1 - sum_{i<j} lambda_i
//! lambda_j ||u_i - u_j||^2`, and the products sum to at most 1/3), so over
//! the triangle
//!
//! `g(u) <= G_max / d_T` when `G_max >= 0`, and `g(u) <= G_max` otherwise.
//!
//! # The search
//!
//! Triangles wait in a queue by their bound; the one with the largest bound
//! is split into four (the edges' midpoints, normalised; a midpoint's
//! program is solved once for both triangles that share the edge). The
//! largest bound in the queue is always an upper bound on `M` (every
//! direction lies in a queued triangle), so the search stops, with that
//! bound as the answer, when it is within `REL_GAP` of the lower bound `m`:
//! the answer is then never below `M` and at most `REL_GAP` above it. Near
//! the maximiser `u*`, `g(u) >= M cos(angle(u, u*))`, and a triangle of
//! angular size `delta` has `d_T ~ 1 - delta^2 / 2`, so the bounds close
//! quadratically and the search goes about eleven levels deep, keeping a few
//! triangles per level.
//!
//! A surface of `B` that is a sphere centred on (or very near) `x_hat` makes
//! `g` flat over a whole region, and the search would have to cover it at
//! the final depth: after [`MAX_PROGRAMS`] cone programs it gives up with
//! an error rather than report a bound it has not certified to `REL_GAP`.

use super::region::Region;
use super::solve::{Support, SupportValue};
use super::{BoundError, BoundOutcome, Intersection};
use crate::model::geometry::Point;
use std::collections::{BinaryHeap, HashMap};

type P3 = Point<3>;

/// The search stops when its upper bound is within this fraction of its
/// lower bound.
pub const REL_GAP: f64 = 1e-7;

/// Cone programs (one per direction) before the search gives up.
pub const MAX_PROGRAMS: usize = 20_000;

/// The tolerance on a maximiser's violation of a piece, relative to `L`, for
/// its distance to count in the lower bound: the solver's primal accuracy on
/// thin sets (the lower bound only decides when the search stops; the answer
/// is the certified upper bound).
const TOL: f64 = 1e-7;

/// A spherical triangle in the queue, ordered by its bound.
#[derive(Debug, Clone, Copy)]
struct Triangle {
    bound: f64,
    v: [usize; 3],
}

impl PartialEq for Triangle {
    fn eq(&self, other: &Self) -> bool {
        self.bound.total_cmp(&other.bound).is_eq()
    }
}
impl Eq for Triangle {}
impl PartialOrd for Triangle {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Triangle {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.bound.total_cmp(&other.bound)
    }
}

/// The directions evaluated so far and what they gave.
struct Search<'a> {
    support: Support<3>,
    regions: &'a [Region<3>],
    p: P3,
    tol: f64,
    /// Unit directions and their certified `G(u)`.
    dirs: Vec<(P3, f64)>,
    midpoints: HashMap<(usize, usize), usize>,
    /// The lower bound `m`.
    lower: f64,
    programs: usize,
}

/// What a direction's program showed.
enum Step {
    Index(usize),
    Empty,
}

impl Search<'_> {
    /// Evaluate the unit direction `u`.
    fn add(&mut self, u: P3) -> Result<Step, BoundError> {
        self.programs += 1;
        match self.support.eval(&u)? {
            SupportValue::Empty => Ok(Step::Empty),
            SupportValue::Value(h, x) => {
                let inside = self.regions.iter().all(|r| r.violation(&x) <= self.tol);
                if inside {
                    self.lower = self.lower.max((x - self.p).norm());
                }
                self.dirs.push((u, h - u.dot(&self.p)));
                Ok(Step::Index(self.dirs.len() - 1))
            }
        }
    }

    /// The midpoint direction of the edge `(i, j)`, evaluated once.
    fn midpoint(&mut self, i: usize, j: usize) -> Result<Step, BoundError> {
        let key = (i.min(j), i.max(j));
        if let Some(&k) = self.midpoints.get(&key) {
            return Ok(Step::Index(k));
        }
        let u = (self.dirs[i].0 + self.dirs[j].0).normalize();
        let step = self.add(u)?;
        if let Step::Index(k) = step {
            self.midpoints.insert(key, k);
        }
        Ok(step)
    }

    /// The bound of the module docs over the triangle `v`.
    fn bound(&self, v: [usize; 3]) -> Triangle {
        let [a, b, c] = v.map(|i| self.dirs[i]);
        let g_max = a.1.max(b.1).max(c.1);
        let bound = if g_max >= 0.0 {
            // ||sum_i lambda_i u_i||^2 = 1 - sum_{i<j} lambda_i lambda_j
            // ||u_i - u_j||^2 >= 1 - c^2 / 3 for the longest chord c (the
            // products sum to at most 1/3): no cancellation in tiny triangles.
            let c2 = [(a.0, b.0), (b.0, c.0), (c.0, a.0)]
                .iter()
                .map(|(x, y)| (x - y).norm_squared())
                .fold(0.0f64, f64::max);
            let d = (1.0 - c2 / 3.0).max(0.0).sqrt();
            // Rounding of d and of the division, covered generously.
            g_max / d * (1.0 + 1e-12)
        } else {
            g_max
        };
        Triangle {
            bound: if bound.is_nan() { f64::INFINITY } else { bound },
            v,
        }
    }
}

/// The icosahedron's 12 unit vertices and 20 faces (vertex triples at the
/// edge length).
fn icosahedron() -> (Vec<P3>, Vec<[usize; 3]>) {
    let phi = 0.5 * (1.0 + 5f64.sqrt());
    let mut v = Vec::with_capacity(12);
    for s1 in [1.0, -1.0] {
        for s2 in [phi, -phi] {
            v.push(P3::new(0.0, s1, s2));
            v.push(P3::new(s1, s2, 0.0));
            v.push(P3::new(s2, 0.0, s1));
        }
    }
    let edge = |i: usize, j: usize| ((v[i] - v[j]).norm() - 2.0).abs() < 1e-9;
    let mut faces = Vec::with_capacity(20);
    for i in 0..12 {
        for j in i + 1..12 {
            for k in j + 1..12 {
                if edge(i, j) && edge(j, k) && edge(i, k) {
                    faces.push([i, j, k]);
                }
            }
        }
    }
    (v.into_iter().map(|x| x.normalize()).collect(), faces)
}

impl Intersection<3> {
    /// `upp_exact` when the set has a spheroid (module docs of
    /// `exact_3d_search`): an upper bound on `max_{x in B} ||x - x_hat||`
    /// within [`REL_GAP`] of it.
    /// `pieces` are the set's pieces in the local frame (those that cut it).
    pub(super) fn upp_exact_search(
        &self,
        pieces: &[Region<3>],
        x_hat: &P3,
    ) -> Result<BoundOutcome, BoundError> {
        let p = self.to_local(x_hat);
        let Some(support) = Support::new(pieces)? else {
            return Ok(BoundOutcome::Empty);
        };
        let scale_l = pieces
            .iter()
            .map(|r| match *r {
                Region::Disc { center, radius } => (center - p).norm() + radius,
                Region::Ellipse { f1, f2, sum } => (0.5 * (f1 + f2) - p).norm() + 0.5 * sum,
            })
            .fold(0.0f64, f64::max)
            .max(f64::MIN_POSITIVE);
        let mut search = Search {
            support,
            regions: pieces,
            p,
            tol: TOL * scale_l,
            dirs: Vec::new(),
            midpoints: HashMap::new(),
            lower: f64::NEG_INFINITY,
            programs: 0,
        };
        let (vertices, faces) = icosahedron();
        for u in vertices {
            if let Step::Empty = search.add(u)? {
                return Ok(BoundOutcome::Empty);
            }
        }
        let mut queue: BinaryHeap<Triangle> = faces.into_iter().map(|f| search.bound(f)).collect();
        loop {
            let Some(top) = queue.pop() else {
                return Err(BoundError::Solver {
                    problem: "upp_exact search",
                    status: "no triangle left (cannot happen)".into(),
                });
            };
            if top.bound <= search.lower + REL_GAP * search.lower.abs() {
                return Ok(BoundOutcome::Bound(top.bound * self.scale));
            }
            if search.programs >= MAX_PROGRAMS {
                return Err(BoundError::Solver {
                    problem: "upp_exact search",
                    status: format!(
                        "not certified to {REL_GAP:e} after {MAX_PROGRAMS} cone programs \
                         (bounds {:.9e} to {:.9e}): the set's far side is nearly a sphere \
                         centred on the estimate",
                        search.lower * self.scale,
                        top.bound * self.scale
                    ),
                });
            }
            let [a, b, c] = top.v;
            let mut mid = [0usize; 3];
            for (slot, (i, j)) in mid.iter_mut().zip([(a, b), (b, c), (c, a)]) {
                match search.midpoint(i, j)? {
                    Step::Index(k) => *slot = k,
                    Step::Empty => return Ok(BoundOutcome::Empty),
                }
            }
            let [ab, bc, ca] = mid;
            for t in [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]] {
                queue.push(search.bound(t));
            }
        }
    }
}
