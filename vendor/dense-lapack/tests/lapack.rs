//! The LAPACK symbols: property tests of what each decomposition promises
//! (with padded leading dimensions and, for the symmetric routines, NaN in the
//! triangle that must not be read), LAPACK's `info` codes, workspace queries
//! and the refusals of argument values that are not implemented.

// BLAS signatures and index arithmetic, mirrored on purpose.
#![allow(clippy::too_many_arguments, clippy::needless_range_loop)]

mod common;

use approx::assert_relative_eq;
use common::*;
use proptest::prelude::*;

fn eye(n: usize) -> M {
    M::new(n, n, n.max(1), |i, j| if i == j { 1.0 } else { 0.0 })
}

/// `Q^T Q` (for `Q` with orthonormal columns).
fn gram(q: &M) -> M {
    mul(&q.t(), q)
}

fn uplo() -> impl Strategy<Value = u8> {
    prop_oneof![Just(b'U'), Just(b'L'), Just(b'u'), Just(b'l')]
}

fn svd_call(which: &str, job: u8, a: &mut M) -> (i32, Vec<f64>, M, M) {
    let (m, n) = (a.rows, a.cols);
    let mn = m.min(n);
    let (ucols, vrows) = if job == b'A' { (m, n) } else { (mn, mn) };
    let mut s = vec![0.0; mn];
    let mut u = M::new(m, ucols, m.max(1) + 1, |_, _| 0.0);
    let mut vt = M::new(vrows, n, vrows.max(1) + 2, |_, _| 0.0);
    let mut work = vec![0.0f64];
    let mut iwork = vec![0i32; 8 * mn.max(1)];
    let mut info = 0;
    for pass in 0..2 {
        let lwork = if pass == 0 { -1 } else { work[0] as i32 };
        work.resize(work[0].max(1.0) as usize, 0.0);
        unsafe {
            if which == "gesdd" {
                dense_lapack::dgesdd_(
                    &c(job),
                    &(m as i32),
                    &(n as i32),
                    a.data.as_mut_ptr(),
                    &a.ld_i32(),
                    s.as_mut_ptr(),
                    u.data.as_mut_ptr(),
                    &u.ld_i32(),
                    vt.data.as_mut_ptr(),
                    &vt.ld_i32(),
                    work.as_mut_ptr(),
                    &lwork,
                    iwork.as_mut_ptr(),
                    &mut info,
                );
            } else {
                dense_lapack::dgesvd_(
                    &c(job),
                    &c(job),
                    &(m as i32),
                    &(n as i32),
                    a.data.as_mut_ptr(),
                    &a.ld_i32(),
                    s.as_mut_ptr(),
                    u.data.as_mut_ptr(),
                    &u.ld_i32(),
                    vt.data.as_mut_ptr(),
                    &vt.ld_i32(),
                    work.as_mut_ptr(),
                    &lwork,
                    &mut info,
                );
            }
        }
        if info != 0 {
            break;
        }
    }
    (info, s, u, vt)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn dsyevr_gives_ascending_eigenvalues_and_orthonormal_eigenvectors(
        n in 0usize..9, pad in 0usize..3, up in uplo(), v in entries(81),
    ) {
        let full = sym(n, pad, &v);
        let mut a = full.clone();
        poison_other_triangle(&mut a, up.to_ascii_uppercase());
        let (info, m, w, z, isuppz) = syevr(b'V', up, &mut a);
        prop_assert_eq!(info, 0);
        prop_assert_eq!(m as usize, n);
        prop_assert!(w.windows(2).all(|p| p[0] <= p[1]), "ascending: {:?}", w);
        let scale = max_abs(&full).max(1.0);
        // A V = V Lambda.
        let av = mul(&M::new(n, n, n.max(1), |i, j| full.at(i, j)), &z);
        let vl = M::new(n, n, n.max(1), |i, j| z.at(i, j) * w[j]);
        prop_assert!(max_abs_diff(&av, &vl) <= 1e-12 * scale * n.max(1) as f64);
        prop_assert!(max_abs_diff(&gram(&z), &eye(n)) <= 1e-13 * n.max(1) as f64);
        for j in 0..n {
            let (lo, hi) = (isuppz[2 * j] as usize, isuppz[2 * j + 1] as usize);
            prop_assert!(1 <= lo && lo <= hi && hi <= n);
            for i in 0..n {
                if i + 1 < lo || i + 1 > hi {
                    prop_assert_eq!(z.at(i, j), 0.0);
                }
            }
        }
        // jobz = 'N' gives the same eigenvalues.
        let mut a2 = full.clone();
        poison_other_triangle(&mut a2, up.to_ascii_uppercase());
        let (info2, _, w2, _, _) = syevr(b'N', up, &mut a2);
        prop_assert_eq!(info2, 0);
        for (x, y) in w.iter().zip(&w2) {
            prop_assert!((x - y).abs() <= 1e-12 * scale * n.max(1) as f64);
        }
    }

    #[test]
    fn dgesdd_and_dgesvd_recompose_a_with_descending_singular_values(
        m in 0usize..8, n in 0usize..8, pad in 0usize..3, full_job in any::<bool>(),
        gesvd in any::<bool>(), v in entries(64),
    ) {
        let a0 = from_vec(m, n, pad, &v);
        let mut a = a0.clone();
        let job = if full_job { b'A' } else { b'S' };
        let (info, s, u, vt) = svd_call(if gesvd { "gesvd" } else { "gesdd" }, job, &mut a);
        prop_assert_eq!(info, 0);
        prop_assert!(s.iter().all(|x| *x >= 0.0));
        prop_assert!(s.windows(2).all(|p| p[0] >= p[1]), "descending: {:?}", s);
        let mn = m.min(n);
        let us = M::new(m, mn, m.max(1), |i, j| u.at(i, j) * s[j]);
        let vtk = M::new(mn, n, mn.max(1), |i, j| vt.at(i, j));
        let rec = mul(&us, &vtk);
        let scale = max_abs(&a0).max(1.0);
        prop_assert!(max_abs_diff(&rec, &M::new(m, n, m.max(1), |i, j| a0.at(i, j))) <= 1e-12 * scale * 8.0);
        // LAPACK returns at once when min(m, n) = 0: U and V^T are not set.
        if mn > 0 {
            prop_assert!(max_abs_diff(&gram(&u), &eye(u.cols)) <= 1e-12);
            prop_assert!(max_abs_diff(&gram(&vt.t()), &eye(vt.rows)) <= 1e-12);
        }
        prop_assert!(u.padding_intact() && vt.padding_intact());
    }

    #[test]
    fn dpotrf_and_dpotrs_solve_spd_systems_reading_one_triangle(
        n in 0usize..9, pad in 0usize..3, up in uplo(), nrhs in 0usize..4, v in entries(81),
    ) {
        let full = spd(n, pad, &v);
        let mut a = full.clone();
        let upc = up.to_ascii_uppercase();
        // A finite sentinel in the other triangle: a write to it shows even
        // where arithmetic on NaN would have hidden it.
        fill_other_triangle(&mut a, upc, 12345.0);
        let mut info = -99;
        unsafe { dense_lapack::dpotrf_(&c(up), &(n as i32), a.data.as_mut_ptr(), &a.ld_i32(), &mut info) };
        prop_assert_eq!(info, 0);
        // The other triangle is neither read nor written.
        for j in 0..n {
            for i in 0..n {
                if (upc == b'U' && i > j) || (upc == b'L' && i < j) {
                    prop_assert_eq!(a.at(i, j), 12345.0);
                }
            }
        }
        // ... nor read: NaN there changes nothing.
        let mut p = full.clone();
        poison_other_triangle(&mut p, upc);
        unsafe { dense_lapack::dpotrf_(&c(up), &(n as i32), p.data.as_mut_ptr(), &p.ld_i32(), &mut info) };
        prop_assert_eq!(info, 0);
        for j in 0..n {
            for i in 0..n {
                if (upc == b'L') == (i >= j) {
                    prop_assert_eq!(p.at(i, j).to_bits(), a.at(i, j).to_bits());
                }
            }
        }
        // The factor recomposes A.
        let f = M::new(n, n, n.max(1), |i, j| {
            let lower = upc == b'L';
            let keep = if lower { i >= j } else { i <= j };
            if keep { a.at(i, j) } else { 0.0 }
        });
        let rec = if upc == b'L' { mul(&f, &f.t()) } else { mul(&f.t(), &f) };
        let want = M::new(n, n, n.max(1), |i, j| full.at(i, j));
        prop_assert!(max_abs_diff(&rec, &want) <= 1e-12 * max_abs(&want).max(1.0));
        let x = from_vec(n, nrhs, 0, &v[5..]);
        let bm = mul(&want, &x);
        let mut b = M::new(n, nrhs, n.max(1) + 2, |i, j| bm.at(i, j));
        unsafe {
            dense_lapack::dpotrs_(&c(up), &(n as i32), &(nrhs as i32), a.data.as_ptr(), &a.ld_i32(), b.data.as_mut_ptr(), &b.ld_i32(), &mut info);
        }
        prop_assert_eq!(info, 0);
        prop_assert!(max_abs_diff(&b, &x) <= 1e-10);
        prop_assert!(b.padding_intact());
    }

    #[test]
    fn dpotrf_reports_the_first_leading_minor_that_is_not_positive(
        n in 2usize..8, bad in 0usize..8, up in uplo(), v in entries(64),
    ) {
        let bad = bad % n;
        // Diagonal SPD matrix with one non-positive pivot at `bad`: the
        // leading minor of order bad + 1 is the first that is not PD.
        let mut a = M::new(n, n, n + 1, |i, j| if i == j { 1.0 + v[i].abs() } else { 0.0 });
        a.set(bad, bad, -v[bad].abs());
        let mut info = 0;
        unsafe { dense_lapack::dpotrf_(&c(up), &(n as i32), a.data.as_mut_ptr(), &a.ld_i32(), &mut info) };
        prop_assert_eq!(info, bad as i32 + 1);
    }

    #[test]
    fn dgesv_solves_nonsingular_systems_with_valid_pivots(
        n in 1usize..9, pad in 0usize..3, nrhs in 0usize..4, shift in 0usize..8,
        v in entries(81),
    ) {
        // A row permutation of a strictly diagonally dominant matrix: always
        // nonsingular, and partial pivoting has rows to interchange.
        let dominant = (2 * n + 1) as f64;
        let a0 = M::new(n, n, n + pad, |i, j| {
            v[(i * n + j) % 81] + if j == (i + shift) % n { dominant } else { 0.0 }
        });
        let mut a = a0.clone();
        let x = from_vec(n, nrhs, 0, &v[3..]);
        let bm = mul(&M::new(n, n, n, |i, j| a0.at(i, j)), &x);
        let mut b = M::new(n, nrhs, n + 1, |i, j| bm.at(i, j));
        let mut ipiv = vec![0i32; n];
        let mut info = -99;
        unsafe {
            dense_lapack::dgesv_(&(n as i32), &(nrhs as i32), a.data.as_mut_ptr(), &a.ld_i32(), ipiv.as_mut_ptr(), b.data.as_mut_ptr(), &b.ld_i32(), &mut info);
        }
        prop_assert_eq!(info, 0);
        prop_assert!(max_abs_diff(&b, &x) <= 1e-10);
        // ipiv: row i was interchanged with row ipiv[i] >= i (1-based), and
        // the interchanges applied to A give L U.
        let mut pa = M::new(n, n, n, |i, j| a0.at(i, j));
        for (i, &p) in ipiv.iter().enumerate() {
            let p = p as usize;
            prop_assert!(p > i && p <= n);
            for j in 0..n {
                let (r, q) = (pa.at(i, j), pa.at(p - 1, j));
                pa.set(i, j, q);
                pa.set(p - 1, j, r);
            }
        }
        let l = M::new(n, n, n, |i, j| if i > j { a.at(i, j) } else if i == j { 1.0 } else { 0.0 });
        let u = M::new(n, n, n, |i, j| if i <= j { a.at(i, j) } else { 0.0 });
        prop_assert!(max_abs_diff(&mul(&l, &u), &pa) <= 1e-12 * 16.0);
        prop_assert!(a.padding_intact() && b.padding_intact());
    }
}

#[test]
fn dgesv_reports_an_exactly_zero_pivot_and_leaves_b_unchanged() {
    // Column 2 is a multiple of column 1: U(2,2) is exactly zero.
    let mut a = M::new(3, 3, 3, |i, j| match j {
        0 => [1.0, 2.0, 4.0][i],
        1 => [2.0, 4.0, 8.0][i],
        _ => [0.0, 1.0, 5.0][i],
    });
    let mut b = [1.0, 2.0, 3.0];
    let mut ipiv = [0i32; 3];
    let mut info = 0;
    unsafe {
        dense_lapack::dgesv_(
            &3,
            &1,
            a.data.as_mut_ptr(),
            &3,
            ipiv.as_mut_ptr(),
            b.as_mut_ptr(),
            &3,
            &mut info,
        );
    }
    assert_eq!(info, 2);
    assert_eq!(b, [1.0, 2.0, 3.0]);
}

#[test]
fn dpotrf_counts_a_nan_pivot_as_not_positive() {
    let mut a = M::new(3, 3, 3, |i, j| if i == j { 4.0 } else { 0.0 });
    a.set(1, 1, f64::NAN);
    let mut info = 0;
    unsafe { dense_lapack::dpotrf_(&c(b'L'), &3, a.data.as_mut_ptr(), &3, &mut info) };
    assert_eq!(info, 2);
}

#[test]
fn workspace_queries_return_lapacks_minimum_sizes() {
    let mut a = sym(5, 0, &[1.0, -0.5, 0.25, 2.0, 3.0]);
    let (mut m, mut info) = (0, 0);
    let mut w = [0.0; 5];
    let mut z = [0.0; 25];
    let mut isuppz = [0; 10];
    let mut work = [0.0];
    let mut iwork = [0];
    unsafe {
        dense_lapack::dsyevr_(
            &c(b'V'),
            &c(b'A'),
            &c(b'U'),
            &5,
            a.data.as_mut_ptr(),
            &5,
            &0.0,
            &0.0,
            &0,
            &0,
            &-1.0,
            &mut m,
            w.as_mut_ptr(),
            z.as_mut_ptr(),
            &5,
            isuppz.as_mut_ptr(),
            work.as_mut_ptr(),
            &-1,
            iwork.as_mut_ptr(),
            &-1,
            &mut info,
        );
    }
    assert_eq!((info, work[0], iwork[0]), (0, 130.0, 50));
    assert_eq!(w, [0.0; 5], "a query computes nothing");
    let mut s = [0.0; 3];
    let mut u = [0.0; 12];
    let mut vt = [0.0; 9];
    let mut a = M::new(4, 3, 4, |i, j| (i + j) as f64);
    unsafe {
        dense_lapack::dgesdd_(
            &c(b'S'),
            &4,
            &3,
            a.data.as_mut_ptr(),
            &4,
            s.as_mut_ptr(),
            u.as_mut_ptr(),
            &4,
            vt.as_mut_ptr(),
            &3,
            work.as_mut_ptr(),
            &-1,
            iwork.as_mut_ptr(),
            &mut info,
        );
    }
    assert_eq!((info, work[0]), (0, (4 * 9 + 6 * 3 + 4) as f64));
    unsafe {
        dense_lapack::dgesvd_(
            &c(b'S'),
            &c(b'S'),
            &4,
            &3,
            a.data.as_mut_ptr(),
            &4,
            s.as_mut_ptr(),
            u.as_mut_ptr(),
            &4,
            vt.as_mut_ptr(),
            &3,
            work.as_mut_ptr(),
            &-1,
            &mut info,
        );
    }
    assert_eq!((info, work[0]), (0, 15.0));
}

#[test]
fn unimplemented_or_illegal_lapack_arguments_return_negative_info() {
    let mut a = sym(4, 0, &[1.0, 2.0, 3.0]);
    let (mut m, mut info) = (0, 0);
    let mut w = [0.0; 4];
    let mut z = [0.0; 16];
    let mut isuppz = [0; 8];
    let mut work = vec![0.0; 104];
    let mut iwork = vec![0; 40];
    let mut syevr = |jobz: u8, range: u8, ldz: i32, lwork: i32, liwork: i32| {
        unsafe {
            dense_lapack::dsyevr_(
                &c(jobz),
                &c(range),
                &c(b'L'),
                &4,
                a.data.as_mut_ptr(),
                &4,
                &0.0,
                &1.0,
                &1,
                &2,
                &-1.0,
                &mut m,
                w.as_mut_ptr(),
                z.as_mut_ptr(),
                &ldz,
                isuppz.as_mut_ptr(),
                work.as_mut_ptr(),
                &lwork,
                iwork.as_mut_ptr(),
                &liwork,
                &mut info,
            );
        }
        info
    };
    assert_eq!(syevr(b'X', b'A', 4, 104, 40), -1);
    assert_eq!(syevr(b'V', b'V', 4, 104, 40), -2, "range V is refused");
    assert_eq!(syevr(b'V', b'I', 4, 104, 40), -2, "range I is refused");
    assert_eq!(syevr(b'V', b'A', 3, 104, 40), -15);
    assert_eq!(syevr(b'V', b'A', 4, 103, 40), -18);
    assert_eq!(syevr(b'V', b'A', 4, 104, 39), -20);
    assert_eq!(syevr(b'V', b'A', 4, 104, 40), 0);
    let mut a = M::new(3, 3, 3, |i, j| (i * j) as f64);
    let (mut s, mut u, mut vt) = ([0.0; 3], [0.0; 9], [0.0; 9]);
    let mut gesdd = |jobz: u8, lda: i32, ldu: i32, ldvt: i32, lwork: i32| {
        unsafe {
            dense_lapack::dgesdd_(
                &c(jobz),
                &3,
                &3,
                a.data.as_mut_ptr(),
                &lda,
                s.as_mut_ptr(),
                u.as_mut_ptr(),
                &ldu,
                vt.as_mut_ptr(),
                &ldvt,
                work.as_mut_ptr(),
                &lwork,
                iwork.as_mut_ptr(),
                &mut info,
            );
        }
        info
    };
    assert_eq!(gesdd(b'O', 3, 3, 3, 100), -1, "jobz O is refused");
    assert_eq!(gesdd(b'S', 2, 3, 3, 100), -5);
    assert_eq!(gesdd(b'S', 3, 2, 3, 100), -8);
    assert_eq!(gesdd(b'S', 3, 3, 2, 100), -10);
    assert_eq!(gesdd(b'S', 3, 3, 3, 4 * 9 + 18 + 2), -12);
    assert_eq!(gesdd(b'S', 3, 3, 3, 100), 0);
    let mut info = 0;
    let mut b = [0.0; 3];
    unsafe { dense_lapack::dpotrf_(&c(b'X'), &3, a.data.as_mut_ptr(), &3, &mut info) };
    assert_eq!(info, -1);
    unsafe { dense_lapack::dpotrf_(&c(b'U'), &3, a.data.as_mut_ptr(), &2, &mut info) };
    assert_eq!(info, -4);
    unsafe {
        dense_lapack::dpotrs_(
            &c(b'U'),
            &3,
            &-1,
            a.data.as_ptr(),
            &3,
            b.as_mut_ptr(),
            &3,
            &mut info,
        )
    };
    assert_eq!(info, -3);
    unsafe {
        dense_lapack::dpotrs_(
            &c(b'U'),
            &3,
            &1,
            a.data.as_ptr(),
            &3,
            b.as_mut_ptr(),
            &2,
            &mut info,
        )
    };
    assert_eq!(info, -7);
    let mut ipiv = [0; 3];
    unsafe {
        dense_lapack::dgesv_(
            &-1,
            &1,
            a.data.as_mut_ptr(),
            &3,
            ipiv.as_mut_ptr(),
            b.as_mut_ptr(),
            &3,
            &mut info,
        )
    };
    assert_eq!(info, -1);
    unsafe {
        dense_lapack::dgesv_(
            &3,
            &1,
            a.data.as_mut_ptr(),
            &1,
            ipiv.as_mut_ptr(),
            b.as_mut_ptr(),
            &3,
            &mut info,
        )
    };
    assert_eq!(info, -4);
}

#[test]
fn non_finite_input_is_reported_not_decomposed() {
    let mut a = sym(4, 0, &[1.0, 2.0, 3.0]);
    a.set(2, 1, f64::INFINITY);
    let (info, m, ..) = syevr(b'N', b'L', &mut a);
    assert_eq!((info, m), (1, 0));
    let mut a = M::new(3, 2, 3, |i, j| (i + j) as f64);
    a.set(1, 1, f64::NAN);
    let (info, ..) = svd_call("gesdd", b'S', &mut a);
    assert_eq!(
        info, -4,
        "a NaN in A is the illegal argument A, as in LAPACK 3.x"
    );
    let mut a = M::new(3, 2, 3, |i, j| (i + j) as f64);
    a.set(0, 0, f64::NEG_INFINITY);
    let (info, ..) = svd_call("gesvd", b'S', &mut a);
    assert_eq!(info, 1);
}

/// clarabel's PSD cone: `syevr(jobz = 'N')` with a one-element `z`
/// placeholder and `ldz = n`, then `gesdd('S')` of a square matrix after a
/// workspace query (psdtrianglecone.rs, syevr.rs, svd.rs).
#[test]
fn clarabel_eigenvalue_and_svd_calls_give_reference_values() {
    // The 4x4 test matrix of clarabel's own syevr test: eigenvalues -1, -1, 8, 9.
    let s = [
        [3.0, 2.0, 4.0, 0.0],
        [2.0, 0.0, 2.0, 0.0],
        [4.0, 2.0, 3.0, 0.0],
        [0.0, 0.0, 0.0, 9.0],
    ];
    let mut a = M::new(4, 4, 4, |i, j| s[i][j]);
    poison_other_triangle(&mut a, b'U');
    let (mut m, mut info) = (0, 0);
    let mut w = [0.0; 4];
    let mut tmpz = [0.0];
    let mut isuppz = [0; 8];
    let mut work = [1.0];
    let mut iwork = [1];
    unsafe {
        dense_lapack::dsyevr_(
            &c(b'N'),
            &c(b'A'),
            &c(b'U'),
            &4,
            a.data.as_mut_ptr(),
            &4,
            &0.0,
            &0.0,
            &0,
            &0,
            &-1.0,
            &mut m,
            w.as_mut_ptr(),
            tmpz.as_mut_ptr(),
            &4,
            isuppz.as_mut_ptr(),
            work.as_mut_ptr(),
            &-1,
            iwork.as_mut_ptr(),
            &-1,
            &mut info,
        );
    }
    assert_eq!(info, 0);
    let mut work = vec![0.0; work[0] as usize];
    let mut iwork = vec![0; iwork[0] as usize];
    unsafe {
        dense_lapack::dsyevr_(
            &c(b'N'),
            &c(b'A'),
            &c(b'U'),
            &4,
            a.data.as_mut_ptr(),
            &4,
            &0.0,
            &0.0,
            &0,
            &0,
            &-1.0,
            &mut m,
            w.as_mut_ptr(),
            tmpz.as_mut_ptr(),
            &4,
            isuppz.as_mut_ptr(),
            work.as_mut_ptr(),
            &(work.len() as i32),
            iwork.as_mut_ptr(),
            &(iwork.len() as i32),
            &mut info,
        );
    }
    assert_eq!((info, m), (0, 4));
    for (got, want) in w.iter().zip([-1.0, -1.0, 8.0, 9.0]) {
        assert_relative_eq!(*got, want, epsilon = 1e-12);
    }
    assert_eq!(tmpz, [0.0], "jobz N leaves z alone");
    let mut a = M::new(4, 4, 4, |i, j| s[i][j]);
    let (info, sv, _, _) = svd_call("gesdd", b'S', &mut a);
    assert_eq!(info, 0);
    for (got, want) in sv.iter().zip([9.0, 8.0, 1.0, 1.0]) {
        assert_relative_eq!(*got, want, epsilon = 1e-12);
    }
}
