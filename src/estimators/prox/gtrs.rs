//! Proximal operators of the local cost (Mourya 2017 eq. 11 and eq. 13), in 2-D
//! and 3-D.
//!
//! For node `v` with lifted variable `theta~ = [theta, d]`, local cost
//! `f_v(theta~) = 1/2 ||B_v theta~ - g_v||^2` (Mourya 2017 eq. 9-10), step `gamma > 0`
//! and input `u`:
//!
//! * [`prox_relaxed`] solves eq. (11) without the quadratic relation (12): the
//!   `L x L` SPD system `(H + I/gamma) theta~ = c + u/gamma` with `H = B^T B`,
//!   `c = B^T g` (`L = 3` in 2-D, 4 in 3-D);
//! * [`prox_gtrs`] solves the GTRS (13) exactly, on the upper nappe of the cone (12):
//!   `||theta~[0:D] - r_v|| = theta~[D]`, `theta~[D] >= 0`. It returns the **global**
//!   minimiser over that set: in 2-D by the one-angle method below
//!   ([`min_quadratic_on_upper_nappe`]), in 3-D by the secular equation of
//!   [`crate::estimators::prox::nappe`] (whose docs show why it keeps its form).
//!
//! # Method of [`prox_gtrs`] in 2-D
//!
//! Shift `y = theta~ - r~_v` (`r~_v = [r_v, 0]`, eq. 12). Up to a constant the
//! objective of (13) is `q(y) = 1/2 y^T A y - b^T y` with `A = H + I/gamma` (positive
//! definite) and `b = c + u/gamma - A r~_v`. Every point of the upper nappe is
//! `y = rho w(phi)`, `w(phi) = [cos phi, sin phi, 1]`, `rho >= 0` (`rho = 0` is the apex).
//! For fixed `phi`, `q` is a convex parabola in `rho` with minimiser
//! `rho = max(b(phi), 0) / a(phi)`, where `a(phi) = w^T A w > 0` and `b(phi) = b^T w`, so
//!
//! `min_{upper nappe} q = -1/2 max_phi F(phi)`, `F(phi) = max(b(phi), 0)^2 / a(phi)`,
//!
//! an exact reduction to one angle. `a` is a trigonometric polynomial of degree 2 and `b`
//! of degree 1; where `b > 0`, `F' = b P / a^2` with `P = 2 b' a - b a'`, whose degree-3
//! harmonics cancel, so `P` is a trigonometric polynomial of degree 2. The global
//! maximiser of `F` is therefore either a real root of `P` or, if `F = 0` everywhere
//! (`-b` in the cone), the apex `y = 0`. The real roots of `P` (at most 4) are exactly the
//! KKT points of the equality-constrained problem (13) away from the apex, on either
//! nappe: the same points as the roots of the quartic secular equation of Beck, Stoica
//! and Li 2008 (Mourya 2017 ref. 6) / Moré 1993, but with no poles and no "hard case",
//! which is an artefact of the multiplier parametrisation, not of the angle `phi`.
//!
//! The substitution `t = tan((phi - phi0)/2)` turns `P = 0` into a quartic in `t`; the
//! rotation `phi0` is chosen so that the leading coefficient `P(phi0 + pi)` is the largest
//! of five equispaced samples of `P`; by discrete Parseval `|P(phi0 + pi)| >= ||p|| / sqrt 2`
//! for the coefficient vector `p`, so Cauchy's bound keeps every root at `|t| < 10`. The quartic is
//! solved in closed form (Ferrari); the real part of a complex pair with a small imaginary
//! part is a seed too, so a near-double real root perturbed into a complex pair is not
//! dropped. Only seeds that can be maxima of `F` are polished (guarded Newton steps) and
//! evaluated: a simple root where `P` crosses from negative to positive is a minimum of
//! `F`, and a clearly complex pair has no real root near it (see `polish_maximum_seed`).
//! All candidates (plus the five samples and the apex) are compared by the exact value of
//! `F`, so the result is always feasible and at least as good as every candidate. If `P` vanishes to rounding (`F` constant to ~1e-14, e.g. an
//! empty problem with `u` on the cone axis) the samples alone are used: the objective is
//! then optimal to that precision although the optimal position is not unique.
//!
//! `A` and `b` are divided by the power of two just below the largest diagonal entry of
//! `A` (the minimiser is invariant), so the paper's scale (`H ~ 1e7`, `1/gamma = 5e7`) and
//! TOA-network scale (coordinates ~1) are handled alike. Cost: ~0.18 us, 4.7x the relaxed
//! prox (see `benches/prox.rs`). The code is written for latency: the candidate angles
//! are kept as unnormalised directions (no division by `1 + t^2`), the five samples are
//! evaluated without data-dependent branches, and the cube root of the resolvent cubic
//! is computed without the FMA-dispatching library routine.

use crate::estimators::local::LocalProblem;
use crate::estimators::prox::nappe::min_quadratic_on_upper_nappe_n;
use crate::model::geometry::{LMat, Lifted, Mat3, Vec3, lift};

/// Why a prox could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProxError {
    /// `gamma` must be finite and positive.
    #[error("gamma must be finite and > 0, got {0}")]
    BadGamma(f64),
    /// An input (measurement row, `u`) was NaN or infinite.
    #[error("non-finite input: {0}")]
    NonFinite(&'static str),
    /// The problem is numerically degenerate.
    #[error("degenerate local problem: {0}")]
    Degenerate(String),
}

impl ProxError {
    /// The kind of this failure: what crosses the wire from a node process.
    pub fn kind(&self) -> ProxFailure {
        match self {
            ProxError::BadGamma(_) => ProxFailure::BadGamma,
            ProxError::NonFinite(_) => ProxFailure::NonFinite,
            ProxError::Degenerate(_) => ProxFailure::Degenerate,
        }
    }
}

/// The kind of a [`ProxError`], without its details: a node process reports
/// this code in its `FAILED` frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProxFailure {
    /// [`ProxError::BadGamma`].
    BadGamma,
    /// [`ProxError::NonFinite`].
    NonFinite,
    /// [`ProxError::Degenerate`].
    Degenerate,
}

impl ProxFailure {
    /// Every kind, in code order.
    pub const ALL: [ProxFailure; 3] = [
        ProxFailure::BadGamma,
        ProxFailure::NonFinite,
        ProxFailure::Degenerate,
    ];

    /// Its code in a frame (1, 2, 3).
    pub fn code(self) -> u32 {
        match self {
            ProxFailure::BadGamma => 1,
            ProxFailure::NonFinite => 2,
            ProxFailure::Degenerate => 3,
        }
    }

    /// The kind of code `code`; an unknown code is a degenerate problem.
    pub fn from_code(code: u32) -> ProxFailure {
        match code {
            1 => ProxFailure::BadGamma,
            2 => ProxFailure::NonFinite,
            _ => ProxFailure::Degenerate,
        }
    }

    /// What the coordinator says of it when only the kind arrived.
    pub fn text(self) -> &'static str {
        match self {
            ProxFailure::BadGamma => "prox failed: bad gamma",
            ProxFailure::NonFinite => "prox failed: non-finite input",
            ProxFailure::Degenerate => "prox failed: degenerate local problem",
        }
    }
}

/// Check `gamma`, `u` and the local problem data (`H`, `c`, anchor) for the prox of
/// Mourya 2017 eq. (11)/(13). Non-finite rows or `g` show up as non-finite `H` or `c`.
/// The one input check of every prox; [`crate::estimators::prox::l0`] adds its per-row check.
pub(crate) fn validate<const D: usize, const L: usize>(
    p: &LocalProblem<D, L>,
    u: &Lifted<L>,
    gamma: f64,
) -> Result<(), ProxError> {
    if !(gamma.is_finite() && gamma > 0.0) {
        return Err(ProxError::BadGamma(gamma));
    }
    if !all_finite(u.iter()) {
        return Err(ProxError::NonFinite("prox input u"));
    }
    if !all_finite(p.h.iter().chain(p.c.iter())) {
        return Err(ProxError::NonFinite(
            "local problem rows B_v or g_v (H = B^T B or c = B^T g)",
        ));
    }
    if !all_finite(p.anchor.iter()) {
        return Err(ProxError::NonFinite("receiver position r_v"));
    }
    Ok(())
}

/// True if every value is finite (branch-free: `x * 0` is NaN exactly for NaN/inf `x`).
#[inline(always)]
fn all_finite<'a>(xs: impl Iterator<Item = &'a f64>) -> bool {
    xs.fold(0.0, |acc, x| acc + x * 0.0).is_finite()
}

/// The relaxed prox: `argmin_theta f_v(theta) + 1/(2 gamma) ||theta - u||^2` with no
/// constraint (Mourya 2017 eq. 11 without eq. 12), i.e. the solution of the SPD system
/// `(H + I/gamma) theta = c + u/gamma`, in 2-D or 3-D.
///
/// Errors: [`ProxError::BadGamma`] if `gamma` is not finite and positive,
/// [`ProxError::NonFinite`] for NaN/infinite `u` or problem data,
/// [`ProxError::Degenerate`] if the system is not numerically positive definite or the
/// solution overflows.
pub fn prox_relaxed<const D: usize, const L: usize>(
    p: &LocalProblem<D, L>,
    u: &Lifted<L>,
    gamma: f64,
) -> Result<Lifted<L>, ProxError> {
    validate(p, u, gamma)?;
    let inv_g = 1.0 / gamma;
    let a = p.h + LMat::<L>::identity() * inv_g;
    let b = p.c + u * inv_g;
    let x = a
        .cholesky()
        .map(|ch| ch.solve(&b))
        .ok_or_else(|| ProxError::Degenerate("H + I/gamma not positive definite".into()))?;
    if x.iter().all(|v| v.is_finite()) {
        Ok(x)
    } else {
        Err(ProxError::Degenerate("relaxed prox overflowed".into()))
    }
}

/// The exact GTRS prox of Mourya 2017 eq. (13): the **global** minimiser of
/// `f_v(theta~) + 1/(2 gamma) ||theta~ - u||^2` over the upper nappe of the cone (12),
/// `||theta~[0:D] - r_v|| = theta~[D] >= 0` (apex `[r_v, 0]` included), in 2-D or 3-D.
///
/// See the module documentation for the method (in 2-D an exact reduction to one angle
/// and a quartic; in 3-D the secular equation of
/// [`crate::estimators::prox::nappe`]). The returned point satisfies the constraint to
/// rounding: its `d` is recomputed as `||theta~[0:D] - r_v||`. An empty problem (no
/// rows) is valid and gives the Euclidean projection of `u` onto the upper nappe.
///
/// Errors: as [`prox_relaxed`].
pub fn prox_gtrs<const D: usize, const L: usize>(
    p: &LocalProblem<D, L>,
    u: &Lifted<L>,
    gamma: f64,
) -> Result<Lifted<L>, ProxError> {
    validate(p, u, gamma)?;
    let inv_g = 1.0 / gamma;
    let r: Lifted<L> = lift(&p.anchor, 0.0);
    let a = p.h + LMat::<L>::identity() * inv_g;
    // b = c + u/gamma - A r~ = (c - H r~) + (u - r~)/gamma, less cancellation.
    let b = (p.c - p.h * r) + (u - r) * inv_g;
    let y = min_on_upper_nappe(&a, &b)?;
    let mut theta = Lifted::<L>::zeros();
    let mut d_sq = 0.0;
    for i in 0..D {
        theta[i] = p.anchor[i] + y[i];
        let di = theta[i] - p.anchor[i];
        d_sq += di * di;
    }
    theta[D] = d_sq.sqrt();
    if theta.iter().all(|v| v.is_finite()) {
        Ok(theta)
    } else {
        Err(ProxError::Degenerate("GTRS prox overflowed".into()))
    }
}

/// The global minimiser of `1/2 y^T A y - b^T y` on the upper nappe in `L`
/// dimensions: [`min_quadratic_on_upper_nappe`] (one angle) for a 2-D
/// position (`L = 3`), [`min_quadratic_on_upper_nappe_n`] otherwise.
fn min_on_upper_nappe<const L: usize>(a: &LMat<L>, b: &Lifted<L>) -> Result<Lifted<L>, ProxError> {
    if L == 3 {
        let a3 = Mat3::from_fn(|i, j| a[(i, j)]);
        let b3 = Vec3::from_fn(|i, _| b[i]);
        let y = min_quadratic_on_upper_nappe(&a3, &b3)?;
        Ok(Lifted::<L>::from_fn(|i, _| y[i]))
    } else {
        min_quadratic_on_upper_nappe_n::<L>(a, b)
    }
}

/// `cos`, `sin` of the five sample angles `(2k + 1) pi / 5`, `k = 0..5`.
const SAMPLES: [(f64, f64); 5] = [
    (0.809_016_994_374_947_5, 0.587_785_252_292_473_1),
    (-0.309_016_994_374_947_5, 0.951_056_516_295_153_5),
    (-1.0, 0.0),
    (-0.309_016_994_374_947_5, -0.951_056_516_295_153_5),
    (0.809_016_994_374_947_5, -0.587_785_252_292_473_1),
];

/// The global minimiser of `q(y) = 1/2 y^T A y - b^T y` over the upper nappe
/// `{y : y_0^2 + y_1^2 = y_2^2, y_2 >= 0}` of the cone of Mourya 2017 eq. (12) (in shifted
/// coordinates `y = theta~ - r~_v`). This is the core of [`prox_gtrs`] (eq. 13).
///
/// `a` must be symmetric positive definite (only its upper triangle is read).
///
/// Errors: [`ProxError::NonFinite`] for non-finite input, [`ProxError::Degenerate`] if
/// `a` is not positive definite along the nappe.
pub fn min_quadratic_on_upper_nappe(a: &Mat3, b: &Vec3) -> Result<Vec3, ProxError> {
    if !all_finite(a.iter().chain(b.iter())) {
        return Err(ProxError::NonFinite("GTRS quadratic data"));
    }
    // Normalise: the minimiser is invariant under (A, b) -> (A, b) / alpha. Scaling by
    // the power of two nearest below alpha is exact and needs no division; the largest
    // diagonal entry then lies in [1, 2). (P and F below are homogeneous in b, so b
    // needs no further normalisation.)
    let alpha = a[(0, 0)].max(a[(1, 1)]).max(a[(2, 2)]);
    if alpha.is_nan() || alpha <= 0.0 {
        return Err(ProxError::Degenerate(
            "A = H + I/gamma has a non-positive diagonal".into(),
        ));
    }
    let ia = pow2_recip(alpha).unwrap_or(1.0 / alpha);
    let q = Quad {
        a00: a[(0, 0)] * ia,
        a11: a[(1, 1)] * ia,
        a22: a[(2, 2)] * ia,
        a01: a[(0, 1)] * ia,
        a02: a[(0, 2)] * ia,
        a12: a[(1, 2)] * ia,
    };
    let (b0, b1, b2) = (b[0] * ia, b[1] * ia, b[2] * ia);

    // Best candidate so far: the apex, F = 0.
    let mut best = Best {
        num: 0.0,
        den: 1.0,
        bw: 0.0,
        c: 1.0,
        s: 0.0,
        h: 1.0,
        bad: false,
    };

    let [p0, p1, q1, p2, q2] = secular_trig(&q, b0, b1, b2);
    let pscale =
        (q.a00.abs() + q.a11.abs() + q.a22.abs() + q.a01.abs() + q.a02.abs() + q.a12.abs())
            * (b0.abs() + b1.abs() + b2.abs());

    // Sample P (and F) at the five angles (2k+1) pi / 5.
    let mut kmax = 0;
    let mut pmax = -1.0;
    for (k, &(c, s)) in SAMPLES.iter().enumerate() {
        best.consider_branchless(&q, b0, b1, b2, c, s);
        let pv = (p0 + p1 * c + q1 * s + p2 * (c * c - s * s) + q2 * (2.0 * c * s)).abs();
        if pv > pmax {
            pmax = pv;
            kmax = k;
        }
    }

    if pmax > 1e-14 * pscale {
        // Rotate: phi = psi + phi0 with phi0 + pi = sample kmax, so that the leading
        // coefficient of the quartic, P(phi0 + pi), is the largest sample.
        let (ck, sk) = SAMPLES[kmax];
        let (c0, s0) = (-ck, -sk);
        let (c20, s20) = (ck * ck - sk * sk, 2.0 * ck * sk);
        let rp1 = p1 * c0 + q1 * s0;
        let rq1 = q1 * c0 - p1 * s0;
        let rp2 = p2 * c20 + q2 * s20;
        let rq2 = q2 * c20 - p2 * s20;
        // (1 + t^2)^2 P(psi + phi0), t = tan(psi / 2).
        let e = [
            p0 + rp1 + rp2,
            2.0 * rq1 + 4.0 * rq2,
            2.0 * p0 - 6.0 * rp2,
            2.0 * rq1 - 4.0 * rq2,
            p0 - rp1 + rp2,
        ];
        let (seeds, ns) = quartic_seeds(&e);
        for seed in &seeds[..ns] {
            // Only a down-crossing of P (Q' < 0) can be a maximum of F; a seed next to
            // a simple root with Q' > 0 (a minimum of F) and the real part of a clearly
            // complex pair (no real root near it) are skipped. See `Seed`.
            let Some(t) = polish_maximum_seed(&e, seed) else {
                continue;
            };
            // (1 + t^2) (cos psi, sin psi) = (1 - t^2, 2t), rotated by phi0; F is
            // invariant under scaling w, so no division by 1 + t^2 is needed.
            let (cp, sp) = (1.0 - t * t, 2.0 * t);
            let c = cp * c0 - sp * s0;
            let s = sp * c0 + cp * s0;
            best.consider(&q, b0, b1, b2, c, s, 1.0 + t * t);
        }
    }
    if best.bad {
        return Err(ProxError::Degenerate(
            "A = H + I/gamma is not positive definite on the cone".into(),
        ));
    }
    // y = rho w with rho = b(w) / a(w) for the best (possibly scaled) w (0 at the apex).
    let rho = best.bw / best.den;
    Ok(Vec3::new(rho * best.c, rho * best.s, rho * best.h))
}

/// `1 / 2^floor(log2 x)` for a normal positive `x` whose reciprocal power of two is
/// normal too (exact, no division); `None` otherwise.
#[inline(always)]
fn pow2_recip(x: f64) -> Option<f64> {
    let biased = (x.to_bits() >> 52) & 0x7ff;
    // x = m 2^(biased - 1023) with m in [1, 2); 1/2^(biased - 1023) has biased exponent
    // 2046 - biased, which must lie in 1..=2046.
    if x > 0.0 && (1..2046).contains(&biased) {
        Some(f64::from_bits((2046 - biased) << 52))
    } else {
        None
    }
}

/// Coefficients `[p0, p1, q1, p2, q2]` of the degree-2 trigonometric polynomial
/// `P(phi) = p0 + p1 cos phi + q1 sin phi + p2 cos 2phi + q2 sin 2phi = 2 b'(phi) a(phi) -
/// b(phi) a'(phi)`, with `a(phi) = w^T A w`, `b(phi) = b^T w`, `w = [cos phi, sin phi, 1]`.
/// Where `b(phi) > 0`, `F'(phi) = b P / a^2` for `F = b^2 / a` (see module docs).
#[inline(always)]
fn secular_trig(q: &Quad, b0: f64, b1: f64, b2: f64) -> [f64; 5] {
    // a(phi) = a0 + a1c cos + a1s sin + a2c cos 2phi + a2s sin 2phi.
    let a0 = 0.5 * (q.a00 + q.a11) + q.a22;
    let a1c = 2.0 * q.a02;
    let a1s = 2.0 * q.a12;
    let a2c = 0.5 * (q.a00 - q.a11);
    let a2s = q.a01;
    // Product-to-sum of 2 b' a - b a'; the degree-3 harmonics cancel exactly.
    [
        1.5 * (b1 * a1c - b0 * a1s),
        2.0 * b1 * (a0 + a2c) - 2.0 * b0 * a2s - b2 * a1s,
        -2.0 * b0 * (a0 - a2c) + 2.0 * b1 * a2s + b2 * a1c,
        0.5 * (b1 * a1c + b0 * a1s) - 2.0 * b2 * a2s,
        0.5 * (b1 * a1s - b0 * a1c) + 2.0 * b2 * a2c,
    ]
}

/// Scaled symmetric `A` (upper triangle).
struct Quad {
    a00: f64,
    a11: f64,
    a22: f64,
    a01: f64,
    a02: f64,
    a12: f64,
}

impl Quad {
    /// `a(w) = w^T A w` at the direction `w = (c, s, h)`.
    #[inline(always)]
    fn a_of(&self, c: f64, s: f64, h: f64) -> f64 {
        self.a00 * c * c
            + self.a11 * s * s
            + 2.0 * (self.a01 * c * s + (self.a02 * c + self.a12 * s) * h)
            + self.a22 * h * h
    }
}

/// `b(w) = b^T w` at the direction `w = (c, s, h)`.
#[inline(always)]
fn b_of(b0: f64, b1: f64, b2: f64, c: f64, s: f64, h: f64) -> f64 {
    b2 * h + b0 * c + b1 * s
}

/// Best angle so far for the reduced problem `max_phi F(phi)`, `F = b(phi)^2 / a(phi)`
/// kept as the fraction `num / den` (no division in the comparisons). The angle is kept
/// as a direction `w = (c, s, h)` on the cone, `c^2 + s^2 = h^2`, `h > 0`, not
/// necessarily scaled to `h = 1`: `F = b(w)^2 / a(w)` does not depend on the scale.
struct Best {
    num: f64,
    den: f64,
    /// `b(w)` of the best direction.
    bw: f64,
    c: f64,
    s: f64,
    h: f64,
    /// Set if `a(phi) <= 0` was met (`A` not positive definite).
    bad: bool,
}

impl Best {
    /// [`Best::consider`] at `w = (c, s, 1)` without data-dependent branches (selects
    /// only), for the five fixed samples, whose signs of `b(phi)` are unpredictable: a mispredicted branch
    /// per sample cost about as much as the rest of the sampling.
    #[inline(always)]
    fn consider_branchless(&mut self, q: &Quad, b0: f64, b1: f64, b2: f64, c: f64, s: f64) {
        let bw = b_of(b0, b1, b2, c, s, 1.0);
        let aw = q.a_of(c, s, 1.0);
        let positive = bw > 0.0;
        self.bad |= positive & (aw <= 0.0);
        let num = if positive { bw * bw } else { 0.0 };
        // With num = 0 this is never true for a valid best (num >= 0, den > 0).
        let better = positive & (num * self.den > self.num * aw);
        self.num = if better { num } else { self.num };
        self.den = if better { aw } else { self.den };
        self.bw = if better { bw } else { self.bw };
        self.c = if better { c } else { self.c };
        self.s = if better { s } else { self.s };
        self.h = if better { 1.0 } else { self.h };
    }

    /// Evaluate `F` at the direction `w = (c, s, h)` (`c^2 + s^2 = h^2`, `h > 0`) and
    /// keep it if it is better.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn consider(&mut self, q: &Quad, b0: f64, b1: f64, b2: f64, c: f64, s: f64, h: f64) {
        let bw = b_of(b0, b1, b2, c, s, h);
        if bw > 0.0 {
            let aw = q.a_of(c, s, h);
            if aw > 0.0 {
                if bw * bw * self.den > self.num * aw {
                    self.num = bw * bw;
                    self.den = aw;
                    self.bw = bw;
                    self.c = c;
                    self.s = s;
                    self.h = h;
                }
            } else {
                self.bad = true;
            }
        }
    }
}

/// `Q(t)` and `Q'(t)` for `Q(t) = sum e[i] t^i` (degree 4), by Horner.
#[inline(always)]
fn horner4(e: &[f64; 5], t: f64) -> (f64, f64) {
    let mut v = e[4];
    let mut d = 0.0;
    for i in (0..4).rev() {
        d = d * t + v;
        v = v * t + e[i];
    }
    (v, d)
}

/// Relative imaginary part `|Im| / (1 + |Re|)` above which a complex pair of the quartic
/// is taken to be genuinely complex (no real root nearby) and its real part is not
/// polished. Rounding perturbs a double real root into a pair with a relative
/// imaginary part of order `sqrt(eps) ~ 1e-8`; such pairs stay seeds.
const COMPLEX_PAIR_SKIP: f64 = 1e-4;

/// Relative Newton step `|Q / Q'| / (1 + |t|)` below which a seed is taken to sit next
/// to a simple root, so that the sign of `Q'` there is the sign at the root.
const NEAR_SIMPLE_ROOT: f64 = 1e-3;

/// The polished root for a quartic seed that may be a maximum of `F`, or `None` if it
/// cannot be one:
///
/// * the real part of a genuinely complex pair (relative imaginary part above
///   [`COMPLEX_PAIR_SKIP`]) has no real root of `Q` nearby;
/// * at a simple root with `Q' > 0`, `P` crosses from negative to positive, so `F`
///   (whose derivative has the sign of `P` where `b > 0`) has a minimum there. `Q' =
///   (1 + t^2) * 2 P'(phi)` at a root, since `dphi/dt = 2 / (1 + t^2) > 0`.
///
/// Skipping these never loses the global maximum, which is a root of `P` at which `P`
/// goes from positive to negative. The sign test is unreliable only for a near-double
/// root pair `r1 < r2` (a maximum of `F` next to a minimum); such a pair is never the
/// global maximum up to `F(r1) - F(r2)`, which is of third order in `r2 - r1`: past
/// `r2`, `F` rises again until the next down-crossing, because `F` returns to its
/// value at the start of the circle (or to 0 where `b(phi)` turns negative). All other
/// seeds are polished by [`newton_polish`].
#[inline]
fn polish_maximum_seed(e: &[f64; 5], seed: &Seed) -> Option<f64> {
    let t0 = seed.re;
    if seed.im > COMPLEX_PAIR_SKIP * (1.0 + t0.abs()) {
        return None;
    }
    let (v, d) = horner4(e, t0);
    if seed.im == 0.0 && d > 0.0 && v.abs() <= NEAR_SIMPLE_ROOT * d * (1.0 + t0.abs()) {
        return None;
    }
    Some(newton_polish_from(e, t0, v, d))
}

/// Guarded Newton polishing of a root of the quartic `e`: a step is taken only if it
/// decreases `|Q|` (or is already tiny), so the result is never worse than the seed.
#[cfg(test)]
fn newton_polish(e: &[f64; 5], t0: f64) -> f64 {
    let (v, d) = horner4(e, t0);
    newton_polish_from(e, t0, v, d)
}

/// [`newton_polish`] given `(Q, Q')` at the seed.
#[inline]
fn newton_polish_from(e: &[f64; 5], t0: f64, v0: f64, d0: f64) -> f64 {
    let mut t = t0;
    let (mut v, mut d) = (v0, d0);
    for _ in 0..8 {
        let step = v / d;
        if !step.is_finite() {
            break;
        }
        let tn = t - step;
        if step.abs() <= 1e-9 * (1.0 + t.abs()) {
            // Quadratic convergence: this step lands at machine precision.
            return tn;
        }
        let (vn, dn) = horner4(e, tn);
        if vn.is_nan() || vn.abs() >= v.abs() {
            break;
        }
        t = tn;
        v = vn;
        d = dn;
    }
    t
}

/// A seed for a real root of the quartic: a real root (`im == 0`) or the real part of a
/// complex pair with imaginary part `im > 0`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Seed {
    pub(crate) re: f64,
    pub(crate) im: f64,
}

/// Seeds for the real roots of the quartic `sum e[i] t^i` (`e[4] != 0`) by Ferrari's
/// method: the real roots, and the real part of each complex pair (so that a near-double
/// real root perturbed into a complex pair still yields a seed). Returns the seeds and
/// their number (2 to 4).
pub(crate) fn quartic_seeds(e: &[f64; 5]) -> ([Seed; 4], usize) {
    let inv = 1.0 / e[4];
    let a = e[3] * inv;
    let b = e[2] * inv;
    let c = e[1] * inv;
    let d = e[0] * inv;
    // Depressed quartic x^4 + p x^2 + q x + r, t = x - a/4.
    let a2 = a * a;
    let p = b - 0.375 * a2;
    let q = c - 0.5 * a * b + 0.125 * a2 * a;
    let r = d - 0.25 * a * c + 0.0625 * a2 * b - 0.011_718_75 * a2 * a2;
    // Resolvent: m^3 + p m^2 + (p^2/4 - r) m - q^2/8 = 0, largest root m >= 0.
    let m = cubic_largest_root(p, 0.25 * p * p - r, -0.125 * q * q).max(0.0);
    let s = (2.0 * m).sqrt();
    let k = if m > 1e-6 * (p.abs() + r.abs().sqrt()) {
        // q / (2s) = q s / (4m): the division runs alongside the square root.
        q * s * (0.25 / m)
    } else {
        let ksq = (m + 0.5 * p) * (m + 0.5 * p) - r;
        ksq.max(0.0).sqrt().copysign(q)
    };
    let sh = 0.25 * a;
    let mut out = [Seed::default(); 4];
    let n1 = quadratic_seeds(-s, 0.5 * p + m + k, sh, &mut out, 0);
    let n2 = quadratic_seeds(s, 0.5 * p + m - k, sh, &mut out, n1);
    (out, n2)
}

/// Write the roots of `x^2 + bb x + cc` minus `sh` (numerically stable form), or the real
/// part of a complex pair, into `out[at..]`; returns the new count.
#[inline(always)]
fn quadratic_seeds(bb: f64, cc: f64, sh: f64, out: &mut [Seed; 4], at: usize) -> usize {
    let h = -0.5 * bb;
    let disc = h * h - cc;
    if disc >= 0.0 {
        let x1 = h + disc.sqrt().copysign(h);
        out[at] = Seed {
            re: x1 - sh,
            im: 0.0,
        };
        out[at + 1] = Seed {
            re: if x1.abs() > 0.0 { cc / x1 - sh } else { -sh },
            im: 0.0,
        };
        at + 2
    } else {
        out[at] = Seed {
            re: h - sh,
            im: (-disc).sqrt(),
        };
        at + 1
    }
}

/// `x^(1/3)` for `x >= 0` to `1e-14` relative: the exponent-thirding bit trick (a few
/// per cent off) and two Halley steps `y (y^3 + 2x) / (2y^3 + x)`, each of which cubes
/// the relative error. Faster than `f64::cbrt` (no FMA dispatch), which matters inside
/// the GTRS prox, where the result only seeds root polishing; zero, subnormal, infinite
/// and NaN inputs go to `f64::cbrt`.
#[inline]
fn cbrt_nonneg(x: f64) -> f64 {
    if !x.is_normal() || x < 0.0 {
        return x.cbrt();
    }
    let mut y = f64::from_bits(x.to_bits() / 3 + 0x2A9F_7893_782D_A1CE);
    for _ in 0..2 {
        let y3 = y * y * y;
        y *= (y3 + 2.0 * x) / (2.0 * y3 + x);
    }
    y
}

/// The largest real root of the monic cubic `m^3 + a m^2 + b m + c` (closed form, then
/// one guarded Newton step where the closed form may have lost accuracy).
///
/// The Newton step is taken in the three-real-root case, for a near-double root, and
/// when the single real root `big + small - a/3` cancels (its magnitude is below
/// [`CUBIC_CANCELLATION`] times that of its terms). Otherwise the closed form is already
/// accurate to `~1e-13` relative, which is plenty: the quartic seeds built from it are
/// polished by Newton steps on the quartic itself. (Skipping the step there saves about
/// a tenth of the GTRS prox time.)
fn cubic_largest_root(a: f64, b: f64, c: f64) -> f64 {
    const THIRD: f64 = 1.0 / 3.0;
    let a3 = a * THIRD;
    let qq = a3 * a3 - b * THIRD;
    let rr = a3 * a3 * a3 - 0.5 * (a3 * b - c);
    let q3 = qq * qq * qq;
    let (mut m, refine) = if rr * rr < q3 {
        // Three real roots; the largest is -2 sqrt(Q) cos((theta + 2 pi)/3) - a/3.
        let th = (rr / q3.sqrt()).clamp(-1.0, 1.0).acos();
        (
            -2.0 * qq.sqrt() * ((th + 2.0 * std::f64::consts::PI) / 3.0).cos() - a3,
            true,
        )
    } else {
        let big = -cbrt_nonneg(rr.abs() + (rr * rr - q3).sqrt()).copysign(rr);
        let small = if big.abs() > 0.0 { qq / big } else { 0.0 };
        let real = big + small - a3;
        // A complex pair with a tiny imaginary part is a perturbed double root, which
        // may be the largest real root.
        let pair_re = -0.5 * (big + small) - a3;
        let pair_im = 0.866_025_403_784_438_6 * (big - small).abs();
        if pair_im <= 1e-6 * (big.abs() + small.abs()) {
            (real.max(pair_re), true)
        } else {
            let terms = big.abs() + small.abs() + a3.abs();
            (real, real.abs() < CUBIC_CANCELLATION * terms)
        }
    };
    if refine {
        let f = ((m + a) * m + b) * m + c;
        let df = (3.0 * m + 2.0 * a) * m + b;
        let mn = m - f / df;
        let fnew = ((mn + a) * mn + b) * mn + c;
        if fnew.abs() < f.abs() {
            m = mn;
        }
    }
    m
}

/// See [`cubic_largest_root`]: below this ratio of `|root|` to the sum of the magnitudes
/// of its closed-form terms, the root is refined by a Newton step.
const CUBIC_CANCELLATION: f64 = 1e-3;

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::model::geometry::Vec2;
    use crate::model::measure::NodeMeasurements;
    use proptest::prelude::*;

    // ---------------------------------------------------------------- helpers

    /// The prox objective from the rows (no allocation; same value as
    /// `LocalProblem::prox_objective`).
    fn objective(p: &LocalProblem, th: &Vec3, u: &Vec3, gamma: f64) -> f64 {
        let mut s = 0.0;
        for (row, g) in p.rows.iter().zip(&p.g) {
            let e = row[0] * th[0] + row[1] * th[1] + row[2] * th[2] - g;
            s += e * e;
        }
        0.5 * s + (th - u).norm_squared() / (2.0 * gamma)
    }

    /// The point of the upper nappe above position `(x, y)`.
    fn lift(p: &LocalProblem, x: f64, y: f64) -> Vec3 {
        Vec3::new(x, y, (x - p.anchor.x).hypot(y - p.anchor.y))
    }

    /// Plain 2-D Nelder-Mead (reflection 1, expansion 2, contraction 1/2, shrink 1/2).
    fn nelder_mead(f: &dyn Fn(f64, f64) -> f64, x0: [f64; 2], step: f64) -> ([f64; 2], f64) {
        let mut best = (x0, f(x0[0], x0[1]));
        let mut step = step;
        for _restart in 0..3 {
            let s0 = best.0;
            let mut pts = [s0, [s0[0] + step, s0[1]], [s0[0], s0[1] + step]];
            let mut val = [best.1, f(pts[1][0], pts[1][1]), f(pts[2][0], pts[2][1])];
            for _ in 0..600 {
                let mut idx = [0usize, 1, 2];
                idx.sort_by(|&i, &j| val[i].total_cmp(&val[j]));
                pts = [pts[idx[0]], pts[idx[1]], pts[idx[2]]];
                val = [val[idx[0]], val[idx[1]], val[idx[2]]];
                let size = (pts[1][0] - pts[0][0])
                    .abs()
                    .max((pts[1][1] - pts[0][1]).abs())
                    .max((pts[2][0] - pts[0][0]).abs())
                    .max((pts[2][1] - pts[0][1]).abs());
                if size <= 1e-15 * (1.0 + pts[0][0].abs() + pts[0][1].abs()) {
                    break;
                }
                let cen = [0.5 * (pts[0][0] + pts[1][0]), 0.5 * (pts[0][1] + pts[1][1])];
                let at = |k: f64| {
                    [
                        cen[0] + k * (pts[2][0] - cen[0]),
                        cen[1] + k * (pts[2][1] - cen[1]),
                    ]
                };
                let xr = at(-1.0);
                let fr = f(xr[0], xr[1]);
                if fr < val[0] {
                    let xe = at(-2.0);
                    let fe = f(xe[0], xe[1]);
                    if fe < fr {
                        pts[2] = xe;
                        val[2] = fe;
                    } else {
                        pts[2] = xr;
                        val[2] = fr;
                    }
                } else if fr < val[1] {
                    pts[2] = xr;
                    val[2] = fr;
                } else {
                    let xc = if fr < val[2] { at(-0.5) } else { at(0.5) };
                    let fc = f(xc[0], xc[1]);
                    if fc < val[2].min(fr) {
                        pts[2] = xc;
                        val[2] = fc;
                    } else {
                        for k in 1..3 {
                            pts[k] = [0.5 * (pts[0][0] + pts[k][0]), 0.5 * (pts[0][1] + pts[k][1])];
                            val[k] = f(pts[k][0], pts[k][1]);
                        }
                    }
                }
            }
            for k in 0..3 {
                if val[k] < best.1 {
                    best = (pts[k], val[k]);
                }
            }
            step *= 1e-3;
        }
        best
    }

    /// Discrete local minima (8-neighbourhood; `j` periodic if `wrap`) of an
    /// `ni x nj` grid, best first.
    fn grid_minima(grid: &[f64], ni: usize, nj: usize, wrap: bool) -> Vec<(f64, usize, usize)> {
        let mut minima = Vec::new();
        for i in 0..ni {
            for j in 0..nj {
                let v = grid[i * nj + j];
                let mut is_min = true;
                for di in -1i64..=1 {
                    for dj in -1i64..=1 {
                        let ii = i as i64 + di;
                        let mut jj = j as i64 + dj;
                        if wrap {
                            jj = jj.rem_euclid(nj as i64);
                        }
                        if ii >= 0
                            && jj >= 0
                            && (ii as usize) < ni
                            && (jj as usize) < nj
                            && grid[ii as usize * nj + jj as usize] < v
                        {
                            is_min = false;
                        }
                    }
                }
                if is_min {
                    minima.push((v, i, j));
                }
            }
        }
        minima.sort_by(|x, y| x.0.total_cmp(&y.0));
        minima
    }

    /// Brute-force global minimum of the prox objective over the upper nappe. Every
    /// trial point is a position `(x, y)` lifted to `d = ||(x, y) - r_v||`, so it is
    /// feasible by construction. Two dense grids over the position:
    ///
    /// * a Cartesian grid over the sublevel set `{f <= f(apex)}`, which holds the
    ///   optimum: the ellipsoid `(theta - theta_rel)^T A (theta - theta_rel) <=
    ///   2 (f(apex) - f(theta_rel))` around the unconstrained minimiser `theta_rel`,
    ///   projected onto the position;
    /// * a polar grid around `r_v` covering the same ellipse (finer near the apex);
    ///
    /// plus the apex, then Nelder-Mead from the best discrete local minima of each grid.
    pub(crate) fn brute_force(p: &LocalProblem, u: &Vec3, gamma: f64, n: usize) -> (Vec3, f64) {
        let apex = Vec3::new(p.anchor.x, p.anchor.y, 0.0);
        let f_apex = objective(p, &apex, u, gamma);
        let rel = prox_relaxed(p, u, gamma).expect("relaxed prox");
        let kappa = 2.0 * (f_apex - objective(p, &rel, u, gamma));
        let mut best = (apex, f_apex);
        if kappa.is_nan() || kappa <= 0.0 {
            return best;
        }
        let a = p.h + Mat3::identity() / gamma;
        let ainv = a.try_inverse().expect("A invertible");
        let e = nalgebra::Matrix2::new(ainv[(0, 0)], ainv[(0, 1)], ainv[(1, 0)], ainv[(1, 1)]);
        let le = e.cholesky().expect("E SPD").l() * (1.05 * kappa.sqrt());
        let f_pos = |x: f64, y: f64| objective(p, &lift(p, x, y), u, gamma);

        // Cartesian grid in ellipse coordinates xi in [-1, 1]^2.
        let map = |xi0: f64, xi1: f64| -> (f64, f64) {
            (
                rel[0] + le[(0, 0)] * xi0,
                rel[1] + le[(1, 0)] * xi0 + le[(1, 1)] * xi1,
            )
        };
        let h = 2.0 / (n - 1) as f64;
        let fxi = |i: f64, j: f64| {
            let (x, y) = map(-1.0 + h * i, -1.0 + h * j);
            f_pos(x, y)
        };
        let mut grid = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                grid[i * n + j] = fxi(i as f64, j as f64);
            }
        }
        for &(_, i, j) in grid_minima(&grid, n, n, false).iter().take(4) {
            let (ij, val) = nelder_mead(&fxi, [i as f64, j as f64], 0.5);
            if val < best.1 {
                let (x, y) = map(-1.0 + h * ij[0], -1.0 + h * ij[1]);
                best = (lift(p, x, y), val);
            }
        }

        // Polar grid around the anchor: rho = rmax (i / (n - 1))^2, phi = 2 pi j / nphi.
        let rmax = (Vec2::new(rel[0], rel[1]) - p.anchor).norm() + le.norm();
        let nphi = 2 * n;
        let polar = |i: f64, j: f64| -> (f64, f64) {
            let rho = rmax * (i / (n - 1) as f64).powi(2);
            let phi = 2.0 * std::f64::consts::PI * j / nphi as f64;
            (p.anchor.x + rho * phi.cos(), p.anchor.y + rho * phi.sin())
        };
        let fpol = |i: f64, j: f64| {
            let (x, y) = polar(i, j);
            f_pos(x, y)
        };
        let mut grid = vec![0.0; n * nphi];
        for i in 0..n {
            for j in 0..nphi {
                grid[i * nphi + j] = fpol(i as f64, j as f64);
            }
        }
        for &(_, i, j) in grid_minima(&grid, n, nphi, true).iter().take(4) {
            let (ij, val) = nelder_mead(&fpol, [i as f64, j as f64], 0.5);
            if val < best.1 {
                let (x, y) = polar(ij[0], ij[1]);
                best = (lift(p, x, y), val);
            }
        }
        best
    }

    /// The gradient of the prox objective from the rows, and the scale of its terms.
    fn objective_gradient(p: &LocalProblem, th: &Vec3, u: &Vec3, gamma: f64) -> (Vec3, f64) {
        let mut grad = (th - u) / gamma;
        let mut sc = (th.norm() + u.norm()) / gamma;
        for (row, g) in p.rows.iter().zip(&p.g) {
            let b = Vec3::new(row[0], row[1], row[2]);
            let e = b.dot(th) - g;
            grad += b * e;
            sc += b.norm() * (b.norm() * th.norm() + g.abs());
        }
        (grad, sc)
    }

    /// A second, independent oracle: every point of the upper nappe is
    /// `r~ + rho [cos phi, sin phi, 1]`, `rho >= 0`. For each of `n` angles the objective,
    /// built from the rows, is an exact quadratic in `rho`, minimised in closed form over
    /// `rho >= 0`; golden-section search in `phi` then refines the best 3 local minima of
    /// the scan. Strong where the 2-D grid is weak (very ill-conditioned `A`).
    fn angular_scan(p: &LocalProblem, u: &Vec3, gamma: f64, n: usize) -> (Vec3, f64) {
        let r = Vec3::new(p.anchor.x, p.anchor.y, 0.0);
        let d0 = r - u;
        let e0: Vec<f64> = p.residuals(&r);
        let on_ray = |phi: f64| -> (Vec3, f64) {
            let w = Vec3::new(phi.cos(), phi.sin(), 1.0);
            // f(rho) = 1/2 sum (e0_i + rho beta_i)^2 + (|d0|^2 + 2 rho w.d0 + 2 rho^2)/(2 gamma)
            let (mut lin, mut quad) = (w.dot(&d0) / gamma, 2.0 / gamma);
            for (row, e) in p.rows.iter().zip(&e0) {
                let beta = row[0] * w[0] + row[1] * w[1] + row[2];
                lin += e * beta;
                quad += beta * beta;
            }
            let rho = (-lin / quad).max(0.0);
            let th = r + w * rho;
            (th, objective(p, &th, u, gamma))
        };
        let h = 2.0 * std::f64::consts::PI / n as f64;
        let vals: Vec<f64> = (0..n).map(|k| on_ray(h * k as f64).1).collect();
        let mut minima: Vec<(f64, usize)> = (0..n)
            .filter(|&k| vals[k] <= vals[(k + n - 1) % n] && vals[k] <= vals[(k + 1) % n])
            .map(|k| (vals[k], k))
            .collect();
        minima.sort_by(|x, y| x.0.total_cmp(&y.0));
        let mut best = on_ray(0.0);
        for &(_, k) in minima.iter().take(3) {
            let (mut lo, mut hi) = (h * (k as f64 - 1.0), h * (k as f64 + 1.0));
            let g = 0.5 * (5f64.sqrt() - 1.0);
            for _ in 0..80 {
                let m1 = hi - g * (hi - lo);
                let m2 = lo + g * (hi - lo);
                if on_ray(m1).1 < on_ray(m2).1 {
                    hi = m2;
                } else {
                    lo = m1;
                }
            }
            let cand = on_ray(0.5 * (lo + hi));
            if cand.1 < best.1 {
                best = cand;
            }
        }
        best
    }

    /// A rounding-error bound (a few ulps per term) for evaluating `objective` at `th`.
    pub(crate) fn eval_error(p: &LocalProblem, th: &Vec3, u: &Vec3, gamma: f64) -> f64 {
        let mut s = 0.0;
        for (row, g) in p.rows.iter().zip(&p.g) {
            let e = row[0] * th[0] + row[1] * th[1] + row[2] * th[2] - g;
            let mag =
                (row[0] * th[0]).abs() + (row[1] * th[1]).abs() + (row[2] * th[2]).abs() + g.abs();
            s += e.abs() * mag;
        }
        s += (th - u).norm() * (th.norm() + u.norm()) / gamma;
        8.0 * f64::EPSILON * s
    }

    /// A random local problem of node `v` (see `case()`).
    #[derive(Debug, Clone)]
    pub(crate) struct Case {
        pub(crate) p: LocalProblem,
        pub(crate) u: Vec3,
        pub(crate) gamma: f64,
        /// Coordinate scale of the instance.
        pub(crate) scale: f64,
    }

    /// Geometry: scale, transmitter count, positions, mode (0 generic, 1 target near
    /// the receiver, 2 nearly collinear), target, near-distance exponent.
    type GeoParams = (
        bool,
        usize,
        [(f64, f64); 4],
        (f64, f64),
        u8,
        (f64, f64),
        f64,
    );
    /// Measurements: noise draws, DOA on, log10 omega, range on, log10 gamma.
    type MeasParams = ([f64; 7], bool, f64, bool, f64);
    /// Input u: mode, direction, log10 magnitude.
    type UParams = (u8, (f64, f64, f64), f64);

    fn build_case(geo: GeoParams, meas: MeasParams, up: UParams) -> Case {
        let (small, m, tx, anchor, mode, tgt, near_log) = geo;
        let (noise, doa_on, omega_log, range_on, gamma_log) = meas;
        let (u_mode, u_dir, u_log) = up;
        let scale = if small { 3.0 } else { 3000.0 };
        let anchor = Vec2::new(scale * anchor.0, scale * anchor.1);
        let mut txs: Vec<Vec2> = tx[..m]
            .iter()
            .map(|t| Vec2::new(scale * t.0, scale * t.1))
            .collect();
        let target = match mode {
            0 => Vec2::new(scale * tgt.0, scale * tgt.1),
            1 => {
                let ang = std::f64::consts::PI * tgt.0;
                anchor + 10f64.powf(near_log) * Vec2::new(ang.cos(), ang.sin())
            }
            _ => {
                let ang = std::f64::consts::PI * tgt.1;
                let e = Vec2::new(ang.cos(), ang.sin());
                let nrm = Vec2::new(-e.y, e.x);
                for (k, t) in txs.iter_mut().enumerate() {
                    *t = anchor + scale * tx[k].0 * e + 1e-6 * scale * tx[k].1 * nrm;
                }
                anchor + scale * tgt.0 * e + 1e-4 * scale * tgt.1 * nrm
            }
        };
        let sig_r = if small { 0.05 } else { 5.0 };
        let sig_doa = 0.5;
        let meas = NodeMeasurements {
            elevation: None,
            bistatic: (0..m)
                .map(|k| {
                    let rho = (target - txs[k]).norm() + (target - anchor).norm();
                    (k, rho + sig_r * noise[k])
                })
                .collect(),
            doa: doa_on
                .then(|| (target.y - anchor.y).atan2(target.x - anchor.x) + sig_doa * noise[4]),
            range: range_on.then(|| (target - anchor).norm() + sig_r * noise[5]),
        };
        let p = LocalProblem::build(anchor, &txs, 10f64.powf(omega_log), &meas);
        let gamma = 10f64.powf(gamma_log);
        let mag = scale * 10f64.powf(u_log);
        let dir = Vec3::new(u_dir.0, u_dir.1, u_dir.2);
        let truth = Vec3::new(target.x, target.y, (target - anchor).norm());
        let apex = Vec3::new(anchor.x, anchor.y, 0.0);
        let u = match u_mode {
            // Near the true lifted target (on or close to the cone).
            0 => truth + 1e-3 * mag * dir,
            // Anywhere around the apex, far or near.
            1 => apex + mag * dir,
            // Below the apex: large negative d.
            2 => {
                apex + Vec3::new(
                    1e-3 * mag * dir.x,
                    1e-3 * mag * dir.y,
                    -mag * (1.0 + dir.z.abs()),
                )
            }
            // Around the target, far.
            _ => truth + mag * dir,
        };
        let _ = noise[6];
        Case { p, u, gamma, scale }
    }

    prop_compose! {
        pub(crate) fn case()(
            geo in (
                any::<bool>(),
                0usize..=4,
                prop::array::uniform4((-1.0f64..1.0, -1.0f64..1.0)),
                (-1.0f64..1.0, -1.0f64..1.0),
                0u8..3,
                (-1.0f64..1.0, -1.0f64..1.0),
                -3.0f64..0.0,
            ),
            meas in (
                prop::array::uniform7(-1.7f64..1.7),
                any::<bool>(),
                -1.0f64..1.0,
                any::<bool>(),
                -10.0f64..-2.0,
            ),
            up in (0u8..4, (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0), -6.0f64..1.0),
        ) -> Case {
            build_case(geo, meas, up)
        }
    }

    /// The paper's geometry (Mourya 2017 Sec. III-C): node `v` of 6, noise-free
    /// measurements of a target at `[520, 480]`.
    pub(crate) fn paper_problem(v: usize) -> LocalProblem {
        let geometry = crate::model::measure::Geometry::mourya2017();
        let tx = &geometry.transmitters;
        let target = Vec2::new(520.0, 480.0);
        let r = geometry.receivers[v];
        let meas = NodeMeasurements {
            elevation: None,
            bistatic: tx
                .iter()
                .enumerate()
                .map(|(k, t)| (k, (target - t).norm() + (target - r).norm()))
                .collect(),
            doa: Some((target.y - r.y).atan2(target.x - r.x)),
            range: None,
        };
        LocalProblem::build(r, tx, 1.0, &meas)
    }

    /// Check a GTRS answer against brute force and the constraint; returns an error
    /// message on failure.
    fn check_against_brute_force(c: &Case, n: usize) -> Result<(), TestCaseError> {
        let th = prox_gtrs(&c.p, &c.u, c.gamma).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let viol = c.p.cone_violation(&th);
        let sc = c.scale + c.p.anchor.norm() + th.norm();
        prop_assert!(viol.abs() <= 1e-9 * sc, "cone violation {viol} at {th:?}");
        prop_assert!(th[2] >= 0.0, "d < 0: {th:?}");
        let f = c.p.prox_objective(&th, &c.u, c.gamma);
        let (bth, _) = brute_force(&c.p, &c.u, c.gamma, n);
        let fb = c.p.prox_objective(&bth, &c.u, c.gamma);
        let round = eval_error(&c.p, &th, &c.u, c.gamma) + eval_error(&c.p, &bth, &c.u, c.gamma);
        prop_assert!(
            f <= fb + 1e-9 * fb.abs() + round,
            "gtrs {f:e} worse than brute force {fb:e} (rel {:e}); gtrs {th:?}, brute {bth:?}",
            (f - fb) / fb
        );
        let (sth, _) = angular_scan(&c.p, &c.u, c.gamma, 4096);
        let fs = c.p.prox_objective(&sth, &c.u, c.gamma);
        let round = eval_error(&c.p, &th, &c.u, c.gamma) + eval_error(&c.p, &sth, &c.u, c.gamma);
        prop_assert!(
            f <= fs + 1e-9 * fs.abs() + round,
            "gtrs {f:e} worse than the angular scan {fs:e}; gtrs {th:?}, scan {sth:?}"
        );
        // Away from the apex (a regular point of the cone) the answer is a KKT point: the
        // gradient of the objective is normal to the cone.
        let y = th - Vec3::new(c.p.anchor.x, c.p.anchor.y, 0.0);
        if th[2] > 0.0 {
            let (grad, sc) = objective_gradient(&c.p, &th, &c.u, c.gamma);
            let n = Vec3::new(y[0], y[1], -y[2]);
            let tangential = grad - n * (grad.dot(&n) / n.norm_squared());
            prop_assert!(
                tangential.norm() <= 1e-10 * sc,
                "not a KKT point: tangential gradient {:e}, scale {sc:e}",
                tangential.norm()
            );
        }
        // The relaxed prox is a lower bound (its feasible set is larger).
        let rel =
            prox_relaxed(&c.p, &c.u, c.gamma).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let fr = c.p.prox_objective(&rel, &c.u, c.gamma);
        let round = eval_error(&c.p, &th, &c.u, c.gamma) + eval_error(&c.p, &rel, &c.u, c.gamma);
        prop_assert!(
            fr <= f + 1e-9 * f.abs() + round,
            "relaxed {fr:e} above gtrs {f:e}"
        );
        Ok(())
    }

    /// Generalised eigenvectors `V` (columns) with `V^T A V = I`, `V^T S V = diag(s)`.
    fn simultaneous_diag(a: &Mat3) -> (Mat3, Vec3) {
        let l = a.cholesky().expect("A SPD").l();
        let li = l.try_inverse().expect("L invertible");
        let s = Mat3::from_diagonal(&Vec3::new(1.0, 1.0, -1.0));
        let m = li * s * li.transpose();
        let eig = m.symmetric_eigen();
        (li.transpose() * eig.eigenvectors, eig.eigenvalues)
    }

    // ---------------------------------------------------------------- unit tests

    #[test]
    fn secular_trig_polynomial_equals_2_db_a_minus_b_da() {
        let a = Mat3::new(3.0, 0.4, -0.7, 0.4, 2.0, 0.3, -0.7, 0.3, 1.5);
        let q = Quad {
            a00: a[(0, 0)],
            a11: a[(1, 1)],
            a22: a[(2, 2)],
            a01: a[(0, 1)],
            a02: a[(0, 2)],
            a12: a[(1, 2)],
        };
        let b = Vec3::new(0.3, -1.1, 0.6);
        let [p0, p1, q1, p2, q2] = secular_trig(&q, b[0], b[1], b[2]);
        for k in 0..50 {
            let phi = 0.37 + 0.13 * k as f64;
            let (s, c) = phi.sin_cos();
            let w = Vec3::new(c, s, 1.0);
            let dw = Vec3::new(-s, c, 0.0);
            let aw = w.dot(&(a * w));
            let daw = 2.0 * dw.dot(&(a * w));
            let direct = 2.0 * b.dot(&dw) * aw - b.dot(&w) * daw;
            let trig = p0 + p1 * c + q1 * s + p2 * (2.0 * phi).cos() + q2 * (2.0 * phi).sin();
            approx::assert_relative_eq!(direct, trig, epsilon = 1e-12, max_relative = 1e-12);
        }
    }

    #[test]
    fn quartic_seeds_recover_all_real_roots_including_double_ones() {
        let sets: [[f64; 4]; 6] = [
            [-3.0, -0.5, 0.25, 2.0],
            [1.0, 1.0, -2.0, 5.0],
            [0.1, 0.1 + 1e-9, -0.7, 0.3],
            [-1.0, -1.0, -1.0, -1.0],
            [1e-3, 2e-3, 12.0, -12.0],
            [0.0, 0.0, 3.0, -4.0],
        ];
        for roots in sets {
            for lead in [1.0, -2.5] {
                // e4 prod (t - r_i)
                let mut poly = vec![lead];
                for r in roots {
                    let mut next = vec![0.0; poly.len() + 1];
                    for (i, c) in poly.iter().enumerate() {
                        next[i] += c;
                        next[i + 1] -= c * r;
                    }
                    poly = next;
                }
                // poly is highest-first; e is lowest-first.
                let e = [poly[4], poly[3], poly[2], poly[1], poly[0]];
                let (seeds, ns) = quartic_seeds(&e);
                let seeds: Vec<f64> = seeds[..ns]
                    .iter()
                    .map(|s| newton_polish(&e, s.re))
                    .collect();
                for r in roots {
                    let dist = seeds
                        .iter()
                        .map(|s| (s - r).abs())
                        .fold(f64::INFINITY, f64::min);
                    assert!(
                        dist <= 1e-6 * (1.0 + r.abs()),
                        "root {r} of {roots:?}: seeds {seeds:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn the_power_of_two_normaliser_maps_the_largest_entry_into_one_to_two_exactly() {
        for x in [
            1.0,
            1.5,
            3.0,
            1e-300,
            7.3e7,
            5e7 + 1.2e7,
            1.7e307,
            0.999_999,
        ] {
            let ia = pow2_recip(x).unwrap();
            let y = x * ia;
            assert!((1.0..2.0).contains(&y), "{x} -> {y}");
            // A power of two: scaling is exact.
            assert_eq!(ia.to_bits() & ((1u64 << 52) - 1), 0, "{x}");
        }
        for x in [0.0, -1.0, f64::INFINITY, f64::NAN, 1e-310, f64::MAX] {
            assert!(pow2_recip(x).is_none(), "{x}");
        }
    }

    #[test]
    fn the_fast_cube_root_agrees_with_the_library_to_rounding_over_all_exponents() {
        let mut x = f64::MIN_POSITIVE;
        let mut worst = 0.0f64;
        while x.is_finite() {
            for m in [1.0, 1.1, 1.37, 1.5, 1.77, 1.99] {
                let v = x * m;
                if !v.is_finite() {
                    continue;
                }
                let rel = (cbrt_nonneg(v) - v.cbrt()).abs() / v.cbrt();
                worst = worst.max(rel);
            }
            x *= 3.7;
        }
        assert!(worst <= 1e-14, "worst relative error {worst:e}");
        for v in [0.0, 1e-310, f64::INFINITY] {
            assert_eq!(cbrt_nonneg(v).to_bits(), v.cbrt().to_bits(), "{v}");
        }
        assert!(cbrt_nonneg(f64::NAN).is_nan());
    }

    #[test]
    fn cubic_largest_root_is_found_for_one_and_three_real_roots() {
        for roots in [
            [1.0, 2.0, 3.0],
            [-4.0, 0.5, 0.5],
            [0.0, 0.0, 0.0],
            [-1.0, -2.0, 7.5],
        ] {
            let a = -(roots[0] + roots[1] + roots[2]);
            let b = roots[0] * roots[1] + roots[1] * roots[2] + roots[0] * roots[2];
            let c = -roots[0] * roots[1] * roots[2];
            let m = cubic_largest_root(a, b, c);
            let want = roots.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            approx::assert_abs_diff_eq!(m, want, epsilon = 1e-7);
        }
        // (m - 2)(m^2 + 1): one real root.
        approx::assert_abs_diff_eq!(cubic_largest_root(-2.0, 1.0, -2.0), 2.0, epsilon = 1e-12);
    }

    #[test]
    fn gtrs_matches_brute_force_on_the_paper_geometry() {
        for v in 0..6 {
            let p = paper_problem(v);
            for (k, u) in [
                Vec3::new(500.0, 500.0, 1000.0),
                Vec3::new(520.0, 480.0, 0.0),
                Vec3::new(-3000.0, 200.0, 5.0),
                Vec3::new(p.anchor.x, p.anchor.y, -2000.0),
            ]
            .into_iter()
            .enumerate()
            {
                let c = Case {
                    p: p.clone(),
                    u,
                    gamma: 2e-8,
                    scale: 3000.0,
                };
                if let Err(e) = check_against_brute_force(&c, 201) {
                    panic!("node {v}, u #{k}: {e}");
                }
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, .. ProptestConfig::default() })]
        /// `row_weights = "noise"`: the exact prox of the weighted cost (rows
        /// divided by their noise standard deviations) is still the global
        /// minimiser on the cone.
        #[test]
        fn gtrs_matches_brute_force_on_noise_weighted_costs(
            v in 0usize..6,
            target in (0.0f64..1000.0, 0.0f64..1000.0),
            noise in prop::array::uniform3(-3.0f64..3.0),
            du in (-300.0f64..300.0, -300.0f64..300.0, -300.0f64..300.0),
            log_gamma in -1.0f64..3.0,
        ) {
            let geometry = crate::model::measure::Geometry::mourya2017();
            let tx = &geometry.transmitters;
            let x = Vec2::new(target.0, target.1);
            let r = geometry.receivers[v];
            let sig = crate::model::measure::Sigmas { range: 5.0, doa: 0.05, elevation: 0.0 };
            let meas = NodeMeasurements {
                elevation: None,
                bistatic: tx
                    .iter()
                    .enumerate()
                    .map(|(k, t)| (k, (x - t).norm() + (x - r).norm() + sig.range * noise[k]))
                    .collect(),
                doa: Some((x.y - r.y).atan2(x.x - r.x) + sig.doa * noise[2]),
                range: None,
            };
            let p = LocalProblem::build_weighted(r, tx, 1.0, &meas, Some(&sig));
            let u = Vec3::new(x.x + du.0, x.y + du.1, (x - r).norm() + du.2);
            let c = Case { p, u, gamma: 10f64.powf(log_gamma), scale: 3000.0 };
            check_against_brute_force(&c, 201)?;
        }
    }

    #[test]
    fn gtrs_recovers_the_noise_free_target_when_u_is_the_truth() {
        // With noise-free data and u = the lifted truth, the truth is the global
        // minimiser (both terms vanish there).
        for v in 0..6 {
            let p = paper_problem(v);
            let t = Vec2::new(520.0, 480.0);
            let truth = Vec3::new(t.x, t.y, (t - p.anchor).norm());
            let th = prox_gtrs(&p, &truth, 2e-8).unwrap();
            approx::assert_relative_eq!(th, truth, max_relative = 1e-9);
        }
    }

    #[test]
    fn empty_problem_on_the_axis_gives_the_circle_or_the_apex() {
        let r = Vec2::new(3.0, -2.0);
        let p = LocalProblem::empty(r);
        // u = [r, d], d > 0: every point of the circle of radius d/2 is optimal.
        let th = prox_gtrs(&p, &Vec3::new(3.0, -2.0, 4.0), 0.1).unwrap();
        approx::assert_abs_diff_eq!(th[2], 2.0, epsilon = 1e-12);
        approx::assert_abs_diff_eq!(p.cone_violation(&th), 0.0, epsilon = 1e-12);
        // d < 0: the apex.
        let th = prox_gtrs(&p, &Vec3::new(3.0, -2.0, -4.0), 0.1).unwrap();
        approx::assert_abs_diff_eq!(th, Vec3::new(3.0, -2.0, 0.0), epsilon = 1e-15);
        // u at the apex: the apex.
        let th = prox_gtrs(&p, &Vec3::new(3.0, -2.0, 0.0), 0.1).unwrap();
        approx::assert_abs_diff_eq!(th, Vec3::new(3.0, -2.0, 0.0), epsilon = 1e-15);
    }

    /// Monic-scaled quartic `lead * prod (t - r_i)` with the given complex roots
    /// (conjugate pairs as `(re, im)` twice), lowest coefficient first.
    fn quartic_from_roots(lead: f64, roots: &[(f64, f64); 4]) -> [f64; 5] {
        // Multiply in complex arithmetic; the result is real for conjugate pairs.
        let mut poly = vec![(lead, 0.0)];
        for &(re, im) in roots {
            let mut next = vec![(0.0, 0.0); poly.len() + 1];
            for (i, &(cr, ci)) in poly.iter().enumerate() {
                next[i].0 += cr;
                next[i].1 += ci;
                next[i + 1].0 -= cr * re - ci * im;
                next[i + 1].1 -= cr * im + ci * re;
            }
            poly = next;
        }
        [poly[4].0, poly[3].0, poly[2].0, poly[1].0, poly[0].0]
    }

    // ---------------------------------------------------------------- properties

    proptest! {
        #![proptest_config(ProptestConfig { cases: 5000, ..ProptestConfig::default() })]

        /// Every real root of a quartic is found (to 1e-9, or for a root in a cluster to
        /// its distance to the neighbour plus the ~sqrt(eps) conditioning of a near-double
        /// root), with 4, 2 or 0 real roots, clusters and either leading sign.
        #[test]
        fn quartic_seeds_find_every_real_root(
            r in prop::array::uniform4(-15.0f64..15.0),
            gap in -9.0f64..0.0,
            im in -6.0f64..1.0,
            shape in 0u8..4,
            lead in prop_oneof![-3.0f64..-0.3, 0.3f64..3.0],
        ) {
            let g = 10f64.powf(gap);
            let i = 10f64.powf(im);
            let roots: [(f64, f64); 4] = match shape {
                0 => [(r[0], 0.0), (r[1], 0.0), (r[2], 0.0), (r[3], 0.0)],
                1 => [(r[0], 0.0), (r[0] + g, 0.0), (r[2], 0.0), (r[3], 0.0)],
                2 => [(r[0], 0.0), (r[1], 0.0), (r[2], i), (r[2], -i)],
                _ => [(r[0], i), (r[0], -i), (r[2], 1.0 + i), (r[2], -1.0 - i)],
            };
            let e = quartic_from_roots(lead, &roots);
            let (seeds, ns) = quartic_seeds(&e);
            prop_assert!((2..=4).contains(&ns));
            let polished: Vec<f64> = seeds[..ns].iter().map(|s| newton_polish(&e, s.re)).collect();
            for (k, &(re, imag)) in roots.iter().enumerate() {
                if imag.abs() > 0.0 {
                    continue;
                }
                let nearest_other = roots
                    .iter()
                    .enumerate()
                    .filter(|&(j, _)| j != k)
                    .map(|(_, &(a, b))| (a - re).hypot(b))
                    .fold(f64::INFINITY, f64::min);
                let dist = polished.iter().map(|s| (s - re).abs()).fold(f64::INFINITY, f64::min);
                // Attainable accuracy: rounding in Q is eps_q; a root moves by
                // ~eps_q/|Q'| (simple) or ~sqrt(eps_q/|Q''/2|) (near-double).
                let eps_q = 4.0 * f64::EPSILON * (0..5).map(|j| e[j].abs() * re.abs().powi(j as i32)).sum::<f64>();
                let d1 = ((1..5).map(|j| j as f64 * e[j] * re.powi(j as i32 - 1)).sum::<f64>()).abs();
                let d2 = ((2..5).map(|j| (j * (j - 1)) as f64 * e[j] * re.powi(j as i32 - 2)).sum::<f64>()).abs();
                let cond = (eps_q / d1).min((2.0 * eps_q / d2).sqrt());
                prop_assert!(
                    dist <= 1e-9 * (1.0 + re.abs()) + 2.0 * nearest_other.min(1e-3) + 10.0 * cond,
                    "root {re} (nearest other {nearest_other:e}) missed: {polished:?}"
                );
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 3000, ..ProptestConfig::default() })]

        #[test]
        fn gtrs_matches_brute_force_on_random_instances(c in case()) {
            check_against_brute_force(&c, 101)?;
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

        /// `b` orthogonal to a generalised eigenvector of `(A, S)` (a zero component of
        /// `beta` in the secular equation): the "hard case" of trust-region theory.
        #[test]
        fn gtrs_matches_brute_force_in_the_hard_case(c in case(), i in 0usize..3, w in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0)) {
            let a = c.p.h + Mat3::identity() / c.gamma;
            let (v, _s) = simultaneous_diag(&a);
            let vi = v.column(i).into_owned();
            let r = Vec3::new(c.p.anchor.x, c.p.anchor.y, 0.0);
            let b0 = (c.p.c - c.p.h * r) + (c.u - r) / c.gamma;
            let mut bt = Vec3::new(w.0, w.1, w.2) * b0.norm();
            bt -= vi * (bt.dot(&vi) / vi.norm_squared());
            prop_assume!(bt.norm() > 0.0);
            let u = r + (bt - (c.p.c - c.p.h * r)) * c.gamma;
            let hc = Case { u, ..c };
            check_against_brute_force(&hc, 101)?;
        }

        /// `-b` in the (self-dual) cone: the apex is the unique minimiser.
        #[test]
        fn gtrs_returns_the_apex_when_it_is_optimal(c in case(), ang in 0.0f64..6.3, slack in 0.0f64..2.0) {
            let r = Vec3::new(c.p.anchor.x, c.p.anchor.y, 0.0);
            let bn = (c.p.c - c.p.h * r).norm() + c.u.norm() / c.gamma + 1.0;
            let bt = -bn * Vec3::new(ang.cos(), ang.sin(), 1.0 + slack);
            let u = r + (bt - (c.p.c - c.p.h * r)) * c.gamma;
            let th = prox_gtrs(&c.p, &u, c.gamma).unwrap();
            let tol = 1e-9 * (c.scale + r.norm());
            prop_assert!((th - r).norm() <= tol, "not the apex: {:?} vs {:?}", th, r);
        }

        /// When the unconstrained minimiser lies on the upper nappe it is the GTRS answer.
        #[test]
        fn gtrs_equals_relaxed_when_the_relaxed_solution_is_feasible(c in case(), pos in (-1.0f64..1.0, -1.0f64..1.0)) {
            let x = c.p.anchor + c.scale * Vec2::new(pos.0, pos.1);
            let th0 = Vec3::new(x.x, x.y, (x - c.p.anchor).norm());
            let u = th0 + c.gamma * (c.p.h * th0 - c.p.c);
            let th = prox_gtrs(&c.p, &u, c.gamma).unwrap();
            prop_assert!((th - th0).norm() <= 1e-8 * (c.scale + th0.norm()), "{:?} vs {:?}", th, th0);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

        /// Without rows the GTRS prox is the projection onto the upper nappe, whose closed
        /// form is `((|p| + s)/2)_+ [p/|p|, 1]` for `u - r~ = [p, s]`.
        #[test]
        fn empty_problem_gtrs_is_the_projection_onto_the_upper_nappe(
            r in (-1e3f64..1e3, -1e3f64..1e3),
            w in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
            lg in -6.0f64..4.0,
            gl in -10.0f64..2.0,
        ) {
            let anchor = Vec2::new(r.0, r.1);
            let p = LocalProblem::empty(anchor);
            let y = Vec3::new(w.0, w.1, w.2) * 10f64.powf(lg);
            let u = Vec3::new(anchor.x, anchor.y, 0.0) + y;
            let th = prox_gtrs(&p, &u, 10f64.powf(gl)).unwrap();
            let pn = (y[0]).hypot(y[1]);
            let rho = (0.5 * (pn + y[2])).max(0.0);
            let want = if pn > 0.0 {
                Vec3::new(anchor.x + rho * y[0] / pn, anchor.y + rho * y[1] / pn, rho)
            } else {
                Vec3::new(anchor.x, anchor.y, 0.0)
            };
            prop_assert!((th - want).norm() <= 1e-9 * (anchor.norm() + y.norm()), "{:?} vs {:?}", th, want);
        }

        /// The relaxed prox solves `(H + I/gamma) theta = c + u/gamma`: the gradient of
        /// the objective, computed from the rows, vanishes.
        #[test]
        fn relaxed_prox_zeroes_the_gradient(c in case()) {
            let th = prox_relaxed(&c.p, &c.u, c.gamma).unwrap();
            let (grad, sc) = objective_gradient(&c.p, &th, &c.u, c.gamma);
            prop_assert!(grad.norm() <= 1e-9 * sc, "gradient {:?} scale {:e}", grad, sc);
        }
    }
}
