//! Argument decoding shared by every routine: the element types, LAPACK's
//! flag characters, illegal-argument reports, and strided column-major views
//! over caller memory.

use faer::traits::RealField;
use faer::{MatMut, MatRef};

/// The element types the routines are instantiated for: `f64` (`d` symbols)
/// and `f32` (`s` symbols).
pub trait Real: RealField + Copy {
    /// `true` unless NaN or infinite.
    fn finite(self) -> bool;
    /// `true` for NaN.
    fn nan(self) -> bool;
    /// The value `v` (exact for the small integers of workspace sizes).
    fn from_i32(v: i32) -> Self;
}

impl Real for f64 {
    fn finite(self) -> bool {
        self.is_finite()
    }
    fn nan(self) -> bool {
        self.is_nan()
    }
    fn from_i32(v: i32) -> Self {
        f64::from(v)
    }
}

impl Real for f32 {
    fn finite(self) -> bool {
        self.is_finite()
    }
    fn nan(self) -> bool {
        self.is_nan()
    }
    fn from_i32(v: i32) -> Self {
        v as f32
    }
}

/// BLAS and LAPACK test exact zeros and ones (`beta = 0` means "do not read
/// `C`"), so these comparisons are exact by design.
#[allow(clippy::float_cmp)]
pub(crate) fn is_zero<T: Real>(x: T) -> bool {
    x == T::zero()
}

#[allow(clippy::float_cmp)]
pub(crate) fn is_one<T: Real>(x: T) -> bool {
    x == T::one()
}

/// An illegal argument: its 1-based position in the routine's argument list,
/// reported by LAPACK as `info = -position`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Illegal(pub i32);

impl Illegal {
    /// LAPACK's `info` for this argument.
    pub fn info(self) -> i32 {
        -self.0
    }
}

/// `op(A)`: `A` itself or its transpose (`C`, the conjugate transpose, is the
/// transpose for real matrices, as in reference BLAS).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Op {
    /// `N`.
    No,
    /// `T` or `C`.
    Trans,
}

/// Which triangle of a symmetric matrix is referenced.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tri {
    /// `U`.
    Upper,
    /// `L`.
    Lower,
}

/// Decode `trans` (argument `pos`), case-insensitively like LAPACK's `LSAME`.
pub(crate) fn op(c: u8, pos: i32) -> Result<Op, Illegal> {
    match c.to_ascii_uppercase() {
        b'N' => Ok(Op::No),
        b'T' | b'C' => Ok(Op::Trans),
        _ => Err(Illegal(pos)),
    }
}

/// Decode `uplo` (argument `pos`).
pub(crate) fn tri(c: u8, pos: i32) -> Result<Tri, Illegal> {
    match c.to_ascii_uppercase() {
        b'U' => Ok(Tri::Upper),
        b'L' => Ok(Tri::Lower),
        _ => Err(Illegal(pos)),
    }
}

/// `Err(Illegal(pos))` unless `v >= 0`.
pub(crate) fn nonneg(v: i32, pos: i32) -> Result<usize, Illegal> {
    usize::try_from(v).map_err(|_| Illegal(pos))
}

/// `Err(Illegal(pos))` unless the leading dimension `ld >= max(1, rows)`.
pub(crate) fn lead(ld: i32, rows: usize, pos: i32) -> Result<usize, Illegal> {
    match usize::try_from(ld) {
        Ok(l) if l >= rows.max(1) => Ok(l),
        _ => Err(Illegal(pos)),
    }
}

/// Elements spanned by a `rows x cols` column-major matrix with leading
/// dimension `ld` (0 when empty). Negative or inconsistent inputs give 0 or a
/// conservative value; the routines check them before any memory is read.
pub fn extent(rows: i32, cols: i32, ld: i32) -> usize {
    if rows <= 0 || cols <= 0 {
        return 0;
    }
    let (rows, cols, ld) = (rows as usize, cols as usize, (ld.max(rows)) as usize);
    (cols - 1).saturating_mul(ld).saturating_add(rows)
}

/// Elements spanned by a vector of `n` entries with increment `inc`.
pub fn vec_extent(n: i32, inc: i32) -> usize {
    if n <= 0 {
        return 0;
    }
    (n as usize - 1)
        .saturating_mul(inc.unsigned_abs() as usize)
        .saturating_add(1)
}

/// `Err(Illegal(pos))` unless `len >= need`: a caller slice shorter than the
/// matrix its dimensions describe.
pub(crate) fn covers(len: usize, need: usize, pos: i32) -> Result<(), Illegal> {
    if len >= need {
        Ok(())
    } else {
        Err(Illegal(pos))
    }
}

/// A `rows x cols` view of `a` with leading dimension `ld` (checked by the
/// caller: `a` covers it and `ld >= rows`).
pub(crate) fn view<T: Real>(a: &[T], rows: usize, cols: usize, ld: usize) -> MatRef<'_, T> {
    if rows == 0 || cols == 0 {
        return MatRef::from_column_major_slice(&a[..0], 0, 0);
    }
    MatRef::from_column_major_slice_with_stride(a, rows, cols, ld)
}

/// Mutable counterpart of [`view`].
pub(crate) fn view_mut<T: Real>(a: &mut [T], rows: usize, cols: usize, ld: usize) -> MatMut<'_, T> {
    if rows == 0 || cols == 0 {
        return MatMut::from_column_major_slice_mut(&mut a[..0], 0, 0);
    }
    MatMut::from_column_major_slice_with_stride_mut(a, rows, cols, ld)
}

/// The `n` entries of a strided vector, in order (BLAS: a negative increment
/// walks the storage backwards).
pub(crate) fn gather<T: Real>(x: &[T], n: usize, inc: i32) -> Vec<T> {
    let step = inc.unsigned_abs() as usize;
    (0..n)
        .map(|i| {
            let k = if inc > 0 { i } else { n - 1 - i };
            x[k * step]
        })
        .collect()
}

/// Write `v` back into the strided vector `x` (inverse of [`gather`]).
pub(crate) fn scatter<T: Real>(v: &[T], x: &mut [T], inc: i32) {
    let n = v.len();
    let step = inc.unsigned_abs() as usize;
    for (i, &value) in v.iter().enumerate() {
        let k = if inc > 0 { i } else { n - 1 - i };
        x[k * step] = value;
    }
}

/// `C[tri] *= beta` (or `= 0` when `beta = 0`, without reading `C`) on the
/// triangle `t` of the `n x n` matrix `c`, or on the whole matrix when `t`
/// is `None`.
pub(crate) fn scale<T: Real>(
    c: &mut [T],
    rows: usize,
    cols: usize,
    ld: usize,
    t: Option<Tri>,
    beta: T,
) {
    if is_one(beta) {
        return;
    }
    for j in 0..cols {
        let (lo, hi) = match t {
            None => (0, rows),
            Some(Tri::Upper) => (0, (j + 1).min(rows)),
            Some(Tri::Lower) => (j.min(rows), rows),
        };
        for x in &mut c[j * ld + lo..j * ld + hi] {
            *x = if is_zero(beta) { T::zero() } else { *x * beta };
        }
    }
}

/// Print reference LAPACK's `XERBLA` message for `routine` and argument `pos`.
pub(crate) fn xerbla(routine: &str, pos: i32) {
    eprintln!(" ** On entry to {routine} parameter number {pos:2} had an illegal value");
}
