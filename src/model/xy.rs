//! Serde for points `[x, y]` read from scenario files.
//!
//! A plain `[f64; 2]` field would take the first two numbers of a longer
//! array and drop the rest without a word, so a depth written as `[x, y, z]`
//! would vanish. These helpers read any array and refuse a length other
//! than two, naming what was found; they write the same `[x, y]` as the
//! plain field, so saved scenarios are unchanged.

use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// Why a list of `n` numbers is not a point.
fn wrong_length(n: usize) -> String {
    match n {
        3 => "3-D positions are not supported yet: a point is [x, y] in metres \
              (got three coordinates; the depth would be dropped)"
            .to_string(),
        n => format!("a point is [x, y] in metres: expected 2 coordinates, got {n}"),
    }
}

fn point<E: serde::de::Error>(v: Vec<f64>) -> Result<[f64; 2], E> {
    match v.as_slice() {
        [x, y] => Ok([*x, *y]),
        other => Err(E::custom(wrong_length(other.len()))),
    }
}

/// Read one point (`#[serde(with = "crate::model::xy")]`).
pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 2], D::Error> {
    point(Vec::<f64>::deserialize(d)?)
}

/// Write one point as `[x, y]`.
pub fn serialize<S: Serializer>(p: &[f64; 2], s: S) -> Result<S::Ok, S::Error> {
    p.serialize(s)
}

/// A list of points (`#[serde(with = "crate::model::xy::list")]`).
pub mod list {
    use super::{Deserialize, Deserializer, Serialize, Serializer, point, wrong_length};
    use serde::de::Error as _;

    /// Read a list of points; the error names the first bad one by index.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<[f64; 2]>, D::Error> {
        let raw = Vec::<Vec<f64>>::deserialize(d)?;
        raw.into_iter()
            .enumerate()
            .map(|(i, v)| {
                let n = v.len();
                point::<D::Error>(v)
                    .map_err(|_| D::Error::custom(format!("point {i}: {}", wrong_length(n))))
            })
            .collect()
    }

    /// Write a list of points.
    pub fn serialize<S: Serializer>(p: &[[f64; 2]], s: S) -> Result<S::Ok, S::Error> {
        p.serialize(s)
    }
}

/// An optional point (`#[serde(default, with = "crate::model::xy::option")]`).
pub mod option {
    use super::{Deserialize, Deserializer, Serialize, Serializer, point};

    /// Read an optional point.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<[f64; 2]>, D::Error> {
        Option::<Vec<f64>>::deserialize(d)?.map(point).transpose()
    }

    /// Write an optional point.
    pub fn serialize<S: Serializer>(p: &Option<[f64; 2]>, s: S) -> Result<S::Ok, S::Error> {
        p.serialize(s)
    }
}

#[cfg(test)]
mod tests {
    use serde::Deserialize;

    #[derive(Debug, Deserialize)]
    struct One {
        #[serde(with = "super")]
        p: [f64; 2],
        #[serde(default, with = "super::list")]
        ps: Vec<[f64; 2]>,
    }

    #[test]
    fn a_point_with_two_coordinates_reads_as_is() {
        let v: One = toml::from_str("p = [1.5, -2]\nps = [[0, 1], [2, 3]]").expect("valid");
        // Exact: these are the numbers as written.
        assert!(
            v.p.iter()
                .zip([1.5, -2.0])
                .all(|(a, b)| a.to_bits() == f64::to_bits(b))
        );
        let flat: Vec<f64> = v.ps.iter().flatten().copied().collect();
        assert!(
            flat.iter()
                .zip([0.0, 1.0, 2.0, 3.0])
                .all(|(a, b)| a.to_bits() == f64::to_bits(b))
        );
        assert_eq!(flat.len(), 4);
    }

    #[test]
    fn a_point_with_three_coordinates_is_refused_as_3d_not_truncated() {
        let e = toml::from_str::<One>("p = [1, 2, 3]")
            .expect_err("3-D")
            .to_string();
        assert!(e.contains("3-D positions are not supported yet"), "{e}");
        let e = toml::from_str::<One>("p = [0, 0]\nps = [[0, 1], [1, 2, 3]]")
            .expect_err("3-D")
            .to_string();
        assert!(e.contains("point 1") && e.contains("3-D"), "{e}");
    }

    #[test]
    fn a_point_with_one_or_four_coordinates_is_refused_with_the_count() {
        for (text, n) in [("p = [1]", "got 1"), ("p = [1, 2, 3, 4]", "got 4")] {
            let e = toml::from_str::<One>(text)
                .expect_err("bad length")
                .to_string();
            assert!(e.contains(n), "{e}");
        }
    }
}
