//! The LAPACK routines, on slices. `Ok(0)` is success, `Ok(i > 0)` LAPACK's
//! numerical `info`, and `Err` an illegal argument (LAPACK's `info < 0`),
//! checked in LAPACK's order.

use crate::args::{Illegal, Real, Tri, covers, extent, is_zero, lead, nonneg, tri, view, view_mut};
use faer::Par;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{LltError, cholesky_in_place, cholesky_in_place_scratch};
use faer::linalg::evd::{ComputeEigenvectors, self_adjoint_evd, self_adjoint_evd_scratch};
use faer::linalg::lu::partial_pivoting::factor::{lu_in_place, lu_in_place_scratch};
use faer::linalg::svd::{ComputeSvdVectors, svd, svd_scratch};
use faer::linalg::triangular_solve as ts;

/// Workspace sizes in LAPACK's `i32`, saturating instead of overflowing.
fn size(v: usize) -> i32 {
    i32::try_from(v).unwrap_or(i32::MAX)
}

/// `dsyevr` with `range = 'A'`: every eigenvalue of the symmetric `n x n`
/// matrix stored in the `uplo` triangle of `a`, ascending, into `w`, and with
/// `jobz = 'V'` the orthonormal eigenvectors into the columns of `z`.
/// `vl`, `vu`, `il`, `iu` and `abstol` are not used by `range = 'A'`.
pub fn syevr<T: Real>(
    jobz: u8,
    range: u8,
    uplo: u8,
    n: i32,
    a: &mut [T],
    lda: i32,
    m: &mut i32,
    w: &mut [T],
    z: &mut [T],
    ldz: i32,
    isuppz: &mut [i32],
    work: &mut [T],
    lwork: i32,
    iwork: &mut [i32],
    liwork: i32,
) -> Result<i32, Illegal> {
    let wantz = match jobz.to_ascii_uppercase() {
        b'V' => true,
        b'N' => false,
        _ => return Err(Illegal(1)),
    };
    // 'V' and 'I' are LAPACK's, but clarabel never asks for them.
    if !range.eq_ignore_ascii_case(&b'A') {
        return Err(Illegal(2));
    }
    let t = tri(uplo, 3)?;
    let nu = nonneg(n, 4)?;
    let lda = lead(lda, nu, 6)?;
    let ldz = match usize::try_from(ldz) {
        Ok(l) if l >= 1 && (!wantz || l >= nu) => l,
        _ => return Err(Illegal(15)),
    };
    let lwmin = if nu <= 1 { 1 } else { 26 * nu };
    let liwmin = if nu <= 1 { 1 } else { 10 * nu };
    covers(work.len(), 1, 17)?;
    covers(iwork.len(), 1, 19)?;
    work[0] = T::from_i32(size(lwmin));
    iwork[0] = size(liwmin);
    let query = lwork == -1 || liwork == -1;
    if !query && (lwork < 0 || (lwork as usize) < lwmin) {
        return Err(Illegal(18));
    }
    if !query && (liwork < 0 || (liwork as usize) < liwmin) {
        return Err(Illegal(20));
    }
    if query {
        return Ok(0);
    }
    *m = 0;
    if nu == 0 {
        return Ok(0);
    }
    covers(a.len(), extent(n, n, lda as i32), 5)?;
    covers(w.len(), nu, 13)?;
    if wantz {
        covers(z.len(), extent(n, n, ldz as i32), 14)?;
        covers(isuppz.len(), 2 * nu, 16)?;
    }
    let av = view(a, nu, nu, lda);
    // faer reads the lower triangle; the upper one is the lower of A^T.
    let lower = if t == Tri::Lower { av } else { av.transpose() };
    for j in 0..nu {
        for i in j..nu {
            if !lower[(i, j)].finite() {
                return Ok(1);
            }
        }
    }
    let compute = if wantz {
        ComputeEigenvectors::Yes
    } else {
        ComputeEigenvectors::No
    };
    let mut buf = MemBuffer::new(self_adjoint_evd_scratch::<T>(
        nu,
        compute,
        Par::Seq,
        Default::default(),
    ));
    let s = faer::diag::DiagMut::from_slice_mut(&mut w[..nu]);
    let u = wantz.then(|| view_mut(z, nu, nu, ldz));
    if self_adjoint_evd(
        lower,
        s,
        u,
        Par::Seq,
        MemStack::new(&mut buf),
        Default::default(),
    )
    .is_err()
    {
        return Ok(1);
    }
    *m = n;
    if wantz {
        for j in 0..nu {
            let col = &z[j * ldz..j * ldz + nu];
            let first = col.iter().position(|v| !is_zero(*v)).unwrap_or(0);
            let last = col.iter().rposition(|v| !is_zero(*v)).unwrap_or(nu - 1);
            isuppz[2 * j] = size(first + 1);
            isuppz[2 * j + 1] = size(last + 1);
        }
    }
    Ok(0)
}

/// `dpotrf`: Cholesky factor of the symmetric `n x n` matrix in the `uplo`
/// triangle of `a`, in place (`A = L L^T` with `L` lower, or `A = U^T U`).
/// `Ok(i > 0)`: the leading minor of order `i` is not positive definite (a
/// NaN pivot counts as not positive); the factorization stopped there.
pub fn potrf<T: Real>(uplo: u8, n: i32, a: &mut [T], lda: i32) -> Result<i32, Illegal> {
    let t = tri(uplo, 1)?;
    let nu = nonneg(n, 2)?;
    let lda = lead(lda, nu, 4)?;
    if nu == 0 {
        return Ok(0);
    }
    covers(a.len(), extent(n, n, lda as i32), 3)?;
    // faer's in-place factorization uses the strictly upper triangle of its
    // matrix as scratch; LAPACK leaves the triangle `uplo` does not name
    // untouched (clarabel relies on it: its factor's other half stays zero).
    // So factor a copy of the named triangle and write that triangle back.
    let at = |i: usize, j: usize| match t {
        Tri::Lower => i + j * lda,
        Tri::Upper => j + i * lda,
    };
    let mut l =
        faer::Mat::<T>::from_fn(nu, nu, |i, j| if i >= j { a[at(i, j)] } else { T::zero() });
    let mut buf = MemBuffer::new(cholesky_in_place_scratch::<T>(
        nu,
        Par::Seq,
        Default::default(),
    ));
    let out = cholesky_in_place(
        l.as_mut(),
        Default::default(),
        Par::Seq,
        MemStack::new(&mut buf),
        Default::default(),
    );
    // On failure the triangle holds the partial factor, as in LAPACK (whose
    // partial values differ in detail: callers only read `info` then).
    for j in 0..nu {
        for i in j..nu {
            a[at(i, j)] = l[(i, j)];
        }
    }
    match out {
        Ok(_) => Ok(0),
        Err(LltError::NonPositivePivot { index }) => Ok(size(index + 1)),
    }
}

/// `dpotrs`: solve `A X = B` in place in `b` (`n x nrhs`) with the factor
/// that [`potrf`] left in the `uplo` triangle of `a`.
pub fn potrs<T: Real>(
    uplo: u8,
    n: i32,
    nrhs: i32,
    a: &[T],
    lda: i32,
    b: &mut [T],
    ldb: i32,
) -> Result<i32, Illegal> {
    let t = tri(uplo, 1)?;
    let nu = nonneg(n, 2)?;
    let nr = nonneg(nrhs, 3)?;
    let lda = lead(lda, nu, 5)?;
    let ldb = lead(ldb, nu, 7)?;
    if nu == 0 || nr == 0 {
        return Ok(0);
    }
    covers(a.len(), extent(n, n, lda as i32), 4)?;
    covers(b.len(), extent(n, nrhs, ldb as i32), 6)?;
    let f = view(a, nu, nu, lda);
    let mut x = view_mut(b, nu, nr, ldb);
    let l = if t == Tri::Lower { f } else { f.transpose() };
    ts::solve_lower_triangular_in_place(l, x.as_mut(), Par::Seq);
    ts::solve_upper_triangular_in_place(l.transpose(), x.as_mut(), Par::Seq);
    Ok(0)
}

/// What an SVD computes of `U` (or `V^T`): LAPACK's job characters.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Job {
    None,
    Thin,
    Full,
}

fn job(c: u8, pos: i32) -> Result<Job, Illegal> {
    match c.to_ascii_uppercase() {
        b'N' => Ok(Job::None),
        b'S' => Ok(Job::Thin),
        b'A' => Ok(Job::Full),
        // 'O' (overwrite A) is LAPACK's, but clarabel never asks for it.
        _ => Err(Illegal(pos)),
    }
}

fn compute(j: Job) -> ComputeSvdVectors {
    match j {
        Job::None => ComputeSvdVectors::No,
        Job::Thin => ComputeSvdVectors::Thin,
        Job::Full => ComputeSvdVectors::Full,
    }
}

/// The SVD both `dgesdd` and `dgesvd` compute, after their own checks:
/// `s` descending and non-negative, `U` (`m x m` or `m x min(m,n)`) and
/// `V^T` (`n x n` or `min(m,n) x n`). `a_pos` is the position of `A` in the
/// caller's argument list, named when `A` holds a NaN.
fn svd_common<T: Real>(
    ju: Job,
    jv: Job,
    m: usize,
    n: usize,
    a: &[T],
    lda: usize,
    a_pos: i32,
    s: &mut [T],
    u: &mut [T],
    ldu: usize,
    vt: &mut [T],
    ldvt: usize,
) -> Result<i32, Illegal> {
    let mn = m.min(n);
    let av = view(a, m, n, lda);
    let mut infinite = false;
    for j in 0..n {
        for i in 0..m {
            let v = av[(i, j)];
            if !v.finite() {
                if v.nan() {
                    return Err(Illegal(a_pos));
                }
                infinite = true;
            }
        }
    }
    if infinite {
        return Ok(1);
    }
    let ucols = if ju == Job::Full { m } else { mn };
    let vrows = if jv == Job::Full { n } else { mn };
    let uv = (ju != Job::None).then(|| view_mut(u, m, ucols, ldu));
    // V^T is stored; faer writes V, which is V^T's transposed view.
    let vv = (jv != Job::None).then(|| view_mut(vt, vrows, n, ldvt).transpose_mut());
    let req = svd_scratch::<T>(m, n, compute(ju), compute(jv), Par::Seq, Default::default());
    let mut buf = MemBuffer::new(req);
    let sd = faer::diag::DiagMut::from_slice_mut(&mut s[..mn]);
    match svd(
        av,
        sd,
        uv,
        vv,
        Par::Seq,
        MemStack::new(&mut buf),
        Default::default(),
    ) {
        Ok(()) => Ok(0),
        Err(_) => Ok(1),
    }
}

/// `dgesdd`: SVD of the `m x n` matrix `a`; `jobz` N, S or A (not O).
pub fn gesdd<T: Real>(
    jobz: u8,
    m: i32,
    n: i32,
    a: &mut [T],
    lda: i32,
    s: &mut [T],
    u: &mut [T],
    ldu: i32,
    vt: &mut [T],
    ldvt: i32,
    work: &mut [T],
    lwork: i32,
) -> Result<i32, Illegal> {
    let j = job(jobz, 1)?;
    let (mu, nu) = (nonneg(m, 2)?, nonneg(n, 3)?);
    let lda = lead(lda, mu, 5)?;
    let (mn, mx) = (mu.min(nu), mu.max(nu));
    let ldu = match usize::try_from(ldu) {
        Ok(l) if l >= 1 && (j == Job::None || l >= mu) => l,
        _ => return Err(Illegal(8)),
    };
    let ldvt = match usize::try_from(ldvt) {
        Ok(l)
            if l >= 1
                && match j {
                    Job::Full => l >= nu,
                    Job::Thin => l >= mn,
                    Job::None => true,
                } =>
        {
            l
        }
        _ => return Err(Illegal(10)),
    };
    let minwrk = if mn == 0 {
        1
    } else if j == Job::None {
        3 * mn + mx.max(7 * mn)
    } else {
        4 * mn * mn + 6 * mn + mx
    };
    covers(work.len(), 1, 11)?;
    work[0] = T::from_i32(size(minwrk));
    if lwork == -1 {
        return Ok(0);
    }
    if lwork < 0 || (lwork as usize) < minwrk {
        return Err(Illegal(12));
    }
    if mn == 0 {
        return Ok(0);
    }
    covers(a.len(), extent(m, n, lda as i32), 4)?;
    covers(s.len(), mn, 6)?;
    let (ucols, vrows) = match j {
        Job::Full => (mu, nu),
        _ => (mn, mn),
    };
    if j != Job::None {
        covers(u.len(), extent(m, ucols as i32, ldu as i32), 7)?;
        covers(vt.len(), extent(vrows as i32, n, ldvt as i32), 9)?;
    }
    svd_common(j, j, mu, nu, a, lda, 4, s, u, ldu, vt, ldvt)
}

/// `dgesvd`: SVD of the `m x n` matrix `a`; `jobu`, `jobvt` N, S or A (not O).
pub fn gesvd<T: Real>(
    jobu: u8,
    jobvt: u8,
    m: i32,
    n: i32,
    a: &mut [T],
    lda: i32,
    s: &mut [T],
    u: &mut [T],
    ldu: i32,
    vt: &mut [T],
    ldvt: i32,
    work: &mut [T],
    lwork: i32,
) -> Result<i32, Illegal> {
    let ju = job(jobu, 1)?;
    let jv = job(jobvt, 2)?;
    let (mu, nu) = (nonneg(m, 3)?, nonneg(n, 4)?);
    let lda = lead(lda, mu, 6)?;
    let (mn, mx) = (mu.min(nu), mu.max(nu));
    let ldu = match usize::try_from(ldu) {
        Ok(l) if l >= 1 && (ju == Job::None || l >= mu) => l,
        _ => return Err(Illegal(9)),
    };
    let ldvt = match usize::try_from(ldvt) {
        Ok(l)
            if l >= 1
                && match jv {
                    Job::Full => l >= nu,
                    Job::Thin => l >= mn,
                    Job::None => true,
                } =>
        {
            l
        }
        _ => return Err(Illegal(11)),
    };
    let minwrk = if mn == 0 {
        1
    } else {
        (3 * mn + mx).max(5 * mn)
    };
    covers(work.len(), 1, 12)?;
    work[0] = T::from_i32(size(minwrk));
    if lwork == -1 {
        return Ok(0);
    }
    if lwork < 0 || (lwork as usize) < minwrk {
        return Err(Illegal(13));
    }
    if mn == 0 {
        return Ok(0);
    }
    covers(a.len(), extent(m, n, lda as i32), 5)?;
    covers(s.len(), mn, 7)?;
    if ju != Job::None {
        let ucols = if ju == Job::Full { mu } else { mn };
        covers(u.len(), extent(m, ucols as i32, ldu as i32), 8)?;
    }
    if jv != Job::None {
        let vrows = if jv == Job::Full { nu } else { mn };
        covers(vt.len(), extent(vrows as i32, n, ldvt as i32), 10)?;
    }
    svd_common(ju, jv, mu, nu, a, lda, 5, s, u, ldu, vt, ldvt)
}

/// `dgesv`: `A = P L U` with partial pivoting, in place in `a` (unit lower
/// `L` below the diagonal, `U` on and above it, row interchanges in `ipiv`,
/// 1-based), then `X = A^{-1} B` in place in `b`. `Ok(i > 0)`: `U(i,i)` is
/// exactly zero, the factor is complete and `b` is left unchanged.
pub fn gesv<T: Real>(
    n: i32,
    nrhs: i32,
    a: &mut [T],
    lda: i32,
    ipiv: &mut [i32],
    b: &mut [T],
    ldb: i32,
) -> Result<i32, Illegal> {
    let nu = nonneg(n, 1)?;
    let nr = nonneg(nrhs, 2)?;
    let lda = lead(lda, nu, 4)?;
    let ldb = lead(ldb, nu, 7)?;
    if nu == 0 {
        return Ok(0);
    }
    covers(a.len(), extent(n, n, lda as i32), 3)?;
    covers(ipiv.len(), nu, 5)?;
    if nr > 0 {
        covers(b.len(), extent(n, nrhs, ldb as i32), 6)?;
    }
    let mut fwd = vec![0usize; nu];
    let mut inv = vec![0usize; nu];
    let mut buf = MemBuffer::new(lu_in_place_scratch::<usize, T>(
        nu,
        nu,
        Par::Seq,
        Default::default(),
    ));
    let order: Vec<usize> = {
        let (_, p) = lu_in_place(
            view_mut(a, nu, nu, lda),
            &mut fwd,
            &mut inv,
            Par::Seq,
            MemStack::new(&mut buf),
            Default::default(),
        );
        p.arrays().0.to_vec()
    };
    // Row `i` of P A is row `order[i]` of A: write it as LAPACK's sequence of
    // interchanges (row i with row ipiv[i] >= i, applied in turn).
    let mut at: Vec<usize> = (0..nu).collect(); // original row now at position k
    let mut pos: Vec<usize> = (0..nu).collect(); // position of original row r
    for i in 0..nu {
        let j = pos[order[i]];
        ipiv[i] = size(j + 1);
        at.swap(i, j);
        pos[at[i]] = i;
        pos[at[j]] = j;
    }
    for i in 0..nu {
        if is_zero(a[i * lda + i]) {
            return Ok(size(i + 1));
        }
    }
    if nr == 0 {
        return Ok(0);
    }
    let mut x = view_mut(b, nu, nr, ldb);
    for i in 0..nu {
        let j = ipiv[i] as usize - 1;
        if j != i {
            for c in 0..nr {
                let (p, q) = (x[(i, c)], x[(j, c)]);
                x[(i, c)] = q;
                x[(j, c)] = p;
            }
        }
    }
    let f = view(a, nu, nu, lda);
    ts::solve_unit_lower_triangular_in_place(f, x.as_mut(), Par::Seq);
    ts::solve_upper_triangular_in_place(f, x.as_mut(), Par::Seq);
    Ok(0)
}
