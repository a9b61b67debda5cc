//! The GTRS of Mourya 2017 eq. (13) in any dimension: the global minimiser of
//! `q(y) = 1/2 y^T A y - b^T y` over the upper nappe of the cone of eq. (12),
//! `{y in R^M : ||y[0..M-1]|| = y[M-1] >= 0}`, for the lifted variable
//! `theta~ = [theta, d]` of a position `theta` in `R^(M-1)` (`M = 4` in 3-D).
//!
//! # Why the secular equation keeps its form in 3-D
//!
//! The constraint matrix of eq. (12) is `S = diag(1, ..., 1, -1)`: in every
//! dimension it has two distinct eigenvalues, `+1` (the position block) and
//! `-1` (the range `d`), so it is indefinite with inertia `(M - 1, 1)`. With
//! `A = L L^T` (Cholesky; `A = H + I/gamma` is positive definite) and the
//! eigendecomposition `L^{-1} S L^{-T} = Q D Q^T`, the change of variables
//! `y = V z`, `V = L^{-T} Q`, gives `V^T A V = I` and `V^T S V = D`; by
//! Sylvester's law of inertia `D` has `M - 1` positive entries and one
//! negative one, exactly as in 2-D. With `beta = V^T b` the problem is
//!
//! `min 1/2 ||z||^2 - beta^T z  s.t.  z^T D z = 0`,
//!
//! and its KKT points are `(I + lambda D) z = beta`, i.e.
//! `z_i = beta_i / (1 + lambda d_i)`, where `lambda` solves the secular
//! equation (Beck, Stoica and Li 2008, Mourya 2017 ref. 6; Moré 1993)
//!
//! `phi(lambda) = sum_i d_i beta_i^2 / (1 + lambda d_i)^2 = 0`.
//!
//! Only the number of terms changes with the dimension: clearing the
//! denominators gives `p(lambda) = sum_i d_i beta_i^2 prod_{j != i} (1 +
//! lambda d_j)^2`, of degree `2 (M - 1)`: the quartic of the 2-D case
//! ([`super::gtrs`]) becomes a sextic in 3-D, and has no closed form.
//!
//! # Method
//!
//! The minimum of `q` on the upper nappe is `-1/2 max_w F(w)`, `F(w) =
//! max(b^T w, 0)^2 / (w^T A w)` over the directions `w = [e, 1]`, `||e|| = 1`
//! (for fixed `w`, `q(rho w)` is a parabola in `rho >= 0`; see
//! [`super::gtrs`]). A maximiser of `F` with `F > 0` is a stationary point on
//! the smooth part of the cone, hence a KKT point: either a real root of
//! `p` that is not a pole, or a pole `-1/d_i` with `beta_i = 0` (the "hard
//! case"), where `z_i` is free and fixed by the constraint. `F = 0`
//! everywhere means the apex is optimal.
//!
//! The candidates are therefore: every real root of `p` (the eigenvalues of
//! its companion matrix, polished by Newton steps on `phi` itself), the real
//! part of every complex pair (a near-double real root perturbed into a
//! pair by rounding), both hard-case points of every pole, and the limits
//! `lambda = 0` (the unconstrained minimiser) and `lambda -> infinity`
//! (direction `D^{-1} beta`). Each candidate `y` is mapped to the feasible
//! direction `w = [y_p / ||y_p||, 1]` and scored by the exact `F(w)`, so the
//! answer is always feasible and at least as good as every candidate; the
//! apex (`F = 0`) is the fallback. Extra candidates can only help.

use crate::estimators::prox::gtrs::ProxError;
use nalgebra::{DMatrix, DVector, SMatrix, SVector};

/// Iterations of the Schur decomposition of the companion matrix before it
/// gives up (it converges in a few dozen on every case seen).
const SCHUR_ITERATIONS: usize = 500;

/// Newton steps on `phi` from each root of the companion matrix.
const POLISH_STEPS: usize = 8;

/// The global minimiser of `1/2 y^T A y - b^T y` over the upper nappe
/// `||y[0..M-1]|| = y[M-1] >= 0` (Mourya 2017 eq. 12-13 in shifted
/// coordinates `y = theta~ - r~_v`), for `M >= 2`. `a` must be symmetric
/// positive definite.
///
/// Errors: [`ProxError::NonFinite`] for non-finite input,
/// [`ProxError::Degenerate`] if `a` is not positive definite or the
/// decomposition fails.
pub fn min_quadratic_on_upper_nappe_n<const M: usize>(
    a: &SMatrix<f64, M, M>,
    b: &SVector<f64, M>,
) -> Result<SVector<f64, M>, ProxError> {
    let y = min_on_nappe(
        DMatrix::from_column_slice(M, M, a.as_slice()),
        DVector::from_column_slice(b.as_slice()),
    )?;
    Ok(SVector::<f64, M>::from_column_slice(y.as_slice()))
}

/// [`min_quadratic_on_upper_nappe_n`] on dynamic matrices (`M = a.nrows()`).
fn min_on_nappe(a: DMatrix<f64>, b: DVector<f64>) -> Result<DVector<f64>, ProxError> {
    let m = a.nrows();
    if m < 2 || a.ncols() != m || b.len() != m {
        return Err(ProxError::Degenerate("the nappe needs M >= 2".into()));
    }
    if !a.iter().chain(b.iter()).all(|x| x.is_finite()) {
        return Err(ProxError::NonFinite("GTRS quadratic data"));
    }
    // The minimiser is invariant under (A, b) -> (A, b) / alpha.
    let alpha = (0..m).map(|i| a[(i, i)]).fold(0.0, f64::max);
    if alpha.is_nan() || alpha <= 0.0 {
        return Err(ProxError::Degenerate(
            "A = H + I/gamma has a non-positive diagonal".into(),
        ));
    }
    let a = a / alpha;
    let b = b / alpha;
    let not_pd = || ProxError::Degenerate("A = H + I/gamma is not positive definite".into());
    let chol = a.clone().cholesky().ok_or_else(not_pd)?;
    let l_inv = chol
        .l()
        .solve_lower_triangular(&DMatrix::identity(m, m))
        .ok_or_else(not_pd)?;
    let mut s = DMatrix::identity(m, m);
    s[(m - 1, m - 1)] = -1.0;
    let ms = &l_inv * s * l_inv.transpose();
    let eig = nalgebra::SymmetricEigen::try_new(ms, f64::EPSILON, 1000).ok_or_else(not_pd)?;
    let d = eig.eigenvalues;
    // V = L^{-T} Q: y = V z.
    let v = l_inv.transpose() * eig.eigenvectors;
    let beta = v.transpose() * &b;

    let mut best = Best::new(&a, &b);
    let mut consider_z = |z: &DVector<f64>| best.consider(&(&v * z));
    // lambda = 0 (the unconstrained minimiser) and lambda -> infinity.
    consider_z(&beta);
    consider_z(&beta.component_div(&d));
    // Hard cases: a pole -1/d_i, z_i fixed by the constraint.
    for i in 0..m {
        let lambda = -1.0 / d[i];
        let mut z = DVector::zeros(m);
        let mut rest = 0.0;
        for j in 0..m {
            let den = 1.0 + lambda * d[j];
            if j != i && den.abs() > 1e-12 * (1.0 + (lambda * d[j]).abs()) {
                z[j] = beta[j] / den;
                rest += d[j] * z[j] * z[j];
            }
        }
        let zi2 = -rest / d[i];
        if zi2 >= 0.0 {
            for sign in [1.0, -1.0] {
                z[i] = sign * zi2.sqrt();
                consider_z(&z);
            }
        }
    }
    // Roots of the secular polynomial.
    for lambda in secular_roots(&d, &beta) {
        let lambda = polish(&d, &beta, lambda);
        let z = DVector::from_fn(m, |i, _| beta[i] / (1.0 + lambda * d[i]));
        if z.iter().all(|x| x.is_finite()) {
            consider_z(&z);
        }
    }
    Ok(best.point())
}

/// The candidate directions with `F > 0` and, once refined, the best:
/// `F(w) = max(b^T w, 0)^2 / (w^T A w)`, `w = [e, 1]`, the apex (`F = 0`)
/// to begin with.
struct Best<'a> {
    a: &'a DMatrix<f64>,
    b: &'a DVector<f64>,
    /// Unit position directions `e` of the candidates.
    seeds: Vec<DVector<f64>>,
}

impl<'a> Best<'a> {
    fn new(a: &'a DMatrix<f64>, b: &'a DVector<f64>) -> Self {
        Best {
            a,
            b,
            seeds: Vec::new(),
        }
    }

    /// `w = [e, 1]`, `b^T w` and `w^T A w`.
    fn eval(&self, e: &DVector<f64>) -> (DVector<f64>, f64, f64) {
        let m = self.b.len();
        let w = DVector::from_fn(m, |i, _| if i + 1 < m { e[i] } else { 1.0 });
        let bw = self.b.dot(&w);
        let aw = w.dot(&(self.a * &w));
        (w, bw, aw)
    }

    /// The value `F` at direction `e` (0 where `b^T w <= 0`).
    fn f(&self, e: &DVector<f64>) -> f64 {
        let (_, bw, aw) = self.eval(e);
        if bw > 0.0 && aw > 0.0 {
            bw * bw / aw
        } else {
            0.0
        }
    }

    /// Take the feasible direction through `y`'s position part as a seed.
    fn consider(&mut self, y: &DVector<f64>) {
        let m = y.len();
        let norm = y.rows(0, m - 1).norm();
        if !(norm.is_finite() && norm > 0.0) {
            return;
        }
        let e = y.rows(0, m - 1) / norm;
        if self.f(&e) > 0.0 {
            self.seeds.push(e);
        }
    }

    /// The Riemannian gradient and Hessian of `log F` at `e` (where
    /// `b^T w > 0`) in the orthonormal tangent basis `t`, and the size of
    /// the gradient's terms (what rounding leaves of it is relative to that).
    fn derivatives(&self, e: &DVector<f64>) -> Derivatives {
        let n = e.len();
        let (w, bw, aw) = self.eval(e);
        let aw_vec = self.a * &w;
        let bp = self.b.rows(0, n);
        let awp = aw_vec.rows(0, n);
        // log F = 2 log(b^T w) - log(w^T A w), as a function of e.
        let g1 = bp * (2.0 / bw);
        let g2 = awp * (2.0 / aw);
        let scale = g1.norm() + g2.norm();
        let g = g1 - g2;
        let h = -(bp * bp.transpose()) * (2.0 / (bw * bw))
            - self.a.view((0, 0), (n, n)) * (2.0 / aw)
            + (awp * awp.transpose()) * (4.0 / (aw * aw));
        let t = tangent_basis(e);
        let rg = t.transpose() * &g;
        let rh = t.transpose() * (h - DMatrix::identity(n, n) * e.dot(&g)) * &t;
        Derivatives { t, rg, rh, scale }
    }

    /// Whether `e` is a stationary direction to rounding.
    fn stationary(&self, d: &Derivatives) -> bool {
        d.rg.norm() <= STATIONARY * d.scale
    }

    /// Newton ascent of `log F` on the sphere of directions from `e`. Near
    /// the maximum (a small Newton step with a negative definite Hessian)
    /// the step is taken if `F` does not fall beyond rounding: `F` is flat
    /// there, and the step moves the direction to the stationary point.
    /// Farther away a step is halved until `F` grows.
    fn refine(&self, mut e: DVector<f64>) -> (f64, DVector<f64>) {
        let mut f = self.f(&e);
        for _ in 0..REFINE_STEPS {
            if f <= 0.0 {
                break;
            }
            let d = self.derivatives(&e);
            if self.stationary(&d) {
                break;
            }
            let newton = (-&d.rh).cholesky().map(|ch| ch.solve(&d.rg));
            if let Some(step) = &newton
                && step.norm() <= 1e-6
            {
                let cand = &e + &d.t * step;
                let cand = &cand / cand.norm();
                let fc = self.f(&cand);
                if fc >= f * (1.0 - 8.0 * f64::EPSILON) {
                    (e, f) = (cand, fc.max(f));
                    continue;
                }
                break;
            }
            let step = newton.unwrap_or_else(|| d.rg.clone() / d.rh.norm().max(d.rg.norm()));
            let mut scale = 1.0;
            let mut moved = false;
            for _ in 0..24 {
                let cand = &e + &d.t * &step * scale;
                let cand = &cand / cand.norm();
                let fc = self.f(&cand);
                if fc > f {
                    (e, f, moved) = (cand, fc, true);
                    break;
                }
                scale *= 0.5;
            }
            if !moved {
                break;
            }
        }
        (self.f(&e), e)
    }

    /// `rho w` for the best refined direction (the apex when none has
    /// `F > 0`). Only seeds within [`REFINE_BAND`] of the best seed's value
    /// are refined: a KKT point from a root is exact to rounding except
    /// near the hard case, where its value is still within that band.
    fn point(&self) -> DVector<f64> {
        let m = self.b.len();
        let mut scored: Vec<(f64, &DVector<f64>)> =
            self.seeds.iter().map(|e| (self.f(e), e)).collect();
        scored.sort_by(|x, y| y.0.total_cmp(&x.0));
        let Some(&(top, _)) = scored.first() else {
            return DVector::zeros(m);
        };
        let mut best: Option<(f64, DVector<f64>)> = None;
        let mut refined: Vec<&DVector<f64>> = Vec::new();
        for &(f, e) in &scored {
            if f < top * (1.0 - REFINE_BAND) || refined.len() == MAX_REFINED {
                break;
            }
            if refined.iter().any(|r| (*r - e).norm() <= 1e-9) {
                continue;
            }
            refined.push(e);
            // A seed that is already stationary (a well-polished root) is
            // taken as it is; refining it could only move it by rounding.
            let (f, e) = if self.stationary(&self.derivatives(e)) {
                (f, e.clone())
            } else {
                self.refine(e.clone())
            };
            if best.as_ref().is_none_or(|(fb, _)| f > *fb) {
                best = Some((f, e));
            }
        }
        match best {
            Some((_, e)) => {
                let (w, bw, aw) = self.eval(&e);
                w * (bw.max(0.0) / aw)
            }
            None => DVector::zeros(m),
        }
    }
}

/// Seeds whose `F` is within this fraction of the best seed's are refined.
const REFINE_BAND: f64 = 1e-3;

/// The Riemannian gradient of `log F`, relative to its terms, below which a
/// direction is stationary to rounding.
const STATIONARY: f64 = 1e-13;

/// At most this many distinct seeds are refined.
const MAX_REFINED: usize = 4;

/// What [`Best::derivatives`] gives.
struct Derivatives {
    /// Orthonormal basis of the tangent space (columns).
    t: DMatrix<f64>,
    /// Riemannian gradient of `log F` in that basis.
    rg: DVector<f64>,
    /// Riemannian Hessian of `log F` in that basis.
    rh: DMatrix<f64>,
    /// Size of the gradient's terms.
    scale: f64,
}

/// Steps of [`Best::refine`] per seed.
const REFINE_STEPS: usize = 30;

/// An orthonormal basis (columns) of the complement of the unit vector `e`:
/// Gram-Schmidt on the coordinate axes, the axis closest to `e` left out.
fn tangent_basis(e: &DVector<f64>) -> DMatrix<f64> {
    let n = e.len();
    let skip = e.iamax();
    let mut cols: Vec<DVector<f64>> = Vec::with_capacity(n - 1);
    for k in (0..n).filter(|&k| k != skip) {
        let mut v = DVector::zeros(n);
        v[k] = 1.0;
        v -= e * e[k];
        for c in &cols {
            let proj = c.dot(&v);
            v -= c * proj;
        }
        let norm = v.norm();
        cols.push(v / norm);
    }
    DMatrix::from_columns(&cols)
}

/// The real roots of `p(lambda) = sum_i d_i beta_i^2 prod_{j != i} (1 +
/// lambda d_j)^2` and the real parts of its complex pairs: the eigenvalues of
/// its companion matrix (leading coefficients negligible against the
/// largest are dropped: those roots went to infinity, the `lambda ->
/// infinity` candidate).
fn secular_roots(d: &DVector<f64>, beta: &DVector<f64>) -> Vec<f64> {
    let m = d.len();
    // Coefficients, lowest degree first.
    let mut p = vec![0.0; 2 * m - 1];
    for i in 0..m {
        let mut term = vec![d[i] * beta[i] * beta[i]];
        for j in (0..m).filter(|&j| j != i) {
            // Multiply by (1 + lambda d_j)^2 = 1 + 2 d_j lambda + d_j^2 lambda^2.
            let f = [1.0, 2.0 * d[j], d[j] * d[j]];
            let mut next = vec![0.0; term.len() + 2];
            for (k, t) in term.iter().enumerate() {
                for (l, g) in f.iter().enumerate() {
                    next[k + l] += t * g;
                }
            }
            term = next;
        }
        for (k, t) in term.iter().enumerate() {
            p[k] += t;
        }
    }
    let scale = p.iter().fold(0.0, |m: f64, c| m.max(c.abs()));
    if !(scale.is_finite() && scale > 0.0) {
        return Vec::new();
    }
    while p.len() > 1 && p[p.len() - 1].abs() <= 1e-14 * scale {
        p.pop();
    }
    let n = p.len() - 1;
    if n == 0 {
        return Vec::new();
    }
    let lead = p[n];
    let companion = DMatrix::from_fn(n, n, |i, j| {
        if j == n - 1 {
            -p[i] / lead
        } else if i == j + 1 {
            1.0
        } else {
            0.0
        }
    });
    match nalgebra::Schur::try_new(companion, f64::EPSILON, SCHUR_ITERATIONS) {
        Some(schur) => schur
            .complex_eigenvalues()
            .iter()
            .map(|c| c.re)
            .filter(|x| x.is_finite())
            .collect(),
        None => Vec::new(),
    }
}

/// Newton steps on `phi(lambda) = sum_i d_i beta_i^2 / (1 + lambda d_i)^2`
/// from `lambda`, keeping the iterate with the smallest `|phi|` relative to
/// its terms.
fn polish(d: &DVector<f64>, beta: &DVector<f64>, lambda: f64) -> f64 {
    let eval = |l: f64| {
        let (mut phi, mut dphi, mut mag) = (0.0, 0.0, 0.0);
        for i in 0..d.len() {
            let den = 1.0 + l * d[i];
            let t = d[i] * beta[i] * beta[i] / (den * den);
            phi += t;
            mag += t.abs();
            dphi -= 2.0 * d[i] * t / den;
        }
        (phi, dphi, mag)
    };
    let (mut best, mut best_res) = (lambda, f64::INFINITY);
    let mut l = lambda;
    for _ in 0..=POLISH_STEPS {
        let (phi, dphi, mag) = eval(l);
        let res = phi.abs() / mag;
        if !res.is_finite() {
            break;
        }
        if res < best_res {
            best = l;
            best_res = res;
        }
        if res <= 4.0 * f64::EPSILON || dphi == 0.0 {
            break;
        }
        l -= phi / dphi;
    }
    best
}

#[cfg(test)]
mod tests;
