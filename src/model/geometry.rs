//! Basic geometric types shared by every module.
//!
//! A scenario is 2-D or 3-D. Positions are [`Point<D>`] (`D` = 2 or 3); the
//! lifted local variable of Mourya 2017 eq. (9)-(13), `theta~ = [theta, d]`,
//! is a [`Lifted<L>`] with `L = D + 1`. Code generic over the dimension takes
//! both as const parameters (stable Rust cannot write `D + 1` in a type) and
//! checks the pair once with [`check_dims`].

/// A point or vector in `D` dimensions (metres).
pub type Point<const D: usize> = nalgebra::SVector<f64, D>;
/// The lifted variable `theta~ = [theta, d]` in `L = D + 1` dimensions.
pub type Lifted<const L: usize> = nalgebra::SVector<f64, L>;
/// An `L` by `L` matrix (normal equations of the lifted problem).
pub type LMat<const L: usize> = nalgebra::SMatrix<f64, L, L>;

/// A 2-D point or vector (metres).
pub type Vec2 = Point<2>;
/// The lifted local variable `theta~ = [x, y, d]` of Mourya 2017 eq. (9)-(13).
pub type Vec3 = Lifted<3>;
/// 3x3 matrix.
pub type Mat3 = LMat<3>;

/// Compile-time check that `(D, L)` is a supported position dimension and
/// its lifted dimension: `D` is 2 or 3 and `L = D + 1`. Evaluated where a
/// generic function is instantiated, so a wrong pair does not compile.
pub const fn check_dims<const D: usize, const L: usize>() {
    assert!(
        (D == 2 || D == 3) && L == D + 1,
        "dimension pair must be (2, 3) or (3, 4)"
    );
}

/// Build a [`Vec2`] from an array.
pub fn v2(p: [f64; 2]) -> Vec2 {
    Vec2::new(p[0], p[1])
}

/// The position part `theta~[0:D]` of a lifted variable.
pub fn pos<const D: usize, const L: usize>(theta: &Lifted<L>) -> Point<D> {
    const { check_dims::<D, L>() };
    Point::<D>::from_fn(|i, _| theta[i])
}

/// The lifted variable `[x, d]`.
pub fn lift<const D: usize, const L: usize>(x: &Point<D>, d: f64) -> Lifted<L> {
    const { check_dims::<D, L>() };
    Lifted::<L>::from_fn(|i, _| if i < D { x[i] } else { d })
}
