//! Vectors whose length a run fixes at run time: a node's lifted variable
//! `theta~ = [theta, d]` (3 numbers in 2-D, 4 in 3-D) and the consensus
//! average of positions (2 or 3 numbers).
//!
//! The math is generic over the dimension at compile time ([`Point<D>`],
//! [`Lifted<L>`]); the protocol between nodes is not, so that one node
//! program, one frame format and one coordinator serve both dimensions. A
//! [`Coords`] carries the numbers between them; [`Coords::lifted`] and
//! [`Coords::of`] convert without touching a bit, and its arithmetic is the
//! componentwise IEEE arithmetic nalgebra does, in the same order, so a 2-D
//! run computes exactly what it computes on [`Lifted<3>`].

use crate::model::geometry::{Lifted, Point};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// The most numbers a [`Coords`] holds (a lifted 3-D variable).
pub const MAX_COORDS: usize = 4;

/// Two to four numbers (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coords {
    c: [f64; MAX_COORDS],
    len: u8,
}

impl Default for Coords {
    /// The lifted origin of a 2-D run, `[0, 0, 0]`.
    fn default() -> Coords {
        Coords::zeros(3)
    }
}

impl Coords {
    /// `len` zeros; `len` is clamped into 2..=4.
    pub fn zeros(len: usize) -> Coords {
        Coords {
            c: [0.0; MAX_COORDS],
            len: len.clamp(2, MAX_COORDS) as u8,
        }
    }

    /// The numbers of `v`, or `None` unless it holds 2 to 4.
    pub fn from_slice(v: &[f64]) -> Option<Coords> {
        if !(2..=MAX_COORDS).contains(&v.len()) {
            return None;
        }
        let mut c = [0.0; MAX_COORDS];
        c[..v.len()].copy_from_slice(v);
        Some(Coords {
            c,
            len: v.len() as u8,
        })
    }

    /// `len` numbers `f(0), f(1), ...`; `len` is clamped into 2..=4.
    pub fn from_fn(len: usize, mut f: impl FnMut(usize) -> f64) -> Coords {
        let mut out = Coords::zeros(len);
        for i in 0..out.len() {
            out.c[i] = f(i);
        }
        out
    }

    /// The numbers of a nalgebra vector of 2 to 4 entries.
    pub fn of<const N: usize>(v: &nalgebra::SVector<f64, N>) -> Coords {
        const { assert!(N >= 2 && N <= MAX_COORDS) };
        let mut c = [0.0; MAX_COORDS];
        c[..N].copy_from_slice(v.as_slice());
        Coords { c, len: N as u8 }
    }

    /// The first `L` numbers as a lifted vector (a missing one read as 0;
    /// callers hold a `Coords` of length `L`).
    pub fn lifted<const L: usize>(&self) -> Lifted<L> {
        self.point::<L>()
    }

    /// The first `D` numbers as a point (the position part of a lifted
    /// variable when `D = len - 1`).
    pub fn point<const D: usize>(&self) -> Point<D> {
        Point::<D>::from_fn(|i, _| self.c.get(i).copied().unwrap_or(0.0))
    }

    /// How many numbers.
    pub fn len(&self) -> usize {
        self.len as usize
    }

    /// Never: a `Coords` holds at least 2 numbers.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The numbers.
    pub fn as_slice(&self) -> &[f64] {
        &self.c[..self.len()]
    }

    /// The numbers, in order.
    pub fn iter(&self) -> std::slice::Iter<'_, f64> {
        self.as_slice().iter()
    }

    /// The last number: `d` of a lifted variable.
    pub fn last(&self) -> f64 {
        self.c[self.len() - 1]
    }

    /// All numbers but the last: the position part of a lifted variable.
    pub fn position(&self) -> Coords {
        Coords {
            c: self.c,
            len: (self.len - 1).max(2),
        }
    }

    /// `2 self - u`, componentwise (the reflected point `r = 2 theta - u`).
    pub fn reflect(&self, u: &Coords) -> Coords {
        self.zip(u, |t, u| 2.0 * t - u)
    }

    /// Every number is finite.
    pub fn is_finite(&self) -> bool {
        self.as_slice().iter().all(|x| x.is_finite())
    }

    /// `f(self_i)` for each `i`.
    pub fn map(&self, f: impl Fn(f64) -> f64) -> Coords {
        Coords::from_fn(self.len(), |i| f(self.c[i]))
    }

    /// `f(self_i, other_i)` for each `i` of `self`.
    pub fn zip(&self, other: &Coords, f: impl Fn(f64, f64) -> f64) -> Coords {
        Coords::from_fn(self.len(), |i| f(self.c[i], other.c[i]))
    }
}

impl<const N: usize> From<[f64; N]> for Coords {
    /// `N` = 2 to 4 numbers (another `N` does not compile).
    fn from(v: [f64; N]) -> Coords {
        Coords::of(&nalgebra::SVector::<f64, N>::from(v))
    }
}

impl std::ops::Index<usize> for Coords {
    type Output = f64;
    fn index(&self, i: usize) -> &f64 {
        &self.as_slice()[i]
    }
}

impl Serialize for Coords {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.as_slice().serialize(s)
    }
}

impl<'de> Deserialize<'de> for Coords {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Coords, D::Error> {
        let v = Vec::<f64>::deserialize(d)?;
        Coords::from_slice(&v).ok_or_else(|| {
            serde::de::Error::custom(format!("expected 2 to 4 numbers, got {}", v.len()))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::geometry::{Vec2, Vec3};

    #[test]
    fn conversions_keep_every_bit_and_the_length() {
        let v = Vec3::new(0.1 + 0.2, -1.0 / 3.0, -0.0);
        let c = Coords::of(&v);
        assert_eq!(c.len(), 3);
        assert_eq!(c.lifted::<3>(), v);
        assert!(c.last().is_sign_negative());
        assert_eq!(c.position().point::<2>(), Vec2::new(v[0], v[1]));
        let w = nalgebra::Vector4::new(1.0, 2.0, 3.0, 4.0);
        assert_eq!(Coords::of(&w).lifted::<4>(), w);
        assert_eq!(Coords::of(&w).position().as_slice(), &[1.0, 2.0, 3.0]);
    }

    #[test]
    fn the_reflection_is_bit_identical_to_nalgebras() {
        let t = Vec3::new(0.1, 1e300, -7.25);
        let u = Vec3::new(0.7, -3e299, 1.0 / 3.0);
        let r = Coords::of(&t).reflect(&Coords::of(&u));
        assert_eq!(r.lifted::<3>(), 2.0 * t - u);
    }

    #[test]
    fn a_slice_of_other_lengths_is_refused_and_serde_round_trips() {
        assert!(Coords::from_slice(&[1.0]).is_none());
        assert!(Coords::from_slice(&[1.0; 5]).is_none());
        let c = Coords::from_slice(&[1.5, -2.0, 3.0, 4.0]).expect("four numbers");
        let s = serde_json::to_string(&c).expect("serializes");
        assert_eq!(s, "[1.5,-2.0,3.0,4.0]");
        let back: Coords = serde_json::from_str(&s).expect("reads back");
        assert_eq!(back, c);
        assert!(serde_json::from_str::<Coords>("[1.0]").is_err());
    }
}
