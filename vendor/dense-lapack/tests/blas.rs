//! The BLAS symbols against naive references on random shapes: every `trans`
//! and `uplo`, leading dimensions larger than the row count (whose padding
//! must stay untouched), `alpha`/`beta` including the 0 and 1 special cases,
//! vector increments other than 1, and the calls clarabel makes.

// BLAS signatures and index arithmetic, mirrored on purpose.
#![allow(clippy::too_many_arguments, clippy::needless_range_loop)]

mod common;

use common::*;
use dense_lapack::Illegal;
use proptest::prelude::*;

const TOL: f64 = 1e-12;

fn op(a: &M, t: u8) -> M {
    if t == b'N' || t == b'n' {
        a.clone()
    } else {
        a.t()
    }
}

fn call_gemm(
    ta: u8,
    tb: u8,
    m: usize,
    n: usize,
    k: usize,
    alpha: f64,
    a: &M,
    b: &M,
    beta: f64,
    cm: &mut M,
) {
    unsafe {
        dense_lapack::dgemm_(
            &c(ta),
            &c(tb),
            &(m as i32),
            &(n as i32),
            &(k as i32),
            &alpha,
            a.data.as_ptr(),
            &a.ld_i32(),
            b.data.as_ptr(),
            &b.ld_i32(),
            &beta,
            cm.data.as_mut_ptr(),
            &cm.ld_i32(),
        );
    }
}

/// alpha and beta drawn from the special values and a generic one.
fn scalar() -> impl Strategy<Value = f64> {
    prop_oneof![Just(0.0), Just(1.0), Just(-1.0), -3.0f64..3.0]
}

fn trans() -> impl Strategy<Value = u8> {
    prop_oneof![Just(b'N'), Just(b'T'), Just(b'C'), Just(b'n'), Just(b't')]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn dgemm_matches_the_triple_loop(
        ta in trans(), tb in trans(), m in 0usize..7, n in 0usize..7, k in 0usize..7,
        pa in 0usize..3, pb in 0usize..3, pc in 0usize..3,
        alpha in scalar(), beta in scalar(), v in entries(64),
    ) {
        let (ra, ca) = if ta == b'N' || ta == b'n' { (m, k) } else { (k, m) };
        let (rb, cb) = if tb == b'N' || tb == b'n' { (k, n) } else { (n, k) };
        let a = from_vec(ra, ca, pa, &v);
        let b = from_vec(rb, cb, pb, &v[7..]);
        let c0 = from_vec(m, n, pc, &v[13..]);
        let mut cm = c0.clone();
        call_gemm(ta, tb, m, n, k, alpha, &a, &b, beta, &mut cm);
        let ab = mul(&op(&a, ta), &op(&b, tb));
        let want = M::new(m, n, m.max(1), |i, j| alpha * ab.at(i, j) + beta * c0.at(i, j));
        prop_assert!(max_abs_diff(&cm, &want) <= TOL, "{:?} vs {:?}", cm, want);
        prop_assert!(cm.padding_intact());
    }

    #[test]
    fn dgemv_matches_the_naive_product_for_any_increment(
        t in trans(), m in 0usize..7, n in 0usize..7, pa in 0usize..3,
        incx in prop_oneof![Just(1i32), Just(2), Just(-1), Just(-3)],
        incy in prop_oneof![Just(1i32), Just(3), Just(-2)],
        alpha in scalar(), beta in scalar(), v in entries(64),
    ) {
        let a = from_vec(m, n, pa, &v);
        let notrans = t == b'N' || t == b'n';
        let (lx, ly) = if notrans { (n, m) } else { (m, n) };
        let xs: Vec<f64> = (0..lx).map(|i| v[(3 * i + 5) % 64]).collect();
        let ys: Vec<f64> = (0..ly).map(|i| v[(5 * i + 11) % 64]).collect();
        // Strided storage: logical entry i at (i or len-1-i) * |inc|.
        let store = |vals: &[f64], inc: i32| -> Vec<f64> {
            let step = inc.unsigned_abs() as usize;
            let mut s = vec![PAD; vals.len().max(1) * step];
            for (i, &x) in vals.iter().enumerate() {
                let k = if inc > 0 { i } else { vals.len() - 1 - i };
                s[k * step] = x;
            }
            s
        };
        let x = store(&xs, incx);
        let mut y = store(&ys, incy);
        let y0 = y.clone();
        unsafe {
            dense_lapack::dgemv_(
                &c(t), &(m as i32), &(n as i32), &alpha, a.data.as_ptr(), &a.ld_i32(),
                x.as_ptr(), &incx, &beta, y.as_mut_ptr(), &incy,
            );
        }
        let opa = op(&a, t);
        let step = incy.unsigned_abs() as usize;
        for i in 0..ly {
            let k = if incy > 0 { i } else { ly - 1 - i };
            let want = if m == 0 || n == 0 {
                ys[i] // reference BLAS returns at once: y is not even scaled
            } else {
                alpha * (0..lx).map(|l| opa.at(i, l) * xs[l]).sum::<f64>() + beta * ys[i]
            };
            prop_assert!((y[k * step] - want).abs() <= TOL, "y[{i}] = {} want {want}", y[k * step]);
        }
        for (idx, (now, was)) in y.iter().zip(&y0).enumerate() {
            if idx % step != 0 || idx / step >= ly {
                prop_assert_eq!(now.to_bits(), was.to_bits(), "gap {} written", idx);
            }
        }
    }

    #[test]
    fn dsymv_reads_only_its_triangle(
        uplo in prop_oneof![Just(b'U'), Just(b'L')], n in 0usize..7, pa in 0usize..3,
        incx in prop_oneof![Just(1i32), Just(-2)], alpha in scalar(), beta in scalar(),
        v in entries(64),
    ) {
        let full = sym(n, pa, &v);
        let mut a = full.clone();
        poison_other_triangle(&mut a, uplo);
        let step = incx.unsigned_abs() as usize;
        let xs: Vec<f64> = (0..n).map(|i| v[(7 * i + 1) % 64]).collect();
        let mut x = vec![PAD; n.max(1) * step];
        for (i, &xv) in xs.iter().enumerate() {
            let k = if incx > 0 { i } else { n - 1 - i };
            x[k * step] = xv;
        }
        let y0: Vec<f64> = (0..n).map(|i| v[(i + 30) % 64]).collect();
        let mut y = y0.clone();
        unsafe {
            dense_lapack::dsymv_(
                &c(uplo), &(n as i32), &alpha, a.data.as_ptr(), &a.ld_i32(), x.as_ptr(), &incx,
                &beta, y.as_mut_ptr(), &1,
            );
        }
        for i in 0..n {
            let want = alpha * (0..n).map(|l| full.at(i, l) * xs[l]).sum::<f64>() + beta * y0[i];
            prop_assert!((y[i] - want).abs() <= TOL);
        }
    }

    #[test]
    fn dsyrk_updates_only_its_triangle(
        uplo in prop_oneof![Just(b'U'), Just(b'L')], t in trans(), n in 0usize..7,
        k in 0usize..6, pa in 0usize..3, pc in 0usize..3, alpha in scalar(), beta in scalar(),
        v in entries(64),
    ) {
        let notrans = t == b'N' || t == b'n';
        let a = if notrans { from_vec(n, k, pa, &v) } else { from_vec(k, n, pa, &v) };
        let c0 = from_vec(n, n, pc, &v[9..]);
        let mut cm = c0.clone();
        unsafe {
            dense_lapack::dsyrk_(
                &c(uplo), &c(t), &(n as i32), &(k as i32), &alpha, a.data.as_ptr(), &a.ld_i32(),
                &beta, cm.data.as_mut_ptr(), &cm.ld_i32(),
            );
        }
        let oa = op(&a, t);
        let aat = mul(&oa, &oa.t());
        for j in 0..n {
            for i in 0..n {
                let mine = if uplo == b'U' { i <= j } else { i >= j };
                if mine {
                    let want = alpha * aat.at(i, j) + beta * c0.at(i, j);
                    prop_assert!((cm.at(i, j) - want).abs() <= TOL);
                } else {
                    prop_assert_eq!(cm.at(i, j).to_bits(), c0.at(i, j).to_bits());
                }
            }
        }
        prop_assert!(cm.padding_intact());
    }

    #[test]
    fn dsyr2k_updates_only_its_triangle(
        uplo in prop_oneof![Just(b'U'), Just(b'L')], t in trans(), n in 0usize..7,
        k in 0usize..6, pa in 0usize..3, pc in 0usize..3, alpha in scalar(), beta in scalar(),
        v in entries(64),
    ) {
        let notrans = t == b'N' || t == b'n';
        let (r, cc) = if notrans { (n, k) } else { (k, n) };
        let a = from_vec(r, cc, pa, &v);
        let b = from_vec(r, cc, 1, &v[21..]);
        let c0 = from_vec(n, n, pc, &v[9..]);
        let mut cm = c0.clone();
        unsafe {
            dense_lapack::dsyr2k_(
                &c(uplo), &c(t), &(n as i32), &(k as i32), &alpha, a.data.as_ptr(), &a.ld_i32(),
                b.data.as_ptr(), &b.ld_i32(), &beta, cm.data.as_mut_ptr(), &cm.ld_i32(),
            );
        }
        let (oa, ob) = (op(&a, t), op(&b, t));
        let abt = mul(&oa, &ob.t());
        for j in 0..n {
            for i in 0..n {
                let mine = if uplo == b'U' { i <= j } else { i >= j };
                if mine {
                    let want = alpha * (abt.at(i, j) + abt.at(j, i)) + beta * c0.at(i, j);
                    prop_assert!((cm.at(i, j) - want).abs() <= TOL);
                } else {
                    prop_assert_eq!(cm.at(i, j).to_bits(), c0.at(i, j).to_bits());
                }
            }
        }
        prop_assert!(cm.padding_intact());
    }
}

#[test]
fn beta_zero_does_not_read_c_and_alpha_zero_does_not_read_a_or_b() {
    let nan = M::new(3, 3, 4, |_, _| f64::NAN);
    let a = M::new(3, 2, 3, |i, j| (i + 2 * j) as f64);
    let b = M::new(2, 3, 2, |i, j| (i * j) as f64 + 1.0);
    let mut cm = nan.clone();
    call_gemm(b'N', b'N', 3, 3, 2, 1.0, &a, &b, 0.0, &mut cm);
    assert!(max_abs_diff(&cm, &mul(&a, &b)) <= TOL);
    let mut cm = M::new(3, 3, 3, |i, j| (i + j) as f64);
    let want = M::new(3, 3, 3, |i, j| 2.0 * (i + j) as f64);
    let nan_a = M::new(3, 2, 3, |_, _| f64::NAN);
    let nan_b = M::new(2, 3, 2, |_, _| f64::NAN);
    call_gemm(b'N', b'N', 3, 3, 2, 0.0, &nan_a, &nan_b, 2.0, &mut cm);
    assert!(max_abs_diff(&cm, &want) <= 0.0);
    let mut y = [f64::NAN; 3];
    let x = [1.0, 1.0];
    unsafe {
        dense_lapack::dgemv_(
            &c(b'N'),
            &3,
            &2,
            &1.0,
            a.data.as_ptr(),
            &3,
            x.as_ptr(),
            &1,
            &0.0,
            y.as_mut_ptr(),
            &1,
        );
    }
    assert_eq!(y, [2.0, 4.0, 6.0]);
}

/// clarabel's `MultiplyGEMM::mul` with transposed operands (psdtrianglecone.rs:
/// `tmp = L2^T L1`, `R = L1 V`), and `syrk(R, Triu)` for `R R^T`.
#[test]
fn clarabel_calling_patterns_give_the_products_it_expects() {
    let l1 = M::new(5, 5, 5, |i, j| {
        if i >= j {
            1.0 + (i * 5 + j) as f64 / 7.0
        } else {
            0.0
        }
    });
    let l2 = M::new(5, 5, 5, |i, j| {
        if i >= j {
            2.0 - (i + 3 * j) as f64 / 11.0
        } else {
            0.0
        }
    });
    let mut tmp = M::new(5, 5, 5, |_, _| 0.0);
    call_gemm(b'T', b'N', 5, 5, 5, 1.0, &l2, &l1, 0.0, &mut tmp);
    assert!(max_abs_diff(&tmp, &mul(&l2.t(), &l1)) <= TOL);
    let mut rrt = M::new(5, 5, 5, |_, _| 0.0);
    unsafe {
        dense_lapack::dsyrk_(
            &c(b'U'),
            &c(b'N'),
            &5,
            &5,
            &1.0,
            tmp.data.as_ptr(),
            &5,
            &0.0,
            rrt.data.as_mut_ptr(),
            &5,
        );
    }
    let want = mul(&tmp, &tmp.t());
    for j in 0..5 {
        for i in 0..=j {
            assert!((rrt.at(i, j) - want.at(i, j)).abs() <= 1e-11);
        }
        for i in j + 1..5 {
            assert_eq!(rrt.at(i, j), 0.0, "the lower triangle is not written");
        }
    }
}

#[test]
fn illegal_blas_arguments_name_their_position_as_reference_blas_does() {
    let a = [0.0; 16];
    let mut cm = [0.0; 16];
    use dense_lapack::blas::{gemm, gemv, symv, syr2k, syrk};
    assert_eq!(
        gemm(b'X', b'N', 2, 2, 2, 1.0, &a, 2, &a, 2, 0.0, &mut cm, 2),
        Err(Illegal(1))
    );
    assert_eq!(
        gemm(b'N', b'Q', 2, 2, 2, 1.0, &a, 2, &a, 2, 0.0, &mut cm, 2),
        Err(Illegal(2))
    );
    assert_eq!(
        gemm(b'N', b'N', -1, 2, 2, 1.0, &a, 2, &a, 2, 0.0, &mut cm, 2),
        Err(Illegal(3))
    );
    assert_eq!(
        gemm(b'N', b'N', 2, 2, 2, 1.0, &a, 1, &a, 2, 0.0, &mut cm, 2),
        Err(Illegal(8))
    );
    assert_eq!(
        gemm(b'T', b'N', 3, 2, 2, 1.0, &a, 2, &a, 1, 0.0, &mut cm, 3),
        Err(Illegal(10))
    );
    assert_eq!(
        gemm(b'N', b'N', 3, 2, 2, 1.0, &a, 3, &a, 2, 0.0, &mut cm, 2),
        Err(Illegal(13))
    );
    // A slice shorter than the dimensions say is refused, never read past.
    assert_eq!(
        gemm(
            b'N',
            b'N',
            4,
            4,
            4,
            1.0,
            &a[..15],
            4,
            &a,
            4,
            0.0,
            &mut cm,
            4
        ),
        Err(Illegal(7))
    );
    let mut y = [0.0; 4];
    assert_eq!(
        gemv(b'N', 2, 2, 1.0, &a, 2, &a, 0, 0.0, &mut y, 1),
        Err(Illegal(8))
    );
    assert_eq!(
        gemv(b'N', 2, 2, 1.0, &a, 2, &a, 1, 0.0, &mut y, 0),
        Err(Illegal(11))
    );
    assert_eq!(
        symv(b'X', 2, 1.0, &a, 2, &a, 1, 0.0, &mut y, 1),
        Err(Illegal(1))
    );
    assert_eq!(
        symv(b'U', 3, 1.0, &a, 2, &a, 1, 0.0, &mut y, 1),
        Err(Illegal(5))
    );
    assert_eq!(
        syrk(b'U', b'X', 2, 2, 1.0, &a, 2, 0.0, &mut cm, 2),
        Err(Illegal(2))
    );
    assert_eq!(
        syrk(b'U', b'N', 2, -1, 1.0, &a, 2, 0.0, &mut cm, 2),
        Err(Illegal(4))
    );
    assert_eq!(
        syrk(b'L', b'T', 3, 2, 1.0, &a, 1, 0.0, &mut cm, 3),
        Err(Illegal(7))
    );
    assert_eq!(
        syr2k(b'L', b'N', 3, 2, 1.0, &a, 3, &a, 2, 0.0, &mut cm, 3),
        Err(Illegal(9))
    );
    assert_eq!(
        syr2k(b'L', b'N', 3, 2, 1.0, &a, 3, &a, 3, 0.0, &mut cm, 2),
        Err(Illegal(12))
    );
}

#[test]
fn single_precision_symbols_compute_the_same_products() {
    let a: Vec<f32> = (0..6).map(|i| i as f32).collect(); // 2 x 3
    let b: Vec<f32> = (0..6).map(|i| 1.0 - i as f32).collect(); // 3 x 2
    let mut cm = [0.0f32; 4];
    unsafe {
        dense_lapack::sgemm_(
            &c(b'N'),
            &c(b'N'),
            &2,
            &2,
            &3,
            &1.0,
            a.as_ptr(),
            &2,
            b.as_ptr(),
            &3,
            &0.0,
            cm.as_mut_ptr(),
            &2,
        );
    }
    // A = [0 2 4; 1 3 5], B = [1 -2; 0 -3; -1 -4] (column-major).
    assert_eq!(cm, [-4.0, -4.0, -22.0, -31.0]);
}
