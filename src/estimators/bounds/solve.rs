//! Clarabel formulations of the convex steps (all in a normalised frame where
//! the relaxed bounding box has unit half-width).

use super::BoundError;
use super::region::{Quadratic, Region};
use crate::model::geometry::Point;
use crate::model::linalg::{MatD, sym_eigenvalues};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
    SupportedConeT::{NonnegativeConeT, PSDTriangleConeT, SecondOrderConeT, ZeroConeT},
};

/// A conic problem `min 1/2 v^T P v + q^T v  s.t.  b - A v in K` under construction.
pub(super) struct Conic {
    pub(super) ncols: usize,
    rows: usize,
    ti: Vec<usize>,
    tj: Vec<usize>,
    tv: Vec<f64>,
    b: Vec<f64>,
    pub(super) cones: Vec<SupportedConeT<f64>>,
}

impl Conic {
    pub(super) fn new(ncols: usize) -> Self {
        Self {
            ncols,
            rows: 0,
            ti: vec![],
            tj: vec![],
            tv: vec![],
            b: vec![],
            cones: vec![],
        }
    }

    /// Append the row `s = b - sum coef * v[col]`.
    pub(super) fn row(&mut self, coefs: &[(usize, f64)], b: f64) {
        for &(j, v) in coefs {
            self.ti.push(self.rows);
            self.tj.push(j);
            self.tv.push(v);
        }
        self.b.push(b);
        self.rows += 1;
    }

    fn a(&self) -> CscMatrix<f64> {
        CscMatrix::new_from_triplets(
            self.rows,
            self.ncols,
            self.ti.clone(),
            self.tj.clone(),
            self.tv.clone(),
        )
    }

    /// Cone rows for the set constraints on `y = (v[0], .., v[D-1])`, with an optional
    /// slack column `t` that enlarges every region by `t` (violation form of
    /// [`Region::violation`]). Ellipses use two extra columns `u1, u2` each:
    /// `||y - f1|| <= u1, ||y - f2|| <= u2, u1 + u2 <= sum + 2t` (exact SOC form).
    fn add_set<const D: usize>(&mut self, regions: &[Region<D>], slack: Option<usize>) {
        for reg in regions {
            match *reg {
                Region::Disc { center, radius } => {
                    let mut first = vec![];
                    if let Some(t) = slack {
                        first.push((t, -1.0));
                    }
                    self.row(&first, radius);
                    for k in 0..D {
                        self.row(&[(k, -1.0)], -center[k]);
                    }
                    self.cones.push(SecondOrderConeT(D + 1));
                }
                Region::Ellipse { f1, f2, sum } => {
                    let u1 = self.ncols;
                    let u2 = self.ncols + 1;
                    self.ncols += 2;
                    for (u, f) in [(u1, f1), (u2, f2)] {
                        self.row(&[(u, -1.0)], 0.0);
                        for k in 0..D {
                            self.row(&[(k, -1.0)], -f[k]);
                        }
                        self.cones.push(SecondOrderConeT(D + 1));
                    }
                    let mut r = vec![(u1, 1.0), (u2, 1.0)];
                    if let Some(t) = slack {
                        r.push((t, -2.0));
                    }
                    self.row(&r, sum);
                    self.cones.push(NonnegativeConeT(1));
                }
            }
        }
    }
}

impl Conic {
    /// A lower bound on `min q^T v` over the problem's feasible set that
    /// holds for any dual vector `z` (weak duality, made rigorous as in
    /// Jansen, Chaykin and Keil, "Rigorous error bounds for the optimal value
    /// in semidefinite programming", 2007, for cones): with `z` projected
    /// onto the dual cone `K*` (every cone here is self-dual) and the
    /// residual `r = q + A^T z`, every feasible `v` has `b - A v in K`, so
    /// `z^T (b - A v) >= 0` and `q^T v >= -b^T z + r^T v >= -b^T z +
    /// sum_j min(r_j lo_j, r_j hi_j)` for `v` in the box `vars`. The
    /// solver's `z` makes `r` tiny; the bound is lowered by a round-off
    /// allowance on the magnitudes of its terms. Needs `P = 0`.
    fn certified_min(&self, q: &[f64], z: &[f64], vars: &[(f64, f64)]) -> f64 {
        let mut z = z.to_vec();
        let mut at = 0;
        for cone in &self.cones {
            at += match *cone {
                NonnegativeConeT(n) => {
                    z[at..at + n].iter_mut().for_each(|v| *v = v.max(0.0));
                    n
                }
                SecondOrderConeT(n) => {
                    let tail = z[at + 1..at + n].iter().map(|v| v * v).sum::<f64>().sqrt();
                    z[at] = z[at].max(tail);
                    n
                }
                PSDTriangleConeT(dim) => {
                    let len = dim * (dim + 1) / 2;
                    project_psd_triangle(&mut z[at..at + len], dim);
                    len
                }
                // Not used by the problems certified here (no projection
                // written): a NaN makes the caller report a failure rather
                // than a wrong value.
                _ => return f64::NAN,
            };
        }
        let mut r = q.to_vec();
        for ((&i, &j), &a) in self.ti.iter().zip(&self.tj).zip(&self.tv) {
            r[j] += a * z[i];
        }
        let by: f64 = self.b.iter().zip(&z).map(|(b, z)| b * z).sum();
        let by_size: f64 = self.b.iter().zip(&z).map(|(b, z)| (b * z).abs()).sum();
        let (mut rest, mut rest_size) = (0.0, 0.0);
        for (rj, &(lo, hi)) in r.iter().zip(vars) {
            rest += (rj * lo).min(rj * hi);
            rest_size += (rj * lo).abs().max((rj * hi).abs());
        }
        -by + rest - round_off(by_size + rest_size)
    }
}

impl Conic {
    /// [`Conic::certified_min`] with the dual variables of `solver`'s last
    /// solve (passed through `tweak` first); a non-finite value is a solver
    /// failure of `problem`.
    fn certify(
        &self,
        q: &[f64],
        solver: &DefaultSolver<f64>,
        vars: &[(f64, f64)],
        tweak: DualTweak<'_>,
        problem: &'static str,
    ) -> Result<f64, BoundError> {
        let mut z = solver.solution.z.clone();
        tweak(&mut z);
        let m = self.certified_min(q, &z, vars);
        if m.is_finite() {
            Ok(m)
        } else {
            Err(BoundError::Solver {
                problem,
                status: "its dual variables certify no finite value".into(),
            })
        }
    }
}

/// Projects a dual vector of clarabel's PSD triangle cone (the upper
/// triangle column by column, off-diagonal entries times `sqrt 2`) onto the
/// cone: the negative eigenvalues of the matrix are set to zero. The
/// scaling makes the cone self-dual under the plain inner product.
fn project_psd_triangle(z: &mut [f64], dim: usize) {
    let sqrt2 = std::f64::consts::SQRT_2;
    let mut m = nalgebra::DMatrix::<f64>::zeros(dim, dim);
    for j in 0..dim {
        for i in 0..=j {
            let v = if i == j {
                z[tri(i, j)]
            } else {
                z[tri(i, j)] / sqrt2
            };
            m[(i, j)] = v;
            m[(j, i)] = v;
        }
    }
    let eig = m.symmetric_eigen();
    let clipped = eig.eigenvalues.map(|l| l.max(0.0));
    let m = &eig.eigenvectors
        * nalgebra::DMatrix::from_diagonal(&clipped)
        * eig.eigenvectors.transpose();
    for j in 0..dim {
        for i in 0..=j {
            let v = 0.5 * (m[(i, j)] + m[(j, i)]);
            z[tri(i, j)] = if i == j { v } else { v * sqrt2 };
        }
    }
}

/// The box of positions `y` on the set of `regions`: the intersection of the
/// regions' own boxes ([`super::relaxed_box`]), widened by a relative 1e-9
/// against its rounding. `None` when the boxes do not meet (the set is
/// empty).
fn position_box<const D: usize>(regions: &[Region<D>]) -> Option<[(f64, f64); D]> {
    let b = super::relaxed_box(regions)?;
    Some(std::array::from_fn(|k| {
        let widen = 1e-9 * (b.hi[k] - b.lo[k]).max(b.lo[k].abs()).max(b.hi[k].abs());
        (b.lo[k] - widen, b.hi[k] + widen)
    }))
}

/// A box holding every variable of [`Conic::add_set`] (no slack) on the set
/// of `regions`: `y` in [`position_box`], and an ellipse's `u1, u2` in `[0,
/// sum]`. `None` when the set is empty.
fn variable_box<const D: usize>(regions: &[Region<D>]) -> Option<Vec<(f64, f64)>> {
    let mut vars = Vec::with_capacity(D + 2 * regions.len());
    vars.extend(position_box(regions)?);
    for r in regions {
        if let Region::Ellipse { sum, .. } = *r {
            vars.extend([(0.0, sum), (0.0, sum)]);
        }
    }
    Some(vars)
}

fn settings() -> DefaultSettings<f64> {
    DefaultSettings {
        verbose: false,
        presolve_enable: false,
        chordal_decomposition_enable: false,
        ..DefaultSettings::default()
    }
}

/// Outcome of one solve.
pub(super) enum Solved {
    /// The primal objective value and the primal variables (the dual
    /// variables stay in the solver, for [`Conic::certified_min`]).
    Optimal { primal: f64, x: Vec<f64> },
    /// The problem is (numerically) primal infeasible, or, for the
    /// minimisations over certificates (min-ball SDP), unbounded below: both
    /// mean the feasible set of positions is empty.
    Infeasible,
}

pub(super) fn run(
    solver: &mut DefaultSolver<f64>,
    problem: &'static str,
) -> Result<Solved, BoundError> {
    run_with(solver, problem, false)
}

fn run_with(
    solver: &mut DefaultSolver<f64>,
    problem: &'static str,
    unbounded_means_empty: bool,
) -> Result<Solved, BoundError> {
    // clarabel's PSD cone `expect`s its LAPACK calls to succeed; dense-lapack
    // reports NaN or infinite input through `info` rather than decompose it,
    // so a diverging solve would panic inside clarabel. Report it as a solver
    // failure of this bound instead.
    if std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| solver.solve())).is_err() {
        return Err(BoundError::Solver {
            problem,
            status: "the conic solver panicked (non-finite iterate)".into(),
        });
    }
    let sol = &solver.solution;
    match sol.status {
        SolverStatus::Solved | SolverStatus::AlmostSolved => {
            if !(sol.obj_val.is_finite() && sol.obj_val_dual.is_finite())
                || sol.x.iter().any(|v| !v.is_finite())
            {
                return Err(BoundError::Solver {
                    problem,
                    status: "non-finite solution".into(),
                });
            }
            Ok(Solved::Optimal {
                primal: sol.obj_val,
                x: sol.x.clone(),
            })
        }
        SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => {
            Ok(Solved::Infeasible)
        }
        SolverStatus::DualInfeasible | SolverStatus::AlmostDualInfeasible
            if unbounded_means_empty =>
        {
            Ok(Solved::Infeasible)
        }
        other => Err(BoundError::Solver {
            problem,
            status: format!("{other:?}"),
        }),
    }
}

pub(super) fn build(
    p: &CscMatrix<f64>,
    q: &[f64],
    c: &Conic,
    problem: &'static str,
) -> Result<DefaultSolver<f64>, BoundError> {
    DefaultSolver::new(p, q, &c.a(), &c.b, &c.cones, settings()).map_err(|e| BoundError::Solver {
        problem,
        status: format!("setup: {e}"),
    })
}

/// `min t` such that every region enlarged by `t` contains a common point: the
/// minimal max-violation `t*` and its point. Always feasible and bounded below.
pub(crate) fn min_max_violation<const D: usize>(
    regions: &[Region<D>],
) -> Result<(f64, Point<D>), BoundError> {
    let mut c = Conic::new(D + 1);
    c.add_set(regions, Some(D));
    let mut q = vec![0.0; c.ncols];
    q[D] = 1.0;
    let p = CscMatrix::zeros((c.ncols, c.ncols));
    let mut s = build(&p, &q, &c, "feasibility SOCP")?;
    match run(&mut s, "feasibility SOCP")? {
        Solved::Optimal { primal, x, .. } => Ok((primal, Point::<D>::from_fn(|i, _| x[i]))),
        Solved::Infeasible => Err(BoundError::Solver {
            problem: "feasibility SOCP",
            status: "reported infeasible (cannot happen for exact data)".into(),
        }),
    }
}

/// Exact axis-aligned bounding box of the intersection, Gholami 2015 eq. (48a)-(48b):
/// `2 D` SOCPs `max / min y_l` over the set (one solver, objective updated).
/// Returns `None` when the solver finds the set empty. Each extreme is the
/// value that the solver's dual variables certify ([`Conic::certified_min`]),
/// so the box holds the set whatever the solver's accuracy (its own primal
/// and dual values can be a few 1e-8 inside on near-tangent sets).
pub(crate) fn bounding_box<const D: usize>(
    regions: &[Region<D>],
) -> Result<Option<(Point<D>, Point<D>)>, BoundError> {
    bounding_box_with(regions, &mut |_| {})
}

/// What is done to the solver's dual variables before they certify a value:
/// nothing, except in the tests that show a certificate holds for any dual
/// vector.
pub(crate) type DualTweak<'a> = &'a mut dyn FnMut(&mut [f64]);

/// [`bounding_box`] with its dual variables passed through `tweak`.
pub(crate) fn bounding_box_with<const D: usize>(
    regions: &[Region<D>],
    tweak: DualTweak<'_>,
) -> Result<Option<(Point<D>, Point<D>)>, BoundError> {
    const PROBLEM: &str = "bounding-box SOCP (48)";
    let mut c = Conic::new(D);
    c.add_set(regions, None);
    let Some(vars) = variable_box(regions) else {
        return Ok(None);
    };
    let p = CscMatrix::zeros((c.ncols, c.ncols));
    let mut q = vec![0.0; c.ncols];
    q[0] = 1.0;
    let mut s = build(&p, &q, &c, PROBLEM)?;
    let mut ext = vec![0.0; 2 * D];
    for (k, e) in ext.iter_mut().enumerate() {
        let (axis, sign) = (k / 2, if k % 2 == 0 { 1.0 } else { -1.0 });
        if k > 0 {
            q.iter_mut().for_each(|v| *v = 0.0);
            q[axis] = sign;
            s.update_q(&q).map_err(|e| BoundError::Solver {
                problem: PROBLEM,
                status: format!("update: {e}"),
            })?;
        }
        match run(&mut s, PROBLEM)? {
            // min sign * y_axis is at least the certified value (outer box).
            Solved::Optimal { .. } => {
                *e = sign * c.certify(&q, &s, &vars, tweak, PROBLEM)?;
            }
            Solved::Infeasible => return Ok(None),
        }
    }
    // ext = [lo_0, hi_0, lo_1, hi_1, ...].
    Ok(Some((
        Point::<D>::from_fn(|i, _| ext[2 * i]),
        Point::<D>::from_fn(|i, _| ext[2 * i + 1]),
    )))
}

/// The support function `h_B(u) = max_{y in B} u . y` of the set of `regions`
/// in any direction, by one solver whose objective is updated per
/// direction: the value its dual variables certify
/// ([`Conic::certified_min`], an upper bound whatever the solver's
/// accuracy) and the solver's maximiser.
pub(crate) struct Support<const D: usize> {
    conic: Conic,
    solver: DefaultSolver<f64>,
    vars: Vec<(f64, f64)>,
    q: Vec<f64>,
}

/// What [`Support::eval`] gives.
pub(crate) enum SupportValue<const D: usize> {
    /// A certified upper bound on `h_B(u)`, and the solver's maximiser.
    Value(f64, Point<D>),
    /// The solver found the set empty.
    Empty,
}

impl<const D: usize> Support<D> {
    const PROBLEM: &'static str = "support-function SOCP";

    /// `None` when the regions' boxes do not meet (the set is empty).
    pub(crate) fn new(regions: &[Region<D>]) -> Result<Option<Self>, BoundError> {
        let mut conic = Conic::new(D);
        conic.add_set(regions, None);
        let Some(vars) = variable_box(regions) else {
            return Ok(None);
        };
        let p = CscMatrix::zeros((conic.ncols, conic.ncols));
        let mut q = vec![0.0; conic.ncols];
        q[0] = -1.0;
        let solver = build(&p, &q, &conic, Self::PROBLEM)?;
        Ok(Some(Support {
            conic,
            solver,
            vars,
            q,
        }))
    }

    /// `h_B(u)` for the direction `u` (any length).
    pub(crate) fn eval(&mut self, u: &Point<D>) -> Result<SupportValue<D>, BoundError> {
        self.q.iter_mut().for_each(|v| *v = 0.0);
        for k in 0..D {
            self.q[k] = -u[k];
        }
        self.solver
            .update_q(&self.q)
            .map_err(|e| BoundError::Solver {
                problem: Self::PROBLEM,
                status: format!("update: {e}"),
            })?;
        match run(&mut self.solver, Self::PROBLEM)? {
            Solved::Optimal { x, .. } => {
                // min -u . y >= m, so h_B(u) <= -m.
                let m = self.conic.certify(
                    &self.q,
                    &self.solver,
                    &self.vars,
                    &mut |_| {},
                    Self::PROBLEM,
                )?;
                Ok(SupportValue::Value(-m, Point::<D>::from_fn(|i, _| x[i])))
            }
            Solved::Infeasible => Ok(SupportValue::Empty),
        }
    }
}

/// Upper triangle column-major index of `(i, j)`, `i <= j`, in Clarabel's
/// scaled PSD triangle vector.
fn tri(i: usize, j: usize) -> usize {
    j * (j + 1) / 2 + i
}

/// Append the rows of a `dim x dim` PSD triangle cone; `entry(i, j)` gives the
/// affine entry `M_ij = constant + sum coef * v[col]` as `(constant, coefs)`.
fn add_psd(c: &mut Conic, dim: usize, entry: impl Fn(usize, usize) -> (f64, Vec<(usize, f64)>)) {
    let sqrt2 = std::f64::consts::SQRT_2;
    let mut order = vec![(0, 0); dim * (dim + 1) / 2];
    for j in 0..dim {
        for i in 0..=j {
            order[tri(i, j)] = (i, j);
        }
    }
    for &(i, j) in &order {
        let w = if i == j { 1.0 } else { sqrt2 };
        let (k, coefs) = entry(i, j);
        let neg: Vec<(usize, f64)> = coefs.iter().map(|&(col, v)| (col, -w * v)).collect();
        c.row(&neg, w * k);
    }
    c.cones.push(PSDTriangleConeT(dim));
}

/// SDP relaxation (Gholami 2015 eq. (2), (25)-(26)) of `max ||x - x_hat||^2` over the
/// quadratics: variables `v = [x_1..x_D, Z_ij (i <= j, row by row)]` (in 2-D
/// `[x1, x2, Z11, Z12, Z22]`),
/// `max tr(Z) - 2 x_hat^T x + ||x_hat||^2` s.t. `tr(P_k Z) + 2 q_k^T x + r_k <= 0`,
/// `[[Z, x], [x^T, 1]] >= 0` (a `(D+1)x(D+1)` PSD block). Returns the value the
/// solver's dual variables certify ([`Conic::certified_min`], with `x` in the
/// box of the `regions` the quadratics describe and `Z` in [`moment_box`]), so
/// it bounds the relaxation whatever the solver's accuracy; `None` if
/// infeasible.
pub(crate) fn maxdis_sdp<const D: usize>(
    regions: &[Region<D>],
    quads: &[Quadratic<D>],
    x_hat: &Point<D>,
) -> Result<Option<f64>, BoundError> {
    maxdis_sdp_with(regions, quads, x_hat, &mut |_| {})
}

/// [`maxdis_sdp`] with its dual variables passed through `tweak`.
pub(crate) fn maxdis_sdp_with<const D: usize>(
    regions: &[Region<D>],
    quads: &[Quadratic<D>],
    x_hat: &Point<D>,
    tweak: DualTweak<'_>,
) -> Result<Option<f64>, BoundError> {
    const PROBLEM: &str = "Upp-MaxDis SDP (26)";
    let Some(xbox) = position_box(regions) else {
        return Ok(None);
    };
    let Some(zbox) = moment_box(quads, &xbox) else {
        return Err(BoundError::Solver {
            problem: PROBLEM,
            status: "no quadratic bounds the moments (no positive definite P_k)".into(),
        });
    };
    let upper: Vec<(usize, usize)> = (0..D).flat_map(|i| (i..D).map(move |j| (i, j))).collect();
    let n = D + upper.len();
    let mut vars = xbox.to_vec();
    vars.extend(zbox);
    let mut c = Conic::new(n);
    for qd in quads {
        let p = &qd.p;
        let mut coefs: Vec<(usize, f64)> = (0..D).map(|k| (k, 2.0 * qd.q[k])).collect();
        for (col, &(i, j)) in upper.iter().enumerate() {
            let v = if i == j {
                p[(i, i)]
            } else {
                p[(i, j)] + p[(j, i)]
            };
            coefs.push((D + col, v));
        }
        c.row(&coefs, -qd.r);
    }
    c.cones.push(NonnegativeConeT(quads.len()));
    // The column of Z_ij, i <= j.
    let mut z_col = [[0usize; D]; D];
    for (col, &(i, j)) in upper.iter().enumerate() {
        z_col[i][j] = D + col;
    }
    add_psd(&mut c, D + 1, |i, j| {
        if j < D {
            (0.0, vec![(z_col[i][j], 1.0)])
        } else if i < D {
            (0.0, vec![(i, 1.0)])
        } else {
            (1.0, vec![])
        }
    });
    let mut q: Vec<f64> = (0..D).map(|k| 2.0 * x_hat[k]).collect();
    q.extend(upper.iter().map(|&(i, j)| if i == j { -1.0 } else { 0.0 }));
    let p = CscMatrix::zeros((n, n));
    let mut s = build(&p, &q, &c, PROBLEM)?;
    match run(&mut s, PROBLEM)? {
        Solved::Optimal { .. } => {
            let m = c.certify(&q, &s, &vars, tweak, PROBLEM)?;
            let xx = x_hat.norm_squared();
            Ok(Some(-m + xx + round_off(m.abs() + xx)))
        }
        Solved::Infeasible => Ok(None),
    }
}

/// A box holding the moment variables `Z_ij` (`i <= j`, row by row) of every
/// feasible point of the Upp-MaxDis SDP: `[[Z, x], [x^T, 1]] >= 0` gives
/// `Z >= 0`, so `|Z_ij| <= tr(Z) / 2` off the diagonal, and a quadratic with
/// `P_k >= mu I`, `mu > 0` (every disc, and the disc each ellipse
/// circumscribes, has `P = I`) gives `mu tr(Z) <= tr(P_k Z) <= -2 q_k^T x -
/// r_k`, bounded over the box of `x`. `None` when no `P_k` is positive
/// definite.
fn moment_box<const D: usize>(
    quads: &[Quadratic<D>],
    xbox: &[(f64, f64); D],
) -> Option<Vec<(f64, f64)>> {
    let trace = quads
        .iter()
        .filter_map(|qd| {
            let p = 0.5 * (qd.p + qd.p.transpose());
            let mu = sym_eigenvalues(&p)?.min();
            (mu > 0.0).then(|| {
                let lin: f64 =
                    qd.q.iter()
                        .zip(xbox)
                        .map(|(q, (lo, hi))| (-2.0 * q * lo).max(-2.0 * q * hi))
                        .sum();
                let t = (lin - qd.r) / mu;
                t + round_off(t.abs() + qd.r.abs() / mu)
            })
        })
        .fold(f64::INFINITY, f64::min);
    // A negative bound means no feasible point at all, of which any box holds.
    let t = trace.max(0.0);
    trace.is_finite().then(|| {
        (0..D)
            .flat_map(|i| (i..D).map(move |j| (i, j)))
            .map(|(i, j)| {
                if i == j {
                    (0.0, t)
                } else {
                    (-t / 2.0, t / 2.0)
                }
            })
            .collect()
    })
}

/// Minimum-ball bound for discs only, Gholami 2015 eq. (43) as a convex QP over the
/// simplex: `v = [lambda_1..lambda_N, c_1..c_D]`,
/// `min ||c||^2 - sum lambda_i (||a_i||^2 - d_i^2)` s.t. `c = sum lambda_i a_i`,
/// `sum lambda_i = 1`, `lambda >= 0`. The returned `(c, R^2)` is re-evaluated
/// exactly from the clipped, renormalised `lambda` (plus an allowance for the
/// rounding of the difference that gives `R^2`), so it is a valid S-lemma
/// certificate (eq. (35)) whatever the solver accuracy; `R^2 < 0` certifies an
/// empty set.
pub(crate) fn minball_qp<const D: usize>(
    discs: &[(Point<D>, f64)],
) -> Result<(Point<D>, f64), BoundError> {
    const PROBLEM: &str = "Upp-MinBall QP (43)";
    let n = discs.len();
    let mut c = Conic::new(n + D);
    c.row(&(0..n).map(|i| (i, 1.0)).collect::<Vec<_>>(), 1.0);
    for axis in 0..D {
        let mut r = vec![(n + axis, 1.0)];
        r.extend(discs.iter().enumerate().map(|(i, (a, _))| (i, -a[axis])));
        c.row(&r, 0.0);
    }
    c.cones.push(ZeroConeT(1 + D));
    for i in 0..n {
        c.row(&[(i, -1.0)], 0.0);
    }
    c.cones.push(NonnegativeConeT(n));
    let mut q: Vec<f64> = discs
        .iter()
        .map(|(a, d)| -(a.norm_squared() - d * d))
        .collect();
    q.extend([0.0; D]);
    let diag: Vec<usize> = (n..n + D).collect();
    let p = CscMatrix::new_from_triplets(n + D, n + D, diag.clone(), diag, vec![2.0; D]);
    let mut s = build(&p, &q, &c, PROBLEM)?;
    let lam = match run(&mut s, PROBLEM)? {
        Solved::Optimal { x, .. } => x[..n].to_vec(),
        Solved::Infeasible => {
            return Err(BoundError::Solver {
                problem: PROBLEM,
                status: "simplex reported infeasible".into(),
            });
        }
    };
    Ok(ball_from_simplex(discs, &lam))
}

/// Exact eq. (42)-(43) evaluation for a (clipped, renormalised) `lambda`.
pub(crate) fn ball_from_simplex<const D: usize>(
    discs: &[(Point<D>, f64)],
    lam: &[f64],
) -> (Point<D>, f64) {
    let clipped: Vec<f64> = lam.iter().map(|l| l.max(0.0)).collect();
    let total: f64 = clipped.iter().sum();
    let n = discs.len() as f64;
    let w: Vec<f64> = if total > 0.0 {
        clipped.iter().map(|l| l / total).collect()
    } else {
        vec![1.0 / n; discs.len()]
    };
    let xc = discs
        .iter()
        .zip(&w)
        .fold(Point::<D>::zeros(), |s, ((a, _), l)| s + a * *l);
    let offsets = discs
        .iter()
        .zip(&w)
        .map(|((a, d), l)| l * (a.norm_squared() - d * d))
        .sum::<f64>();
    // ||xc||^2 <= sum w ||a||^2 (convexity), so this bounds every term.
    let size = discs
        .iter()
        .zip(&w)
        .map(|((a, d), l)| l * (a.norm_squared() + d * d))
        .sum::<f64>();
    (xc, xc.norm_squared() - offsets + round_off(2.0 * size))
}

/// General S-lemma minimum enclosing ball (Gholami 2015 eq. (34)-(37) with quadratic
/// constraints `x^T P_k x + 2 q_k^T x + r_k <= 0`): `v = [lambda_1..lambda_K, c_1..c_D, gamma]`,
/// `min gamma` s.t. `lambda >= 0` and the `(2D+1)x(2D+1)` LMI (5x5 in 2-D)
/// `[[S, g, 0], [g^T, h, c^T], [0, c, I]] >= 0`, `S = sum lambda_k P_k - I`,
/// `g = sum lambda_k q_k + c`, `h = sum lambda_k r_k + gamma` (Schur form of
/// eq. (37), `gamma - ||c||^2` in the corner). Returns `(c, gamma)` with the
/// conservative (larger) objective value, or `None` when `gamma` is unbounded
/// below (the set is empty).
pub(crate) fn minball_sdp<const D: usize>(
    quads: &[Quadratic<D>],
) -> Result<Option<(Point<D>, f64)>, BoundError> {
    const PROBLEM: &str = "Upp-MinBall S-lemma SDP (37)";
    let k = quads.len();
    // Columns: lambda (k), c (D), gamma.
    let (c0, g) = (k, k + D);
    let mut c = Conic::new(k + D + 1);
    for i in 0..k {
        c.row(&[(i, -1.0)], 0.0);
    }
    c.cones.push(NonnegativeConeT(k));
    add_psd(&mut c, 2 * D + 1, |i, j| {
        let lam = |f: &dyn Fn(&Quadratic<D>) -> f64| -> Vec<(usize, f64)> {
            quads
                .iter()
                .enumerate()
                .map(|(idx, qd)| (idx, f(qd)))
                .collect()
        };
        // Blocks: S on 0..D, h at D, I on D+1..2D+1 (i <= j).
        if j < D {
            if i == j {
                (-1.0, lam(&|qd| qd.p[(i, i)]))
            } else {
                (0.0, lam(&|qd| 0.5 * (qd.p[(i, j)] + qd.p[(j, i)])))
            }
        } else if j == D && i < D {
            let mut v = lam(&|qd| qd.q[i]);
            v.push((c0 + i, 1.0));
            (0.0, v)
        } else if j == D {
            let mut v = lam(&|qd| qd.r);
            v.push((g, 1.0));
            (0.0, v)
        } else if i == D {
            (0.0, vec![(c0 + j - D - 1, 1.0)])
        } else if i == j {
            (1.0, vec![])
        } else {
            (0.0, vec![])
        }
    });
    let mut q = vec![0.0; k + D + 1];
    q[g] = 1.0;
    let p = CscMatrix::zeros((k + D + 1, k + D + 1));
    let mut s = build(&p, &q, &c, PROBLEM)?;
    // gamma unbounded below certifies ||x - c||^2 <= gamma < 0 on the set: empty.
    match run_with(&mut s, PROBLEM, true)? {
        Solved::Optimal { x, .. } => match ball_from_multipliers(quads, &x[..k]) {
            Some(ball) => Ok(Some(ball)),
            None => Err(BoundError::Solver {
                problem: PROBLEM,
                status: "its multipliers certify no bounded ball (sum lambda_k P_k is singular)"
                    .into(),
            }),
        },
        Solved::Infeasible => Ok(None),
    }
}

/// The enclosing ball that multipliers `lambda` certify, evaluated exactly
/// (Gholami 2015 eq. (35)-(37) for fixed `lambda`): with `H = sum lambda_k P_k`,
/// `b = sum lambda_k q_k` and `rho = sum lambda_k r_k`, every `x` of the set
/// has `x^T H x + 2 b^T x + rho <= 0`, that is `(x - c)^T H (x - c) <= gamma`
/// for `c = -H^-1 b` and `gamma = b^T H^-1 b - rho`; when `H >= I` this gives
/// `||x - c||^2 <= gamma`. The solver's `lambda` is clipped to `>= 0` and
/// scaled so that the smallest eigenvalue of `H` is at least 1 (scaling
/// keeps a certificate valid), so the ball is valid whatever the solver's
/// accuracy, as [`ball_from_simplex`] is for discs (with discs and
/// `sum lambda = 1`, `H = I` and the two agree). `None` if no scaling makes
/// `H >= I` (a singular `H`: the multipliers certify no bounded ball).
pub(crate) fn ball_from_multipliers<const D: usize>(
    quads: &[Quadratic<D>],
    lam: &[f64],
) -> Option<(Point<D>, f64)> {
    let lam: Vec<f64> = lam.iter().map(|l| l.max(0.0)).collect();
    let h: MatD<D> = quads.iter().zip(&lam).map(|(qd, l)| qd.p * *l).sum();
    let h = 0.5 * (h + h.transpose());
    let eig = sym_eigenvalues(&h)?;
    let (smallest, largest) = (eig.min(), eig.max());
    if !(smallest.is_finite() && smallest > 0.0) {
        return None;
    }
    let t = (1.0 / smallest).max(1.0);
    let h = h * t;
    let b: Point<D> = quads.iter().zip(&lam).map(|(qd, l)| qd.q * (*l * t)).sum();
    let rho: f64 = quads.iter().zip(&lam).map(|(qd, l)| qd.r * *l * t).sum();
    let rho_size: f64 = quads
        .iter()
        .zip(&lam)
        .map(|(qd, l)| (qd.r * *l * t).abs())
        .sum();
    let c = -h.cholesky()?.solve(&b);
    // b^T H^-1 b = -b^T c, to a relative accuracy of about eps * cond(H).
    let bhb = -b.dot(&c);
    let size = bhb.abs() * (largest / smallest) + rho_size;
    Some((c, bhb - rho + round_off(size)))
}

/// Outward allowance for the rounding of `R^2`, a difference of sums whose
/// terms add up to `size` in magnitude: when the set is nearly a point,
/// `R^2` is a small difference of large numbers, and a few ulps of them
/// would otherwise make the ball smaller than the set.
fn round_off(size: f64) -> f64 {
    64.0 * f64::EPSILON * size
}
