//! Small dense linear algebra in `D` = 2 or 3 dimensions for code generic over
//! the dimension. nalgebra's LU, determinant and symmetric eigendecomposition
//! need a dimension known to its type-level arithmetic, which a const generic
//! `D` is not; each function here copies into the concrete size, calls
//! nalgebra there, and copies back (bit for bit what nalgebra gives at that
//! size). Any other `D` gives `None`.

use crate::model::geometry::Point;
use nalgebra::SMatrix;

/// A `D` by `D` matrix.
pub type MatD<const D: usize> = SMatrix<f64, D, D>;

fn sized<const N: usize, const D: usize>(a: &MatD<D>) -> SMatrix<f64, N, N> {
    SMatrix::<f64, N, N>::from_fn(|i, j| a[(i, j)])
}

fn back<const N: usize, const D: usize>(a: &SMatrix<f64, N, N>) -> MatD<D> {
    MatD::<D>::from_fn(|i, j| a[(i, j)])
}

fn back_vec<const D: usize>(x: &[f64]) -> Point<D> {
    Point::<D>::from_fn(|i, _| x[i])
}

/// Solve `a x = b` by LU with partial pivoting (nalgebra's `lu().solve`).
/// `None` if `a` is singular.
pub fn lu_solve<const D: usize>(a: &MatD<D>, b: &Point<D>) -> Option<Point<D>> {
    let v = |b: &Point<D>, n: usize| -> Vec<f64> { b.iter().take(n).copied().collect() };
    match D {
        2 => sized::<2, D>(a)
            .lu()
            .solve(&Point::<2>::from_column_slice(&v(b, 2)))
            .map(|x| back_vec(x.as_slice())),
        3 => sized::<3, D>(a)
            .lu()
            .solve(&Point::<3>::from_column_slice(&v(b, 3)))
            .map(|x| back_vec(x.as_slice())),
        _ => None,
    }
}

/// The determinant (nalgebra's closed forms for 2x2 and 3x3).
pub fn determinant<const D: usize>(a: &MatD<D>) -> Option<f64> {
    match D {
        2 => Some(sized::<2, D>(a).determinant()),
        3 => Some(sized::<3, D>(a).determinant()),
        _ => None,
    }
}

/// The eigenvalues (ascending) and unit eigenvectors (columns, in the same
/// order) of the symmetric `a` (nalgebra's `SymmetricEigen`, reading the
/// lower triangle).
pub fn sym_eigen<const D: usize>(a: &MatD<D>) -> Option<(Point<D>, MatD<D>)> {
    fn sorted<const D: usize>(vals: &[f64], vecs: MatD<D>) -> (Point<D>, MatD<D>) {
        let mut order: Vec<usize> = (0..D).collect();
        order.sort_by(|&i, &j| vals[i].total_cmp(&vals[j]));
        (
            Point::<D>::from_fn(|i, _| vals[order[i]]),
            MatD::<D>::from_fn(|i, j| vecs[(i, order[j])]),
        )
    }
    match D {
        2 => {
            let e = sized::<2, D>(a).symmetric_eigen();
            Some(sorted(e.eigenvalues.as_slice(), back(&e.eigenvectors)))
        }
        3 => {
            let e = sized::<3, D>(a).symmetric_eigen();
            Some(sorted(e.eigenvalues.as_slice(), back(&e.eigenvectors)))
        }
        _ => None,
    }
}

/// The eigenvalues of the symmetric `a` in nalgebra's order (its
/// `symmetric_eigenvalues`, reading the lower triangle).
pub fn sym_eigenvalues<const D: usize>(a: &MatD<D>) -> Option<Point<D>> {
    match D {
        2 => Some(back_vec(
            sized::<2, D>(a).symmetric_eigenvalues().as_slice(),
        )),
        3 => Some(back_vec(
            sized::<3, D>(a).symmetric_eigenvalues().as_slice(),
        )),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn the_3d_helpers_agree_with_their_definitions() {
        let a = MatD::<3>::new(4.0, 1.0, -2.0, 1.0, 3.0, 0.5, -2.0, 0.5, 5.0);
        let b = Point::<3>::new(1.0, -2.0, 3.0);
        let x = lu_solve(&a, &b).expect("regular");
        assert_relative_eq!(a * x, b, max_relative = 1e-14);
        let (vals, vecs) = sym_eigen(&a).expect("symmetric");
        assert!(vals[0] <= vals[1] && vals[1] <= vals[2]);
        for k in 0..3 {
            let v = vecs.column(k);
            assert_relative_eq!(a * v, v * vals[k], epsilon = 1e-12);
        }
        assert_relative_eq!(
            determinant(&a).expect("3x3"),
            vals.iter().product::<f64>(),
            max_relative = 1e-13
        );
        assert!(lu_solve(&MatD::<3>::zeros(), &b).is_none());
        assert!(determinant(&MatD::<4>::identity()).is_none());
    }
}
