//! Points as written in scenario files: `[x, y]` or `[x, y, z]`.
//!
//! A plain `[f64; 2]` field would take the first two numbers of a longer
//! array and drop the rest without a word, so a depth written as `[x, y, z]`
//! would vanish. A [`Pt`] reads any array of two or three numbers and keeps
//! them all; it refuses other lengths, naming what was found. The scenario
//! decides its dimension from its receivers and refuses a point of another
//! dimension by key (see the scenario's `sections::points`). A `Pt` writes
//! back exactly what was read, so saved scenarios are unchanged.
//!
//! The depth axis is `z`, positive upwards (a depth of 100 m is `z = -100`),
//! as in the sonar scenarios' surface at `z = 0`.

use crate::model::geometry::Point;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// A point of a scenario file (metres): two or three finite-or-not numbers
/// (finiteness is checked with the key by the scenario reader).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pt {
    c: [f64; 3],
    dim: usize,
}

impl Pt {
    /// `[x, y]`.
    pub const fn xy(x: f64, y: f64) -> Pt {
        Pt {
            c: [x, y, 0.0],
            dim: 2,
        }
    }

    /// `[x, y, z]`.
    pub const fn xyz(x: f64, y: f64, z: f64) -> Pt {
        Pt {
            c: [x, y, z],
            dim: 3,
        }
    }

    /// The point's coordinates from a slice of 2 or 3 numbers.
    pub fn from_slice(v: &[f64]) -> Result<Pt, String> {
        match *v {
            [x, y] => Ok(Pt::xy(x, y)),
            [x, y, z] => Ok(Pt::xyz(x, y, z)),
            _ => Err(wrong_length(v.len())),
        }
    }

    /// 2 or 3.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The coordinates as written.
    pub fn coords(&self) -> &[f64] {
        &self.c[..self.dim]
    }

    /// Every coordinate is finite.
    pub fn is_finite(&self) -> bool {
        self.coords().iter().all(|x| x.is_finite())
    }

    /// The point in `D` dimensions: its first `D` coordinates, a missing `z`
    /// read as 0. Callers check `dim() == D` first (the scenario reader
    /// refuses mixed dimensions), so nothing is dropped.
    pub fn point<const D: usize>(&self) -> Point<D> {
        Point::<D>::from_fn(|i, _| self.c.get(i).copied().unwrap_or(0.0))
    }

    /// The Euclidean distance to `other` (metres), in 3-D when either point
    /// is 3-D (a 2-D point is at `z = 0`); between two 2-D points exactly
    /// what nalgebra computes on [`Point<2>`].
    pub fn distance(&self, other: &Pt) -> f64 {
        if self.dim == 3 || other.dim == 3 {
            (self.point::<3>() - other.point::<3>()).norm()
        } else {
            (self.point::<2>() - other.point::<2>()).norm()
        }
    }

    /// The point from a position of `D` = 2 or 3 coordinates.
    pub fn of<const D: usize>(p: &Point<D>) -> Pt {
        match D {
            3 => Pt::xyz(p[0], p[1], p[2]),
            _ => Pt::xy(p[0], p[1]),
        }
    }
}

impl From<[f64; 2]> for Pt {
    fn from(p: [f64; 2]) -> Pt {
        Pt::xy(p[0], p[1])
    }
}

impl From<[f64; 3]> for Pt {
    fn from(p: [f64; 3]) -> Pt {
        Pt::xyz(p[0], p[1], p[2])
    }
}

impl std::ops::Index<usize> for Pt {
    type Output = f64;
    fn index(&self, i: usize) -> &f64 {
        &self.coords()[i]
    }
}

/// Why a list of `n` numbers is not a point.
fn wrong_length(n: usize) -> String {
    format!("a point is [x, y] or [x, y, z] in metres: expected 2 or 3 coordinates, got {n}")
}

impl Serialize for Pt {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.coords().serialize(s)
    }
}

impl<'de> Deserialize<'de> for Pt {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Pt, D::Error> {
        let v = Vec::<f64>::deserialize(d)?;
        Pt::from_slice(&v).map_err(serde::de::Error::custom)
    }
}

/// A list of points (`#[serde(with = "crate::model::xy::list")]`): the error
/// names the first bad one by index.
pub mod list {
    use super::{Deserialize, Deserializer, Pt, Serialize, Serializer};
    use serde::de::Error as _;

    /// Read a list of points.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<Pt>, D::Error> {
        let raw = Vec::<Vec<f64>>::deserialize(d)?;
        raw.iter()
            .enumerate()
            .map(|(i, v)| {
                Pt::from_slice(v).map_err(|e| D::Error::custom(format!("point {i}: {e}")))
            })
            .collect()
    }

    /// Write a list of points.
    pub fn serialize<S: Serializer>(p: &[Pt], s: S) -> Result<S::Ok, S::Error> {
        p.serialize(s)
    }
}

#[cfg(test)]
mod tests {
    use super::Pt;
    use serde::Deserialize;

    #[derive(Debug, Deserialize, serde::Serialize)]
    struct One {
        p: Pt,
        #[serde(default, with = "super::list")]
        ps: Vec<Pt>,
    }

    #[test]
    fn a_point_with_two_coordinates_reads_and_writes_as_is() {
        let v: One = toml::from_str("p = [1.5, -2]\nps = [[0, 1], [2, 3]]").expect("valid");
        // Exact: these are the numbers as written.
        assert_eq!(v.p.dim(), 2);
        assert!(
            v.p.coords()
                .iter()
                .zip([1.5, -2.0])
                .all(|(a, b)| a.to_bits() == f64::to_bits(b))
        );
        let flat: Vec<f64> = v.ps.iter().flat_map(|p| p.coords().to_vec()).collect();
        assert_eq!(flat.len(), 4);
        let text = toml::to_string(&v).expect("writes");
        assert!(text.contains("p = [1.5, -2.0]"), "{text}");
    }

    #[test]
    fn a_point_with_three_coordinates_keeps_its_depth() {
        let v: One = toml::from_str("p = [1, 2, -300]\nps = [[0, 1, 2]]").expect("3-D");
        assert_eq!(v.p.dim(), 3);
        assert_eq!(v.p.point::<3>()[2].to_bits(), (-300.0f64).to_bits());
        assert_eq!(v.ps[0].coords().len(), 3);
        let text = toml::to_string(&v).expect("writes");
        assert!(text.contains("p = [1.0, 2.0, -300.0]"), "{text}");
    }

    #[test]
    fn a_point_with_one_or_four_coordinates_is_refused_with_the_count() {
        for (text, n) in [("p = [1]", "got 1"), ("p = [1, 2, 3, 4]", "got 4")] {
            let e = toml::from_str::<One>(text)
                .expect_err("bad length")
                .to_string();
            assert!(e.contains(n) && e.contains("[x, y, z]"), "{e}");
        }
        let e = toml::from_str::<One>("p = [0, 0]\nps = [[0, 1], [1]]")
            .expect_err("bad length")
            .to_string();
        assert!(e.contains("point 1") && e.contains("got 1"), "{e}");
    }
}
