//! The BLAS and LAPACK routines that clarabel's PSD cone calls, exported with
//! the Fortran ABI that `blas-sys` and `lapack-sys` declare, and implemented in
//! pure Rust on [faer]. Linking this crate is all a build needs: no system
//! BLAS, LAPACK, Fortran runtime or C compiler.
//!
//! # ABI
//! Every argument is a pointer; integers are 32-bit (`c_int`); flag characters
//! are single bytes compared case-insensitively, as LAPACK's `LSAME` does; no
//! hidden string-length arguments are read. Matrices are column-major with a
//! leading dimension that may exceed the row count.
//!
//! # What is implemented
//! | symbol | operation | supported flags |
//! |---|---|---|
//! | `dgemm_` | `C = alpha op(A) op(B) + beta C` | `trans` N, T, C |
//! | `dgemv_` | `y = alpha op(A) x + beta y` | `trans` N, T, C; any nonzero `inc` |
//! | `dsymv_` | `y = alpha A x + beta y`, `A` symmetric from one triangle | `uplo` U, L; any nonzero `inc` |
//! | `dsyrk_` | `C = alpha op(A) op(A)^T + beta C` on one triangle | `uplo` U, L; `trans` N, T, C |
//! | `dsyr2k_` | `C = alpha (op(A) op(B)^T + op(B) op(A)^T) + beta C` on one triangle | `uplo` U, L; `trans` N, T, C |
//! | `dsyevr_` | all eigenvalues (ascending) and optionally eigenvectors | `jobz` N, V; `range` A only; `uplo` U, L |
//! | `dpotrf_` | Cholesky `A = L L^T` or `U^T U` in place | `uplo` U, L |
//! | `dpotrs_` | solve with a `dpotrf_` factor | `uplo` U, L |
//! | `dgesdd_` | SVD `A = U S V^T` | `jobz` N, S, A (not O) |
//! | `dgesvd_` | SVD `A = U S V^T` | `jobu`/`jobvt` N, S, A (not O) |
//! | `dgesv_` | LU with partial pivoting and solve | — |
//!
//! The `s` (single precision) variants of the same routines are exported too:
//! clarabel instantiates its dense-algebra traits for `f32` as well.
//!
//! # Conventions kept from LAPACK
//! * `beta = 0` means `C` (or `y`) is not read, so NaN on input does not
//!   propagate; `alpha = 0` means `A` and `B` are not read.
//! * Only the triangle that `uplo` names is read (`dsymv_`, `dsyevr_`,
//!   `dpotrf_`, `dpotrs_`) or written (`dsyrk_`, `dsyr2k_`, `dpotrf_`).
//! * Workspace queries: `lwork = -1` (and `liwork = -1`) write LAPACK's
//!   minimum sizes into `work[0]` (`iwork[0]`) and return; a smaller workspace
//!   than that minimum is refused with `info < 0`, as LAPACK refuses it. The
//!   workspace itself is not used: faer allocates its own.
//! * `info = -i` names the illegal argument `i` (1-based), after printing
//!   LAPACK's `XERBLA` message to stderr; `info > 0` reports a numerical
//!   failure: the order of the leading minor that is not positive definite
//!   (`dpotrf_`, with a NaN pivot counted as not positive, as LAPACK does),
//!   the exactly-zero pivot of `U` (`dgesv_`), or no convergence (`dsyevr_`,
//!   `dgesdd_`, `dgesvd_`).
//! * A BLAS routine has no `info`: an illegal argument prints the `XERBLA`
//!   message and aborts the process rather than return a wrong answer.
//!
//! # Where this departs from LAPACK
//! * Argument values clarabel never passes and this crate does not implement
//!   are refused with `info < 0` instead of computed: `dsyevr_` with
//!   `range` V or I (`info = -2`), `dgesdd_` with `jobz = 'O'` (`-1`),
//!   `dgesvd_` with `jobu` or `jobvt` O (`-1` or `-2`).
//! * `dsyevr_` ignores `abstol` (faer converges to full working accuracy,
//!   which is what `abstol <= 0` asks of LAPACK) and reports a NaN or
//!   infinite entry of the referenced triangle as `info = 1`: LAPACK leaves
//!   that case undefined, and a decomposition of it would be meaningless.
//!   `isuppz` gives the first and last nonzero row of each eigenvector.
//! * Both SVDs report a NaN entry of `A` as the illegal argument `A`
//!   (`info = -4` in `dgesdd_`, as LAPACK 3.x does; `-5` in `dgesvd_`), and
//!   an infinite entry as `info = 1` (no convergence).
//! * `dgesv_` on an exactly singular matrix returns LAPACK's `info`, but the
//!   entries of `L` below a zero pivot are what faer computed (LAPACK leaves
//!   them unscaled); `b` is left unchanged.
//! * Results agree with reference LAPACK to rounding, not bit for bit.

#![deny(clippy::float_cmp)]
#![allow(clippy::too_many_arguments)]

mod args;
pub mod blas;
mod ffi;
pub mod lapack;

pub use args::{Illegal, Real};
pub use ffi::*;
