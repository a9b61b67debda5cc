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
//! First the fast path of the `monotone` submodule: the minimiser over the whole cone is
//! the one root of the secular function on the interval where `A + lambda S`
//! (`S = diag(1, ..., 1, -1)`) is positive definite, found by a bracketed
//! Newton iteration on Cholesky factors and certified by the factor itself;
//! when it lies on the upper nappe it is the answer. Otherwise (the root on
//! the lower nappe, the hard case, an ill-conditioned factor) every KKT point
//! is enumerated, as follows.
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
//! The candidates are therefore: every real root of `p` (all its complex
//! roots by the Aberth-Ehrlich iteration, polished by Newton steps on `phi`
//! itself), the real
//! part of every complex pair (a near-double real root perturbed into a
//! pair by rounding), both hard-case points of every pole, and the limits
//! `lambda = 0` (the unconstrained minimiser) and `lambda -> infinity`
//! (direction `D^{-1} beta`). Each candidate `y` is mapped to the feasible
//! direction `w = [y_p / ||y_p||, 1]` and scored by the exact `F(w)`, so the
//! answer is always feasible and at least as good as every candidate; the
//! apex (`F = 0`) is the fallback. Extra candidates can only help. The best
//! few (within 1e-3 of the best value) are refined by Newton
//! ascent of `log F` on the sphere of directions, unless already stationary:
//! near the hard case a root's value is good but its direction is not.
//!
//! Everything is on fixed-size matrices of the lifted dimension `M` (the
//! eigendecomposition by cyclic Jacobi sweeps, the polynomial on arrays), so
//! a solve allocates nothing.

use crate::estimators::prox::gtrs::ProxError;
use nalgebra::{Complex, SMatrix, SVector};

mod monotone;

/// Largest lifted dimension handled (the secular polynomial of degree
/// `2 (M - 1)` lives in arrays of this length).
const MAX_M: usize = 6;
const CAP: usize = 2 * MAX_M;

/// Cyclic Jacobi sweeps of the eigendecomposition before it gives up.
const JACOBI_SWEEPS: usize = 50;

/// Aberth-Ehrlich iterations before the roots are taken as they are.
const ABERTH_ITERATIONS: usize = 60;

/// Newton steps on `phi` from each root.
const POLISH_STEPS: usize = 8;

/// Seeds whose `F` is within this fraction of the best seed's are refined.
const REFINE_BAND: f64 = 1e-3;

/// At most this many distinct seeds are refined.
const MAX_REFINED: usize = 4;

/// Steps of [`Best::refine`] per seed.
const REFINE_STEPS: usize = 30;

/// The Riemannian gradient of `log F`, relative to its terms, below which a
/// direction is stationary to rounding.
const STATIONARY: f64 = 1e-13;

type Mat<const M: usize> = SMatrix<f64, M, M>;
type Vector<const M: usize> = SVector<f64, M>;

/// The global minimiser of `1/2 y^T A y - b^T y` over the upper nappe
/// `||y[0..M-1]|| = y[M-1] >= 0` (Mourya 2017 eq. 12-13 in shifted
/// coordinates `y = theta~ - r~_v`), for `3 <= M <= 6` (a 2-D to 5-D
/// position). `a` must be symmetric positive definite.
///
/// Errors: [`ProxError::NonFinite`] for non-finite input,
/// [`ProxError::Degenerate`] if `a` is not positive definite, `M` is out of
/// range or the decomposition fails.
pub fn min_quadratic_on_upper_nappe_n<const M: usize>(
    a: &Mat<M>,
    b: &Vector<M>,
) -> Result<Vector<M>, ProxError> {
    if !(3..=MAX_M).contains(&M) {
        return Err(ProxError::Degenerate(format!(
            "the nappe solver takes 3 <= M <= {MAX_M}, got {M}"
        )));
    }
    if !a.iter().chain(b.iter()).all(|x| x.is_finite()) {
        return Err(ProxError::NonFinite("GTRS quadratic data"));
    }
    // The minimiser is invariant under (A, b) -> (A, b) / alpha.
    let alpha = (0..M).map(|i| a[(i, i)]).fold(0.0, f64::max);
    if alpha.is_nan() || alpha <= 0.0 {
        return Err(ProxError::Degenerate(
            "A = H + I/gamma has a non-positive diagonal".into(),
        ));
    }
    let a = a / alpha;
    let b = b / alpha;
    if let Some(y) = monotone::upper_nappe_minimiser(&a, &b) {
        let mut w = direction(&y);
        w[M - 1] = 1.0;
        let (bw, aw) = (b.dot(&w), w.dot(&(a * w)));
        if bw > 0.0 && aw > 0.0 {
            return Ok(w * (bw / aw));
        }
    }
    enumerate_kkt_points(&a, &b)
}

/// The minimiser by the enumeration of every KKT point (see the module
/// docs), for `a` scaled to a largest diagonal entry of 1.
fn enumerate_kkt_points<const M: usize>(a: &Mat<M>, b: &Vector<M>) -> Result<Vector<M>, ProxError> {
    let not_pd = || ProxError::Degenerate("A = H + I/gamma is not positive definite".into());
    let chol = a.cholesky().ok_or_else(not_pd)?;
    let l_inv = chol
        .l()
        .solve_lower_triangular(&Mat::<M>::identity())
        .ok_or_else(not_pd)?;
    let mut s = Mat::<M>::identity();
    s[(M - 1, M - 1)] = -1.0;
    let (d, q) = jacobi_eigen(l_inv * s * l_inv.transpose()).ok_or_else(not_pd)?;
    // V = L^{-T} Q: y = V z.
    let v = l_inv.transpose() * q;
    let beta = v.transpose() * b;

    let mut best = Best::new(a, b);
    // lambda = 0 (the unconstrained minimiser) and lambda -> infinity.
    best.consider(&(v * beta));
    best.consider(&(v * beta.component_div(&d)));
    // Hard cases: a pole -1/d_i, z_i fixed by the constraint.
    for i in 0..M {
        let lambda = -1.0 / d[i];
        let mut z = Vector::<M>::zeros();
        let mut rest = 0.0;
        for j in 0..M {
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
                best.consider(&(v * z));
            }
        }
    }
    // Roots of the secular polynomial.
    let (roots, nr) = secular_roots(&d, &beta);
    for &lambda in &roots[..nr] {
        let lambda = polish(&d, &beta, lambda);
        let z = Vector::<M>::from_fn(|i, _| beta[i] / (1.0 + lambda * d[i]));
        if z.iter().all(|x| x.is_finite()) {
            best.consider(&(v * z));
        }
    }
    Ok(best.point())
}

/// Eigenvalues and eigenvectors (columns) of the symmetric `m` by cyclic
/// Jacobi rotations (accurate to rounding relative to `||m||`); `None` if
/// the sweeps do not converge.
fn jacobi_eigen<const M: usize>(mut m: Mat<M>) -> Option<(Vector<M>, Mat<M>)> {
    let mut v = Mat::<M>::identity();
    let norm = m.norm();
    if !(norm.is_finite() && norm > 0.0) {
        return None;
    }
    let off = |m: &Mat<M>| -> f64 {
        (0..M)
            .flat_map(|i| (0..M).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| m[(i, j)] * m[(i, j)])
            .sum::<f64>()
            .sqrt()
    };
    for _ in 0..JACOBI_SWEEPS {
        if off(&m) <= 2.0 * f64::EPSILON * norm {
            return Some((m.diagonal(), v));
        }
        for p in 0..M {
            for q in p + 1..M {
                let apq = m[(p, q)];
                if apq.abs() <= 1e-300 {
                    continue;
                }
                let theta = (m[(q, q)] - m[(p, p)]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..M {
                    let (mkp, mkq) = (m[(k, p)], m[(k, q)]);
                    m[(k, p)] = c * mkp - s * mkq;
                    m[(k, q)] = s * mkp + c * mkq;
                }
                for k in 0..M {
                    let (mpk, mqk) = (m[(p, k)], m[(q, k)]);
                    m[(p, k)] = c * mpk - s * mqk;
                    m[(q, k)] = s * mpk + c * mqk;
                }
                for k in 0..M {
                    let (vkp, vkq) = (v[(k, p)], v[(k, q)]);
                    v[(k, p)] = c * vkp - s * vkq;
                    v[(k, q)] = s * vkp + c * vkq;
                }
            }
        }
    }
    // Rounding can stall the last sweeps just above the threshold.
    (off(&m) <= 1e-12 * norm).then(|| (m.diagonal(), v))
}

/// The candidate directions with `F > 0` and, once refined, the best:
/// `F(w) = max(b^T w, 0)^2 / (w^T A w)`, `w = [e, 1]`. A direction `e` is
/// kept as an `M`-vector whose last entry is 0.
struct Best<'a, const M: usize> {
    a: &'a Mat<M>,
    b: &'a Vector<M>,
    seeds: [(f64, Vector<M>); CAP + 2 * MAX_M + 2],
    n: usize,
}

/// What [`Best::derivatives`] gives: an orthonormal basis `t` of the tangent
/// space in its first `M - 2` columns (then `e` and the last axis), the
/// Riemannian gradient `rg` and Hessian `rh` of `log F` in that basis (their
/// last two entries are 0 and `-I`), and the size of the gradient's terms.
struct Derivatives<const M: usize> {
    t: Mat<M>,
    rg: Vector<M>,
    rh: Mat<M>,
    scale: f64,
}

impl<'a, const M: usize> Best<'a, M> {
    fn new(a: &'a Mat<M>, b: &'a Vector<M>) -> Self {
        Best {
            a,
            b,
            seeds: [(0.0, Vector::<M>::zeros()); CAP + 2 * MAX_M + 2],
            n: 0,
        }
    }

    /// `b^T w` and `w^T A w` for `w = [e, 1]`.
    fn eval(&self, e: &Vector<M>) -> (Vector<M>, f64, f64) {
        let mut w = *e;
        w[M - 1] = 1.0;
        (w, self.b.dot(&w), w.dot(&(self.a * w)))
    }

    /// The value `F` at direction `e` (0 where `b^T w <= 0`).
    fn f(&self, e: &Vector<M>) -> f64 {
        let (_, bw, aw) = self.eval(e);
        if bw > 0.0 && aw > 0.0 {
            bw * bw / aw
        } else {
            0.0
        }
    }

    /// Take the feasible direction through `y`'s position part as a seed.
    fn consider(&mut self, y: &Vector<M>) {
        let e = direction(y);
        if !e.iter().all(|x| x.is_finite()) || self.n == self.seeds.len() {
            return;
        }
        let f = self.f(&e);
        if f > 0.0 {
            self.seeds[self.n] = (f, e);
            self.n += 1;
        }
    }

    fn derivatives(&self, e: &Vector<M>) -> Derivatives<M> {
        let (w, bw, aw) = self.eval(e);
        let mut bp = *self.b;
        bp[M - 1] = 0.0;
        let mut awp = self.a * w;
        awp[M - 1] = 0.0;
        // log F = 2 log(b^T w) - log(w^T A w), as a function of e.
        let g1 = bp * (2.0 / bw);
        let g2 = awp * (2.0 / aw);
        let scale = g1.norm() + g2.norm();
        let g = g1 - g2;
        let mut app = *self.a;
        for k in 0..M {
            app[(M - 1, k)] = 0.0;
            app[(k, M - 1)] = 0.0;
        }
        let h = -(bp * bp.transpose()) * (2.0 / (bw * bw)) - app * (2.0 / aw)
            + (awp * awp.transpose()) * (4.0 / (aw * aw));
        let t = tangent_basis(e);
        let mut rg = t.transpose() * g;
        let mut shift = Mat::<M>::identity() * e.dot(&g);
        shift[(M - 1, M - 1)] = 0.0;
        let mut rh = t.transpose() * (h - shift) * t;
        for k in M - 2..M {
            rg[k] = 0.0;
            for j in 0..M {
                rh[(k, j)] = 0.0;
                rh[(j, k)] = 0.0;
            }
            rh[(k, k)] = -1.0;
        }
        Derivatives { t, rg, rh, scale }
    }

    fn stationary(&self, d: &Derivatives<M>) -> bool {
        d.rg.norm() <= STATIONARY * d.scale
    }

    /// Newton ascent of `log F` on the sphere of directions from `e`. Near
    /// the maximum (a small Newton step with a negative definite Hessian)
    /// the step is taken if `F` does not fall beyond rounding: `F` is flat
    /// there, and the step moves the direction to the stationary point.
    /// Farther away a step is halved until `F` grows.
    fn refine(&self, mut e: Vector<M>) -> (f64, Vector<M>) {
        let mut f = self.f(&e);
        for _ in 0..REFINE_STEPS {
            if f <= 0.0 {
                break;
            }
            let d = self.derivatives(&e);
            if self.stationary(&d) {
                break;
            }
            let newton = (-d.rh).cholesky().map(|ch| ch.solve(&d.rg));
            if let Some(step) = &newton
                && step.norm() <= 1e-6
            {
                let cand = e + d.t * step;
                let cand = cand / cand.norm();
                let fc = self.f(&cand);
                if fc >= f * (1.0 - 8.0 * f64::EPSILON) {
                    (e, f) = (cand, fc.max(f));
                    continue;
                }
                break;
            }
            let step = newton.unwrap_or_else(|| d.rg / d.rh.norm().max(d.rg.norm()));
            let mut scale = 1.0;
            let mut moved = false;
            for _ in 0..24 {
                let cand = e + d.t * step * scale;
                let cand = cand / cand.norm();
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
    fn point(&mut self) -> Vector<M> {
        let seeds = &mut self.seeds[..self.n];
        seeds.sort_by(|x, y| y.0.total_cmp(&x.0));
        let Some(&(top, _)) = seeds.first() else {
            return Vector::<M>::zeros();
        };
        let mut best: Option<(f64, Vector<M>)> = None;
        let mut refined: [Vector<M>; MAX_REFINED] = [Vector::<M>::zeros(); MAX_REFINED];
        let mut nref = 0;
        for &(f, e) in self.seeds[..self.n].iter() {
            if f < top * (1.0 - REFINE_BAND) || nref == MAX_REFINED {
                break;
            }
            if refined[..nref].iter().any(|r| (r - e).norm() <= 1e-9) {
                continue;
            }
            refined[nref] = e;
            nref += 1;
            // A seed that is already stationary (a well-polished root) comes
            // back from its first step unmoved.
            let (f, e) = self.refine(e);
            if best.as_ref().is_none_or(|(fb, _)| f > *fb) {
                best = Some((f, e));
            }
        }
        match best {
            Some((_, e)) => {
                let (w, bw, aw) = self.eval(&e);
                w * (bw.max(0.0) / aw)
            }
            None => Vector::<M>::zeros(),
        }
    }
}

/// The unit direction `e` of `y`'s position part (last entry 0): the point
/// `rho [e, 1]` of the nappe through `y`. Not finite when the position part
/// is 0 or not finite.
fn direction<const M: usize>(y: &Vector<M>) -> Vector<M> {
    let mut e = *y;
    e[M - 1] = 0.0;
    let norm = e.norm();
    if norm > 0.0 && norm.is_finite() {
        e / norm
    } else {
        e * f64::NAN
    }
}

/// An orthonormal basis of the complement of the unit `e` (last entry 0)
/// within the position space, in the first `M - 2` columns (Gram-Schmidt on
/// the axes, the one closest to `e` left out), then `e` and the last axis.
fn tangent_basis<const M: usize>(e: &Vector<M>) -> Mat<M> {
    let mut t = Mat::<M>::zeros();
    let skip = e.rows(0, M - 1).iamax();
    for (col, k) in (0..M - 1).filter(|&k| k != skip).enumerate() {
        let mut v = Vector::<M>::zeros();
        v[k] = 1.0;
        v -= e * e[k];
        for j in 0..col {
            let c = t.column(j).into_owned();
            v -= c * c.dot(&v);
        }
        let norm = v.norm();
        t.set_column(col, &(v / norm));
    }
    t.set_column(M - 2, e);
    t[(M - 1, M - 1)] = 1.0;
    t
}

/// The roots of `p(lambda) = sum_i d_i beta_i^2 prod_{j != i} (1 + lambda
/// d_j)^2` as real numbers: the real roots and the real parts of the
/// complex pairs (leading coefficients negligible against the largest are
/// dropped: those roots went to infinity, the `lambda -> infinity`
/// candidate).
fn secular_roots<const M: usize>(d: &Vector<M>, beta: &Vector<M>) -> ([f64; CAP], usize) {
    // Coefficients, lowest degree first.
    let mut p = [0.0; CAP];
    for i in 0..M {
        let mut term = [0.0; CAP];
        term[0] = d[i] * beta[i] * beta[i];
        let mut deg = 0;
        for j in (0..M).filter(|&j| j != i) {
            // Multiply by (1 + lambda d_j)^2 = 1 + 2 d_j lambda + d_j^2 lambda^2.
            let f = [1.0, 2.0 * d[j], d[j] * d[j]];
            let mut next = [0.0; CAP];
            for (k, t) in term[..=deg].iter().enumerate() {
                for (l, g) in f.iter().enumerate() {
                    next[k + l] += t * g;
                }
            }
            term = next;
            deg += 2;
        }
        for k in 0..=deg {
            p[k] += term[k];
        }
    }
    let mut n = 2 * (M - 1);
    let scale = p[..=n].iter().fold(0.0, |m: f64, c| m.max(c.abs()));
    let mut out = [0.0; CAP];
    if !(scale.is_finite() && scale > 0.0) {
        return (out, 0);
    }
    while n > 0 && p[n].abs() <= 1e-14 * scale {
        n -= 1;
    }
    if n == 0 {
        return (out, 0);
    }
    let poles: [f64; MAX_M] = std::array::from_fn(|i| if i < M { -1.0 / d[i] } else { f64::NAN });
    let roots = aberth(&p[..=n], &poles[..M]);
    let mut k = 0;
    for z in &roots[..n] {
        if z.re.is_finite() {
            out[k] = z.re;
            k += 1;
        }
    }
    (out, k)
}

/// Every complex root of the real polynomial `p` (lowest degree first,
/// `p.len() - 1 <= CAP` its degree, leading coefficient non-zero) by the
/// Aberth-Ehrlich iteration, started near the given real points `near`
/// (the secular equation's poles, which its real roots surround), off the
/// real axis so that complex pairs can form; further starts go on a circle
/// of the Cauchy bound's radius.
fn aberth(p: &[f64], near: &[f64]) -> [Complex<f64>; CAP] {
    let n = p.len() - 1;
    let lead = p[n];
    let radius = 1.0 + p[..n].iter().fold(0.0, |m: f64, c| m.max((c / lead).abs()));
    let mut z = [Complex::new(0.0, 0.0); CAP];
    for (k, zk) in z[..n].iter_mut().enumerate() {
        *zk = match near
            .get(k / 2)
            .filter(|x| x.is_finite() && x.abs() < radius)
        {
            Some(&x) => {
                let side = if k % 2 == 0 { 1.0 } else { -1.0 };
                Complex::new(x * (1.0 + 0.05 * side), 0.07 * side * x.abs().max(1e-3))
            }
            None => {
                let angle = std::f64::consts::TAU * (k as f64 + 0.25) / n as f64 + 0.4;
                Complex::from_polar(radius, angle)
            }
        };
    }
    // p, p' and the size of p's terms at x (Horner on |x| and |c|): a root
    // is converged when |p| is at the rounding level of its terms.
    let eval = |x: Complex<f64>| {
        let (mut v, mut dv) = (Complex::new(0.0, 0.0), Complex::new(0.0, 0.0));
        let (ax, mut size) = (x.norm(), 0.0);
        for &c in p.iter().rev() {
            dv = dv * x + v;
            v = v * x + c;
            size = size * ax + c.abs();
        }
        (v, dv, size)
    };
    let mut converged = [false; CAP];
    for _ in 0..ABERTH_ITERATIONS {
        let mut done = true;
        for k in 0..n {
            if converged[k] {
                continue;
            }
            let (v, dv, size) = eval(z[k]);
            let tol = 8.0 * f64::EPSILON * size;
            if v.norm_sqr() <= tol * tol {
                converged[k] = true;
                continue;
            }
            done = false;
            let ratio = v / dv;
            let mut sum = Complex::new(0.0, 0.0);
            for j in (0..n).filter(|&j| j != k) {
                sum += (z[k] - z[j]).inv();
            }
            let w = ratio / (Complex::new(1.0, 0.0) - ratio * sum);
            if w.is_finite() {
                z[k] -= w;
            }
        }
        if done {
            break;
        }
    }
    z
}

/// Newton steps on `phi(lambda) = sum_i d_i beta_i^2 / (1 + lambda d_i)^2`
/// from `lambda`, keeping the iterate with the smallest `|phi|` relative to
/// its terms.
fn polish<const M: usize>(d: &Vector<M>, beta: &Vector<M>, lambda: f64) -> f64 {
    let eval = |l: f64| {
        let (mut phi, mut dphi, mut mag) = (0.0, 0.0, 0.0);
        for i in 0..M {
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
