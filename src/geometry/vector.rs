//! The vectors and matrices a scene writes: 2 components in a 2D scene,
//! 3 in a 3D one.
//!
//! A scene's dimension is the length of its `grid.max`, known only once
//! the whole file is read; so a [`Vector`] accepts either length when it
//! is parsed, keeps the length it was written with (it serialises back
//! to the same array, so that a scene's text, a checkpoint's copy of it
//! and `cleave study`'s edits round-trip unchanged), and validation
//! checks every vector against the grid's dimension, naming the field.
//! After validation the engine reads fixed arrays ([`Vector::xy`],
//! [`Vector::xyz`], [`Vector::get`]).

use serde::de::{self, SeqAccess, Visitor};
use serde::ser::SerializeSeq;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::fmt;

/// A point or a vector of a scene: 2 or 3 components as written, or
/// unset (a key left out, whose default is zero in either dimension;
/// validation replaces it by the zero of the grid's dimension).
#[derive(Clone, Copy, PartialEq, Default)]
pub struct Vector {
    c: [f64; 3],
    /// 0 (unset), 2 or 3.
    n: u8,
}

impl Vector {
    /// The default of a vector key that is left out.
    pub const UNSET: Vector = Vector { c: [0.0; 3], n: 0 };

    /// The zero vector of `dim` (2 or 3) components.
    pub fn zero(dim: usize) -> Vector {
        Vector {
            c: [0.0; 3],
            n: dim.clamp(2, 3) as u8,
        }
    }

    /// Its number of components: 2, 3, or 0 when unset.
    pub fn len(&self) -> usize {
        self.n as usize
    }

    /// Whether the key was left out (see [`Vector::UNSET`]).
    pub fn is_unset(&self) -> bool {
        self.n == 0
    }

    /// Whether it is empty (unset): the same as [`Vector::is_unset`].
    pub fn is_empty(&self) -> bool {
        self.is_unset()
    }

    /// The components as written.
    pub fn components(&self) -> &[f64] {
        &self.c[..self.len()]
    }

    /// The vector itself if set, else the zero of `dim` components.
    pub fn or_zero(self, dim: usize) -> Vector {
        if self.is_unset() {
            Vector::zero(dim)
        } else {
            self
        }
    }

    /// The first `D` components (zeros beyond those written). For a
    /// validated scene of dimension `D` these are all of them; a 2D
    /// reader of a 3D vector would drop z, which validation and the
    /// methods' refusal of 3D runs rule out.
    pub fn get<const D: usize>(&self) -> [f64; D] {
        debug_assert!(
            self.len() <= D,
            "a {}-component vector read as {D}",
            self.len()
        );
        std::array::from_fn(|i| if i < 3 { self.c[i] } else { 0.0 })
    }

    /// `(x, y)` of a 2D scene's vector.
    pub fn xy(&self) -> [f64; 2] {
        self.get::<2>()
    }

    /// `(x, y, z)` of a 3D scene's vector (z is 0 for a 2-component one).
    pub fn xyz(&self) -> [f64; 3] {
        self.get::<3>()
    }
}

/// Component `i` (0, 1 or 2; a component beyond those written is 0).
impl std::ops::Index<usize> for Vector {
    type Output = f64;
    fn index(&self, i: usize) -> &f64 {
        &self.c[i]
    }
}

impl From<[f64; 2]> for Vector {
    fn from(v: [f64; 2]) -> Vector {
        Vector {
            c: [v[0], v[1], 0.0],
            n: 2,
        }
    }
}

impl From<[f64; 3]> for Vector {
    fn from(v: [f64; 3]) -> Vector {
        Vector { c: v, n: 3 }
    }
}

impl fmt::Debug for Vector {
    /// As written: `[1.0, 2.0]`, `[1.0, 2.0, 3.0]`, or `[]` when unset.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.components()).finish()
    }
}

impl Serialize for Vector {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut seq = s.serialize_seq(Some(self.len()))?;
        for x in self.components() {
            seq.serialize_element(x)?;
        }
        seq.end()
    }
}

impl<'de> Deserialize<'de> for Vector {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Vector, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Vector;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an array of 2 numbers [x, y] (2D) or 3 numbers [x, y, z] (3D)")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vector, A::Error> {
                let mut v = Vector::UNSET;
                let mut n = 0usize;
                while let Some(x) = seq.next_element::<f64>()? {
                    if n < 3 {
                        v.c[n] = x;
                    }
                    n += 1;
                }
                if !(2..=3).contains(&n) {
                    return Err(de::Error::invalid_length(n, &self));
                }
                v.n = n as u8;
                Ok(v)
            }
        }
        d.deserialize_seq(V)
    }
}

/// A square matrix of a scene (a body's `velocity_gradient`): 2×2 or 3×3
/// as written, or unset (zero in either dimension), row by row.
#[derive(Clone, Copy, PartialEq, Default)]
pub struct Matrix {
    rows: [Vector; 3],
    /// Rows written: 0 (unset), 2 or 3.
    n: u8,
}

impl Matrix {
    /// The default of a matrix key that is left out.
    pub const UNSET: Matrix = Matrix {
        rows: [Vector::UNSET; 3],
        n: 0,
    };

    /// The zero matrix of `dim` × `dim`.
    pub fn zero(dim: usize) -> Matrix {
        let dim = dim.clamp(2, 3);
        Matrix {
            rows: [Vector::zero(dim); 3],
            n: dim as u8,
        }
    }

    /// Whether the key was left out.
    pub fn is_unset(&self) -> bool {
        self.n == 0
    }

    /// The rows as written (each may have 2 or 3 components until
    /// validated).
    pub fn rows(&self) -> &[Vector] {
        &self.rows[..self.n as usize]
    }

    /// The matrix itself if set, else the zero of `dim` × `dim`.
    pub fn or_zero(self, dim: usize) -> Matrix {
        if self.is_unset() {
            Matrix::zero(dim)
        } else {
            self
        }
    }

    /// Whether every entry is 0 (an unset matrix is).
    pub fn is_zero(&self) -> bool {
        self.rows()
            .iter()
            .all(|r| r.components().iter().all(|&x| x == 0.0))
    }

    /// The `D` × `D` entries (see [`Vector::get`]).
    pub fn get<const D: usize>(&self) -> [[f64; D]; D] {
        std::array::from_fn(|i| {
            if i < 3 {
                self.rows[i].get::<D>()
            } else {
                [0.0; D]
            }
        })
    }

    /// The 2×2 entries of a 2D scene's matrix.
    pub fn xy(&self) -> [[f64; 2]; 2] {
        self.get::<2>()
    }

    /// The 3×3 entries of a 3D scene's matrix.
    pub fn xyz(&self) -> [[f64; 3]; 3] {
        self.get::<3>()
    }
}

impl From<[[f64; 2]; 2]> for Matrix {
    fn from(m: [[f64; 2]; 2]) -> Matrix {
        Matrix {
            rows: [m[0].into(), m[1].into(), Vector::UNSET],
            n: 2,
        }
    }
}

impl From<[[f64; 3]; 3]> for Matrix {
    fn from(m: [[f64; 3]; 3]) -> Matrix {
        Matrix {
            rows: m.map(Vector::from),
            n: 3,
        }
    }
}

impl fmt::Debug for Matrix {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.rows()).finish()
    }
}

impl Serialize for Matrix {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut seq = s.serialize_seq(Some(self.n as usize))?;
        for r in self.rows() {
            seq.serialize_element(r)?;
        }
        seq.end()
    }
}

impl<'de> Deserialize<'de> for Matrix {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Matrix, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Matrix;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("2 rows of 2 numbers (2D) or 3 rows of 3 numbers (3D)")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Matrix, A::Error> {
                let mut m = Matrix::UNSET;
                let mut n = 0usize;
                while let Some(r) = seq.next_element::<Vector>()? {
                    if n < 3 {
                        m.rows[n] = r;
                    }
                    n += 1;
                }
                if !(2..=3).contains(&n) {
                    return Err(de::Error::invalid_length(n, &self));
                }
                m.n = n as u8;
                Ok(m)
            }
        }
        d.deserialize_seq(V)
    }
}

/// A point of the plane, whether a fixed array or a scene's [`Vector`]
/// (a polyline of either is measured alike: [`super::distance_to_polyline`]).
pub trait Point2: Copy {
    fn xy(self) -> [f64; 2];
}

impl Point2 for [f64; 2] {
    fn xy(self) -> [f64; 2] {
        self
    }
}

impl Point2 for Vector {
    fn xy(self) -> [f64; 2] {
        Vector::xy(&self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vectors_keep_their_length_and_round_trip() {
        for text in ["[1.0,2.0]", "[1.0,2.0,3.0]"] {
            let v: Vector = serde_json::from_str(text).unwrap();
            assert_eq!(serde_json::to_string(&v).unwrap(), text);
        }
        let v: Vector = serde_json::from_str("[1, 2]").unwrap();
        assert_eq!(v.xy(), [1.0, 2.0]);
        assert_eq!(v.xyz(), [1.0, 2.0, 0.0]);
        for bad in ["[1.0]", "[1,2,3,4]", "[]"] {
            let e = serde_json::from_str::<Vector>(bad).unwrap_err().to_string();
            assert!(e.contains("2 numbers [x, y]"), "{bad}: {e}");
        }
        let m: Matrix = serde_json::from_str("[[0,1,0],[0,0,0],[2,0,0]]").unwrap();
        assert_eq!(m.xyz()[2][0], 2.0);
        assert_eq!(
            serde_json::to_string(&m).unwrap(),
            "[[0.0,1.0,0.0],[0.0,0.0,0.0],[2.0,0.0,0.0]]"
        );
        assert!(serde_json::from_str::<Matrix>("[[0,1]]").is_err());
        assert!(Matrix::UNSET.is_zero() && Matrix::zero(3).rows().len() == 3);
        assert_eq!(Vector::UNSET.or_zero(3), Vector::from([0.0; 3]));
    }
}
