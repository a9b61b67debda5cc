//! Shared helpers: column-major matrices with padded leading dimensions whose
//! padding holds a sentinel (so a test sees any read or write outside the
//! matrix), naive references, and thin callers of the exported symbols with
//! the argument conventions clarabel uses.
#![allow(dead_code)]

use proptest::prelude::*;

/// The padding value: any write to it, or any use of it in a result, shows.
pub const PAD: f64 = 7.0e300;

/// A column-major `rows x cols` matrix with leading dimension `ld >= rows`.
#[derive(Debug, Clone)]
pub struct M {
    pub rows: usize,
    pub cols: usize,
    pub ld: usize,
    pub data: Vec<f64>,
}

impl M {
    pub fn new(rows: usize, cols: usize, ld: usize, f: impl Fn(usize, usize) -> f64) -> Self {
        assert!(ld >= rows.max(1));
        let mut data = vec![PAD; ld * cols.max(1)];
        for j in 0..cols {
            for i in 0..rows {
                data[j * ld + i] = f(i, j);
            }
        }
        Self {
            rows,
            cols,
            ld,
            data,
        }
    }

    pub fn at(&self, i: usize, j: usize) -> f64 {
        self.data[j * self.ld + i]
    }

    pub fn set(&mut self, i: usize, j: usize, v: f64) {
        self.data[j * self.ld + i] = v;
    }

    /// The padding rows are untouched.
    pub fn padding_intact(&self) -> bool {
        (0..self.cols).all(|j| {
            (self.rows..self.ld).all(|i| self.data[j * self.ld + i].to_bits() == PAD.to_bits())
        })
    }

    pub fn t(&self) -> M {
        M::new(self.cols, self.rows, self.cols.max(1), |i, j| self.at(j, i))
    }

    pub fn ld_i32(&self) -> i32 {
        self.ld as i32
    }
}

/// `A B` (naive triple loop).
pub fn mul(a: &M, b: &M) -> M {
    assert_eq!(a.cols, b.rows);
    M::new(a.rows, b.cols, a.rows.max(1), |i, j| {
        (0..a.cols).map(|l| a.at(i, l) * b.at(l, j)).sum()
    })
}

pub fn max_abs_diff(a: &M, b: &M) -> f64 {
    assert_eq!((a.rows, a.cols), (b.rows, b.cols));
    let mut d: f64 = 0.0;
    for j in 0..a.cols {
        for i in 0..a.rows {
            d = d.max((a.at(i, j) - b.at(i, j)).abs());
        }
    }
    d
}

pub fn max_abs(a: &M) -> f64 {
    let mut d: f64 = 0.0;
    for j in 0..a.cols {
        for i in 0..a.rows {
            d = d.max(a.at(i, j).abs());
        }
    }
    d
}

/// Entries in [-2, 2].
pub fn entries(len: usize) -> impl Strategy<Value = Vec<f64>> {
    proptest::collection::vec(-2.0f64..2.0, len)
}

/// A `rows x cols` matrix from `v` (row-major reading of `v`), with `pad`
/// extra rows of leading dimension.
pub fn from_vec(rows: usize, cols: usize, pad: usize, v: &[f64]) -> M {
    M::new(rows, cols, rows.max(1) + pad, |i, j| {
        v[(i * cols + j) % v.len().max(1)]
    })
}

/// A symmetric positive definite `n x n` matrix `G G^T + n I`.
pub fn spd(n: usize, pad: usize, v: &[f64]) -> M {
    let g = from_vec(n, n, 0, v);
    let ggt = mul(&g, &g.t());
    M::new(n, n, n.max(1) + pad, |i, j| {
        ggt.at(i, j) + if i == j { n as f64 } else { 0.0 }
    })
}

/// A symmetric matrix from `v`, padded.
pub fn sym(n: usize, pad: usize, v: &[f64]) -> M {
    let g = from_vec(n, n, 0, v);
    M::new(n, n, n.max(1) + pad, |i, j| g.at(i, j) + g.at(j, i))
}

/// Put NaN in the triangle `uplo` does not name (strictly), so that reading
/// it shows in the result.
pub fn poison_other_triangle(a: &mut M, uplo: u8) {
    for j in 0..a.cols {
        for i in 0..a.rows {
            let other = if uplo == b'U' { i > j } else { i < j };
            if other {
                a.set(i, j, f64::NAN);
            }
        }
    }
}

/// Put `v` in the triangle `uplo` does not name (strictly).
pub fn fill_other_triangle(a: &mut M, uplo: u8, v: f64) {
    for j in 0..a.cols {
        for i in 0..a.rows {
            let other = if uplo == b'U' { i > j } else { i < j };
            if other {
                a.set(i, j, v);
            }
        }
    }
}

/// The symmetric matrix that the `uplo` triangle of `a` stores.
pub fn symmetrize(a: &M, uplo: u8) -> M {
    M::new(a.rows, a.rows, a.rows.max(1), |i, j| {
        let (r, c) = if (uplo == b'U') == (i <= j) {
            (i, j)
        } else {
            (j, i)
        };
        a.at(r, c)
    })
}

/// A flag character as the ABI passes it.
pub fn c(ch: u8) -> std::ffi::c_char {
    ch as std::ffi::c_char
}

/// `dsyevr_` with `range = 'A'` as clarabel calls it: a workspace query,
/// then the solve. Returns (info, m, eigenvalues, Z).
pub fn syevr(jobz: u8, uplo: u8, a: &mut M) -> (i32, i32, Vec<f64>, M, Vec<i32>) {
    let n = a.rows as i32;
    let mut w = vec![0.0; a.rows];
    let mut z = M::new(a.rows, a.rows, a.rows.max(1), |_, _| 0.0);
    let mut isuppz = vec![0i32; 2 * a.rows.max(1)];
    let mut work = vec![0.0f64];
    let mut iwork = vec![0i32];
    let (mut m, mut info) = (0i32, 0i32);
    let zero = 0.0;
    let izero = 0;
    for pass in 0..2 {
        let (lwork, liwork) = if pass == 0 {
            (-1, -1)
        } else {
            let l = work[0] as usize;
            let li = iwork[0] as usize;
            work.resize(l, 0.0);
            iwork.resize(li, 0);
            (l as i32, li as i32)
        };
        unsafe {
            dense_lapack::dsyevr_(
                &c(jobz),
                &c(b'A'),
                &c(uplo),
                &n,
                a.data.as_mut_ptr(),
                &a.ld_i32(),
                &zero,
                &zero,
                &izero,
                &izero,
                &-1.0,
                &mut m,
                w.as_mut_ptr(),
                z.data.as_mut_ptr(),
                &(z.ld as i32),
                isuppz.as_mut_ptr(),
                work.as_mut_ptr(),
                &lwork,
                iwork.as_mut_ptr(),
                &liwork,
                &mut info,
            );
        }
        if info != 0 {
            break;
        }
    }
    (info, m, w, z, isuppz)
}
