//! The exported symbols (`dgemm_`, ..., and their `s` twins). Each reads its
//! scalar arguments, turns the array pointers into slices of exactly the
//! extent the dimensions describe, and calls the routine in [`crate::blas`]
//! or [`crate::lapack`]. An illegal argument prints LAPACK's `XERBLA` message;
//! a LAPACK routine then returns `info = -i`, a BLAS routine (which has no
//! `info`) aborts the process rather than return a wrong answer.
//!
//! # Safety
//! The callers' contract is reference BLAS/LAPACK's: every pointer is valid
//! for the extent its dimension arguments describe, output arrays do not
//! overlap the inputs, and scalar pointers are valid.

use crate::args::{Illegal, extent, vec_extent, xerbla};
use crate::{blas, lapack};
use std::ffi::c_char;
use std::os::raw::c_int;

/// A slice of `len` elements at `p`; empty when `len` is 0 or `p` is null
/// (the routine then reports the array argument if it needed elements).
unsafe fn rd<'a, T>(p: *const T, len: usize) -> &'a [T] {
    if len == 0 || p.is_null() {
        &[]
    } else {
        // SAFETY: the caller's BLAS contract (module docs).
        unsafe { std::slice::from_raw_parts(p, len) }
    }
}

/// Mutable counterpart of [`rd`].
unsafe fn wr<'a, T>(p: *mut T, len: usize) -> &'a mut [T] {
    if len == 0 || p.is_null() {
        &mut []
    } else {
        // SAFETY: the caller's BLAS contract (module docs).
        unsafe { std::slice::from_raw_parts_mut(p, len) }
    }
}

/// A BLAS routine's illegal argument: XERBLA's message, then abort.
fn blas_fail(routine: &str, e: Illegal) -> ! {
    xerbla(routine, e.0);
    std::process::abort()
}

/// A LAPACK routine's `info`.
fn lapack_info(routine: &str, r: Result<i32, Illegal>) -> c_int {
    match r {
        Ok(i) => i,
        Err(e) => {
            xerbla(routine, e.0);
            e.info()
        }
    }
}

/// Rows of `op(A)` stored: `rows` when `trans` is N, else `cols`.
fn stored(trans: c_char, rows: c_int, cols: c_int) -> (c_int, c_int) {
    if (trans as u8).eq_ignore_ascii_case(&b'N') {
        (rows, cols)
    } else {
        (cols, rows)
    }
}

macro_rules! export {
    ($t:ty, $gemm:ident, $gemv:ident, $symv:ident, $syrk:ident, $syr2k:ident,
     $syevr:ident, $potrf:ident, $potrs:ident, $gesdd:ident, $gesvd:ident, $gesv:ident,
     $p:literal) => {
        #[doc = concat!("BLAS `", $p, "GEMM`: see [`blas::gemm`].")]
        ///
        /// # Safety
        /// Reference BLAS's contract (module docs).
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $gemm(
            transa: *const c_char,
            transb: *const c_char,
            m: *const c_int,
            n: *const c_int,
            k: *const c_int,
            alpha: *const $t,
            a: *const $t,
            lda: *const c_int,
            b: *const $t,
            ldb: *const c_int,
            beta: *const $t,
            c: *mut $t,
            ldc: *const c_int,
        ) {
            unsafe {
                let (ta, tb, m, n, k, lda, ldb, ldc) =
                    (*transa, *transb, *m, *n, *k, *lda, *ldb, *ldc);
                let (ra, ca) = stored(ta, m, k);
                let (rb, cb) = stored(tb, k, n);
                let r = blas::gemm(
                    ta as u8,
                    tb as u8,
                    m,
                    n,
                    k,
                    *alpha,
                    rd(a, extent(ra, ca, lda)),
                    lda,
                    rd(b, extent(rb, cb, ldb)),
                    ldb,
                    *beta,
                    wr(c, extent(m, n, ldc)),
                    ldc,
                );
                if let Err(e) = r {
                    blas_fail(concat!($p, "GEMM"), e);
                }
            }
        }

        #[doc = concat!("BLAS `", $p, "GEMV`: see [`blas::gemv`].")]
        ///
        /// # Safety
        /// Reference BLAS's contract (module docs).
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $gemv(
            trans: *const c_char,
            m: *const c_int,
            n: *const c_int,
            alpha: *const $t,
            a: *const $t,
            lda: *const c_int,
            x: *const $t,
            incx: *const c_int,
            beta: *const $t,
            y: *mut $t,
            incy: *const c_int,
        ) {
            unsafe {
                let (t, m, n, lda, incx, incy) = (*trans, *m, *n, *lda, *incx, *incy);
                let (lx, ly) = stored(t, n, m);
                let r = blas::gemv(
                    t as u8,
                    m,
                    n,
                    *alpha,
                    rd(a, extent(m, n, lda)),
                    lda,
                    rd(x, vec_extent(lx, incx)),
                    incx,
                    *beta,
                    wr(y, vec_extent(ly, incy)),
                    incy,
                );
                if let Err(e) = r {
                    blas_fail(concat!($p, "GEMV"), e);
                }
            }
        }

        #[doc = concat!("BLAS `", $p, "SYMV`: see [`blas::symv`].")]
        ///
        /// # Safety
        /// Reference BLAS's contract (module docs).
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $symv(
            uplo: *const c_char,
            n: *const c_int,
            alpha: *const $t,
            a: *const $t,
            lda: *const c_int,
            x: *const $t,
            incx: *const c_int,
            beta: *const $t,
            y: *mut $t,
            incy: *const c_int,
        ) {
            unsafe {
                let (n, lda, incx, incy) = (*n, *lda, *incx, *incy);
                let r = blas::symv(
                    *uplo as u8,
                    n,
                    *alpha,
                    rd(a, extent(n, n, lda)),
                    lda,
                    rd(x, vec_extent(n, incx)),
                    incx,
                    *beta,
                    wr(y, vec_extent(n, incy)),
                    incy,
                );
                if let Err(e) = r {
                    blas_fail(concat!($p, "SYMV"), e);
                }
            }
        }

        #[doc = concat!("BLAS `", $p, "SYRK`: see [`blas::syrk`].")]
        ///
        /// # Safety
        /// Reference BLAS's contract (module docs).
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $syrk(
            uplo: *const c_char,
            trans: *const c_char,
            n: *const c_int,
            k: *const c_int,
            alpha: *const $t,
            a: *const $t,
            lda: *const c_int,
            beta: *const $t,
            c: *mut $t,
            ldc: *const c_int,
        ) {
            unsafe {
                let (t, n, k, lda, ldc) = (*trans, *n, *k, *lda, *ldc);
                let (ra, ca) = stored(t, n, k);
                let r = blas::syrk(
                    *uplo as u8,
                    t as u8,
                    n,
                    k,
                    *alpha,
                    rd(a, extent(ra, ca, lda)),
                    lda,
                    *beta,
                    wr(c, extent(n, n, ldc)),
                    ldc,
                );
                if let Err(e) = r {
                    blas_fail(concat!($p, "SYRK"), e);
                }
            }
        }

        #[doc = concat!("BLAS `", $p, "SYR2K`: see [`blas::syr2k`].")]
        ///
        /// # Safety
        /// Reference BLAS's contract (module docs).
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $syr2k(
            uplo: *const c_char,
            trans: *const c_char,
            n: *const c_int,
            k: *const c_int,
            alpha: *const $t,
            a: *const $t,
            lda: *const c_int,
            b: *const $t,
            ldb: *const c_int,
            beta: *const $t,
            c: *mut $t,
            ldc: *const c_int,
        ) {
            unsafe {
                let (t, n, k, lda, ldb, ldc) = (*trans, *n, *k, *lda, *ldb, *ldc);
                let (ra, ca) = stored(t, n, k);
                let r = blas::syr2k(
                    *uplo as u8,
                    t as u8,
                    n,
                    k,
                    *alpha,
                    rd(a, extent(ra, ca, lda)),
                    lda,
                    rd(b, extent(ra, ca, ldb)),
                    ldb,
                    *beta,
                    wr(c, extent(n, n, ldc)),
                    ldc,
                );
                if let Err(e) = r {
                    blas_fail(concat!($p, "SYR2K"), e);
                }
            }
        }

        #[doc = concat!("LAPACK `", $p, "SYEVR`: see [`lapack::syevr`].")]
        ///
        /// # Safety
        /// Reference LAPACK's contract (module docs). With `jobz = 'N'`, `z`
        /// and `isuppz` are not touched.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $syevr(
            jobz: *const c_char,
            range: *const c_char,
            uplo: *const c_char,
            n: *const c_int,
            a: *mut $t,
            lda: *const c_int,
            _vl: *const $t,
            _vu: *const $t,
            _il: *const c_int,
            _iu: *const c_int,
            _abstol: *const $t,
            m: *mut c_int,
            w: *mut $t,
            z: *mut $t,
            ldz: *const c_int,
            isuppz: *mut c_int,
            work: *mut $t,
            lwork: *const c_int,
            iwork: *mut c_int,
            liwork: *const c_int,
            info: *mut c_int,
        ) {
            unsafe {
                let (jz, n, lda, ldz) = (*jobz as u8, *n, *lda, *ldz);
                let wantz = jz.eq_ignore_ascii_case(&b'V');
                let nz = if wantz { extent(n, n, ldz) } else { 0 };
                let ns = if wantz { 2 * n.max(1) as usize } else { 0 };
                let r = lapack::syevr(
                    jz,
                    *range as u8,
                    *uplo as u8,
                    n,
                    wr(a, extent(n, n, lda)),
                    lda,
                    &mut *m,
                    wr(w, n.max(0) as usize),
                    wr(z, nz),
                    ldz,
                    wr(isuppz, ns),
                    wr(work, 1),
                    *lwork,
                    wr(iwork, 1),
                    *liwork,
                );
                *info = lapack_info(concat!($p, "SYEVR"), r);
            }
        }

        #[doc = concat!("LAPACK `", $p, "POTRF`: see [`lapack::potrf`].")]
        ///
        /// # Safety
        /// Reference LAPACK's contract (module docs).
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $potrf(
            uplo: *const c_char,
            n: *const c_int,
            a: *mut $t,
            lda: *const c_int,
            info: *mut c_int,
        ) {
            unsafe {
                let (n, lda) = (*n, *lda);
                let r = lapack::potrf(*uplo as u8, n, wr(a, extent(n, n, lda)), lda);
                *info = lapack_info(concat!($p, "POTRF"), r);
            }
        }

        #[doc = concat!("LAPACK `", $p, "POTRS`: see [`lapack::potrs`].")]
        ///
        /// # Safety
        /// Reference LAPACK's contract (module docs).
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $potrs(
            uplo: *const c_char,
            n: *const c_int,
            nrhs: *const c_int,
            a: *const $t,
            lda: *const c_int,
            b: *mut $t,
            ldb: *const c_int,
            info: *mut c_int,
        ) {
            unsafe {
                let (n, nrhs, lda, ldb) = (*n, *nrhs, *lda, *ldb);
                let r = lapack::potrs(
                    *uplo as u8,
                    n,
                    nrhs,
                    rd(a, extent(n, n, lda)),
                    lda,
                    wr(b, extent(n, nrhs, ldb)),
                    ldb,
                );
                *info = lapack_info(concat!($p, "POTRS"), r);
            }
        }

        #[doc = concat!("LAPACK `", $p, "GESDD`: see [`lapack::gesdd`].")]
        ///
        /// # Safety
        /// Reference LAPACK's contract (module docs). `iwork` is not used.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $gesdd(
            jobz: *const c_char,
            m: *const c_int,
            n: *const c_int,
            a: *mut $t,
            lda: *const c_int,
            s: *mut $t,
            u: *mut $t,
            ldu: *const c_int,
            vt: *mut $t,
            ldvt: *const c_int,
            work: *mut $t,
            lwork: *const c_int,
            _iwork: *mut c_int,
            info: *mut c_int,
        ) {
            unsafe {
                let (jz, m, n, lda, ldu, ldvt) = (*jobz as u8, *m, *n, *lda, *ldu, *ldvt);
                let mn = m.min(n);
                let (nu, nv) = match jz.to_ascii_uppercase() {
                    b'S' => (extent(m, mn, ldu), extent(mn, n, ldvt)),
                    b'A' => (extent(m, m, ldu), extent(n, n, ldvt)),
                    _ => (0, 0),
                };
                let r = lapack::gesdd(
                    jz,
                    m,
                    n,
                    wr(a, extent(m, n, lda)),
                    lda,
                    wr(s, mn.max(0) as usize),
                    wr(u, nu),
                    ldu,
                    wr(vt, nv),
                    ldvt,
                    wr(work, 1),
                    *lwork,
                );
                *info = lapack_info(concat!($p, "GESDD"), r);
            }
        }

        #[doc = concat!("LAPACK `", $p, "GESVD`: see [`lapack::gesvd`].")]
        ///
        /// # Safety
        /// Reference LAPACK's contract (module docs).
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $gesvd(
            jobu: *const c_char,
            jobvt: *const c_char,
            m: *const c_int,
            n: *const c_int,
            a: *mut $t,
            lda: *const c_int,
            s: *mut $t,
            u: *mut $t,
            ldu: *const c_int,
            vt: *mut $t,
            ldvt: *const c_int,
            work: *mut $t,
            lwork: *const c_int,
            info: *mut c_int,
        ) {
            unsafe {
                let (ju, jv, m, n, lda, ldu, ldvt) =
                    (*jobu as u8, *jobvt as u8, *m, *n, *lda, *ldu, *ldvt);
                let mn = m.min(n);
                let nu = match ju.to_ascii_uppercase() {
                    b'S' => extent(m, mn, ldu),
                    b'A' => extent(m, m, ldu),
                    _ => 0,
                };
                let nv = match jv.to_ascii_uppercase() {
                    b'S' => extent(mn, n, ldvt),
                    b'A' => extent(n, n, ldvt),
                    _ => 0,
                };
                let r = lapack::gesvd(
                    ju,
                    jv,
                    m,
                    n,
                    wr(a, extent(m, n, lda)),
                    lda,
                    wr(s, mn.max(0) as usize),
                    wr(u, nu),
                    ldu,
                    wr(vt, nv),
                    ldvt,
                    wr(work, 1),
                    *lwork,
                );
                *info = lapack_info(concat!($p, "GESVD"), r);
            }
        }

        #[doc = concat!("LAPACK `", $p, "GESV`: see [`lapack::gesv`].")]
        ///
        /// # Safety
        /// Reference LAPACK's contract (module docs).
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $gesv(
            n: *const c_int,
            nrhs: *const c_int,
            a: *mut $t,
            lda: *const c_int,
            ipiv: *mut c_int,
            b: *mut $t,
            ldb: *const c_int,
            info: *mut c_int,
        ) {
            unsafe {
                let (n, nrhs, lda, ldb) = (*n, *nrhs, *lda, *ldb);
                let r = lapack::gesv(
                    n,
                    nrhs,
                    wr(a, extent(n, n, lda)),
                    lda,
                    wr(ipiv, n.max(0) as usize),
                    wr(b, extent(n, nrhs, ldb)),
                    ldb,
                );
                *info = lapack_info(concat!($p, "GESV"), r);
            }
        }
    };
}

export!(
    f64, dgemm_, dgemv_, dsymv_, dsyrk_, dsyr2k_, dsyevr_, dpotrf_, dpotrs_, dgesdd_, dgesvd_,
    dgesv_, "D"
);
export!(
    f32, sgemm_, sgemv_, ssymv_, ssyrk_, ssyr2k_, ssyevr_, spotrf_, spotrs_, sgesdd_, sgesvd_,
    sgesv_, "S"
);
