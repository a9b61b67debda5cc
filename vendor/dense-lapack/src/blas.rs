//! The level-2 and level-3 BLAS routines, on slices, with reference BLAS's
//! argument checks (the `Err` names the illegal argument by its position in the
//! Fortran argument list) and quick returns. The exported symbols in `ffi`
//! only turn pointers into slices and call these.

use crate::args::{
    Illegal, Op, Real, Tri, covers, extent, gather, is_one, is_zero, lead, nonneg, op, scale,
    scatter, tri, vec_extent, view, view_mut,
};
use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::{Accum, MatRef, Par};

fn apply<T: Real>(a: MatRef<'_, T>, o: Op) -> MatRef<'_, T> {
    match o {
        Op::No => a,
        Op::Trans => a.transpose(),
    }
}

fn structure(t: Tri) -> BlockStructure {
    match t {
        Tri::Upper => BlockStructure::TriangularUpper,
        Tri::Lower => BlockStructure::TriangularLower,
    }
}

/// `dgemm`: `C = alpha op(A) op(B) + beta C`, `C` is `m x n`, `op(A)` is
/// `m x k`.
pub fn gemm<T: Real>(
    transa: u8,
    transb: u8,
    m: i32,
    n: i32,
    k: i32,
    alpha: T,
    a: &[T],
    lda: i32,
    b: &[T],
    ldb: i32,
    beta: T,
    c: &mut [T],
    ldc: i32,
) -> Result<(), Illegal> {
    let ta = op(transa, 1)?;
    let tb = op(transb, 2)?;
    let (mu, nu, ku) = (nonneg(m, 3)?, nonneg(n, 4)?, nonneg(k, 5)?);
    let (ra, ca) = if ta == Op::No { (mu, ku) } else { (ku, mu) };
    let (rb, cb) = if tb == Op::No { (ku, nu) } else { (nu, ku) };
    let lda = lead(lda, ra, 8)?;
    let ldb = lead(ldb, rb, 10)?;
    let ldc = lead(ldc, mu, 13)?;
    if mu == 0 || nu == 0 || ((is_zero(alpha) || ku == 0) && is_one(beta)) {
        return Ok(());
    }
    covers(c.len(), extent(m, n, ldc as i32), 12)?;
    if is_zero(alpha) || ku == 0 {
        scale(c, mu, nu, ldc, None, beta);
        return Ok(());
    }
    covers(a.len(), extent(ra as i32, ca as i32, lda as i32), 7)?;
    covers(b.len(), extent(rb as i32, cb as i32, ldb as i32), 9)?;
    let accum = if is_zero(beta) {
        Accum::Replace
    } else {
        scale(c, mu, nu, ldc, None, beta);
        Accum::Add
    };
    let av = apply(view(a, ra, ca, lda), ta);
    let bv = apply(view(b, rb, cb, ldb), tb);
    matmul(view_mut(c, mu, nu, ldc), accum, av, bv, alpha, Par::Seq);
    Ok(())
}

/// `dgemv`: `y = alpha op(A) x + beta y`, `A` is `m x n`.
pub fn gemv<T: Real>(
    trans: u8,
    m: i32,
    n: i32,
    alpha: T,
    a: &[T],
    lda: i32,
    x: &[T],
    incx: i32,
    beta: T,
    y: &mut [T],
    incy: i32,
) -> Result<(), Illegal> {
    let t = op(trans, 1)?;
    let (mu, nu) = (nonneg(m, 2)?, nonneg(n, 3)?);
    let lda = lead(lda, mu, 6)?;
    if incx == 0 {
        return Err(Illegal(8));
    }
    if incy == 0 {
        return Err(Illegal(11));
    }
    if mu == 0 || nu == 0 || (is_zero(alpha) && is_one(beta)) {
        return Ok(());
    }
    let (lenx, leny) = if t == Op::No { (nu, mu) } else { (mu, nu) };
    covers(y.len(), vec_extent(leny as i32, incy), 10)?;
    let mut yv = if is_zero(beta) {
        vec![T::zero(); leny]
    } else {
        let mut v = gather(y, leny, incy);
        scale(&mut v, leny, 1, leny, None, beta);
        v
    };
    if !is_zero(alpha) {
        covers(a.len(), extent(m, n, lda as i32), 5)?;
        covers(x.len(), vec_extent(lenx as i32, incx), 7)?;
        let xv = gather(x, lenx, incx);
        let av = apply(view(a, mu, nu, lda), t);
        let xm = view(&xv, lenx, 1, lenx);
        matmul(
            view_mut(&mut yv, leny, 1, leny),
            Accum::Add,
            av,
            xm,
            alpha,
            Par::Seq,
        );
    }
    scatter(&yv, y, incy);
    Ok(())
}

/// The full symmetric `n x n` matrix whose `t` triangle is stored in `a`
/// (the other triangle is not read).
pub(crate) fn symmetric<T: Real>(a: &[T], n: usize, lda: usize, t: Tri) -> faer::Mat<T> {
    faer::Mat::from_fn(n, n, |i, j| {
        let (r, c) = match t {
            Tri::Upper if i > j => (j, i),
            Tri::Lower if i < j => (j, i),
            _ => (i, j),
        };
        a[c * lda + r]
    })
}

/// `dsymv`: `y = alpha A x + beta y`, `A` symmetric `n x n`, stored in the
/// `uplo` triangle.
pub fn symv<T: Real>(
    uplo: u8,
    n: i32,
    alpha: T,
    a: &[T],
    lda: i32,
    x: &[T],
    incx: i32,
    beta: T,
    y: &mut [T],
    incy: i32,
) -> Result<(), Illegal> {
    let t = tri(uplo, 1)?;
    let nu = nonneg(n, 2)?;
    let lda = lead(lda, nu, 5)?;
    if incx == 0 {
        return Err(Illegal(7));
    }
    if incy == 0 {
        return Err(Illegal(10));
    }
    if nu == 0 || (is_zero(alpha) && is_one(beta)) {
        return Ok(());
    }
    covers(y.len(), vec_extent(n, incy), 9)?;
    let mut yv = if is_zero(beta) {
        vec![T::zero(); nu]
    } else {
        let mut v = gather(y, nu, incy);
        scale(&mut v, nu, 1, nu, None, beta);
        v
    };
    if !is_zero(alpha) {
        covers(a.len(), extent(n, n, lda as i32), 4)?;
        covers(x.len(), vec_extent(n, incx), 6)?;
        let full = symmetric(a, nu, lda, t);
        let xv = gather(x, nu, incx);
        let xm = view(&xv, nu, 1, nu);
        matmul(
            view_mut(&mut yv, nu, 1, nu),
            Accum::Add,
            full.as_ref(),
            xm,
            alpha,
            Par::Seq,
        );
    }
    scatter(&yv, y, incy);
    Ok(())
}

/// `dsyrk`: `C = alpha op(A) op(A)^T + beta C` on the `uplo` triangle of the
/// `n x n` matrix `C` (the other triangle is neither read nor written);
/// `op(A)` is `n x k`.
pub fn syrk<T: Real>(
    uplo: u8,
    trans: u8,
    n: i32,
    k: i32,
    alpha: T,
    a: &[T],
    lda: i32,
    beta: T,
    c: &mut [T],
    ldc: i32,
) -> Result<(), Illegal> {
    let t = tri(uplo, 1)?;
    let o = op(trans, 2)?;
    let (nu, ku) = (nonneg(n, 3)?, nonneg(k, 4)?);
    let (ra, ca) = if o == Op::No { (nu, ku) } else { (ku, nu) };
    let lda = lead(lda, ra, 7)?;
    let ldc = lead(ldc, nu, 10)?;
    if nu == 0 || ((is_zero(alpha) || ku == 0) && is_one(beta)) {
        return Ok(());
    }
    covers(c.len(), extent(n, n, ldc as i32), 9)?;
    let accum = if is_zero(beta) && !is_zero(alpha) && ku > 0 {
        Accum::Replace
    } else {
        scale(c, nu, nu, ldc, Some(t), beta);
        Accum::Add
    };
    if is_zero(alpha) || ku == 0 {
        return Ok(());
    }
    covers(a.len(), extent(ra as i32, ca as i32, lda as i32), 6)?;
    let av = apply(view(a, ra, ca, lda), o);
    triangular::matmul(
        view_mut(c, nu, nu, ldc),
        structure(t),
        accum,
        av,
        BlockStructure::Rectangular,
        av.transpose(),
        BlockStructure::Rectangular,
        alpha,
        Par::Seq,
    );
    Ok(())
}

/// `dsyr2k`: `C = alpha (op(A) op(B)^T + op(B) op(A)^T) + beta C` on the
/// `uplo` triangle of `C`; `op(A)`, `op(B)` are `n x k`.
pub fn syr2k<T: Real>(
    uplo: u8,
    trans: u8,
    n: i32,
    k: i32,
    alpha: T,
    a: &[T],
    lda: i32,
    b: &[T],
    ldb: i32,
    beta: T,
    c: &mut [T],
    ldc: i32,
) -> Result<(), Illegal> {
    let t = tri(uplo, 1)?;
    let o = op(trans, 2)?;
    let (nu, ku) = (nonneg(n, 3)?, nonneg(k, 4)?);
    let (ra, ca) = if o == Op::No { (nu, ku) } else { (ku, nu) };
    let lda = lead(lda, ra, 7)?;
    let ldb = lead(ldb, ra, 9)?;
    let ldc = lead(ldc, nu, 12)?;
    if nu == 0 || ((is_zero(alpha) || ku == 0) && is_one(beta)) {
        return Ok(());
    }
    covers(c.len(), extent(n, n, ldc as i32), 11)?;
    let accum = if is_zero(beta) && !is_zero(alpha) && ku > 0 {
        Accum::Replace
    } else {
        scale(c, nu, nu, ldc, Some(t), beta);
        Accum::Add
    };
    if is_zero(alpha) || ku == 0 {
        return Ok(());
    }
    covers(a.len(), extent(ra as i32, ca as i32, lda as i32), 6)?;
    covers(b.len(), extent(ra as i32, ca as i32, ldb as i32), 8)?;
    let av = apply(view(a, ra, ca, lda), o);
    let bv = apply(view(b, ra, ca, ldb), o);
    let mut cv = view_mut(c, nu, nu, ldc);
    for (l, r, acc) in [(av, bv, accum), (bv, av, Accum::Add)] {
        triangular::matmul(
            cv.as_mut(),
            structure(t),
            acc,
            l,
            BlockStructure::Rectangular,
            r.transpose(),
            BlockStructure::Rectangular,
            alpha,
            Par::Seq,
        );
    }
    Ok(())
}
