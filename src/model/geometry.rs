//! Basic geometric types shared by every module.

/// A 2-D point or vector (metres).
pub type Vec2 = nalgebra::Vector2<f64>;
/// The lifted local variable `theta~ = [x, y, d]` of Mourya 2017 eq. (9)-(13).
pub type Vec3 = nalgebra::Vector3<f64>;
/// 3x3 matrix.
pub type Mat3 = nalgebra::Matrix3<f64>;

/// Build a [`Vec2`] from an array.
pub fn v2(p: [f64; 2]) -> Vec2 {
    Vec2::new(p[0], p[1])
}

/// The position part `theta~[0:2]` of a lifted variable.
pub fn pos(theta: &Vec3) -> Vec2 {
    Vec2::new(theta[0], theta[1])
}
