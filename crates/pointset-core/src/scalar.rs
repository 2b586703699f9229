//! Scalar storage types for attribute channels (the PLY scalar types).

use std::fmt;

/// The storage type an attribute channel had in its file, or should have when written.
///
/// Values are always held as `f32` in memory; the storage type only decides how they are
/// encoded on disk, so `uchar` colours and `double` confidences both survive a round trip.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum ScalarType {
    /// Signed 8-bit integer (`char` / `int8`).
    I8,
    /// Unsigned 8-bit integer (`uchar` / `uint8`).
    U8,
    /// Signed 16-bit integer (`short` / `int16`).
    I16,
    /// Unsigned 16-bit integer (`ushort` / `uint16`).
    U16,
    /// Signed 32-bit integer (`int` / `int32`).
    I32,
    /// Unsigned 32-bit integer (`uint` / `uint32`).
    U32,
    /// 32-bit float (`float` / `float32`); the default.
    #[default]
    F32,
    /// 64-bit float (`double` / `float64`).
    F64,
}

impl ScalarType {
    /// Every scalar type, in PLY order.
    pub const ALL: [ScalarType; 8] = [
        ScalarType::I8,
        ScalarType::U8,
        ScalarType::I16,
        ScalarType::U16,
        ScalarType::I32,
        ScalarType::U32,
        ScalarType::F32,
        ScalarType::F64,
    ];

    /// Size of one value in bytes.
    pub fn size(self) -> usize {
        match self {
            ScalarType::I8 | ScalarType::U8 => 1,
            ScalarType::I16 | ScalarType::U16 => 2,
            ScalarType::I32 | ScalarType::U32 | ScalarType::F32 => 4,
            ScalarType::F64 => 8,
        }
    }

    /// Whether the type holds integers.
    pub fn is_integer(self) -> bool {
        !matches!(self, ScalarType::F32 | ScalarType::F64)
    }

    /// Smallest and largest representable value (for integer types).
    pub fn range(self) -> (f64, f64) {
        match self {
            ScalarType::I8 => (i8::MIN.into(), i8::MAX.into()),
            ScalarType::U8 => (0.0, u8::MAX.into()),
            ScalarType::I16 => (i16::MIN.into(), i16::MAX.into()),
            ScalarType::U16 => (0.0, u16::MAX.into()),
            ScalarType::I32 => (i32::MIN.into(), i32::MAX.into()),
            ScalarType::U32 => (0.0, u32::MAX.into()),
            ScalarType::F32 => (f32::MIN.into(), f32::MAX.into()),
            ScalarType::F64 => (f64::MIN, f64::MAX),
        }
    }

    /// The canonical PLY name (`char`, `uchar`, `short`, `ushort`, `int`, `uint`, `float`,
    /// `double`), the spelling every PLY reader accepts.
    pub fn ply_name(self) -> &'static str {
        match self {
            ScalarType::I8 => "char",
            ScalarType::U8 => "uchar",
            ScalarType::I16 => "short",
            ScalarType::U16 => "ushort",
            ScalarType::I32 => "int",
            ScalarType::U32 => "uint",
            ScalarType::F32 => "float",
            ScalarType::F64 => "double",
        }
    }

    /// Parses either PLY spelling (`uchar` or `uint8`, …).
    pub fn from_ply_name(name: &str) -> Option<Self> {
        Some(match name {
            "char" | "int8" => ScalarType::I8,
            "uchar" | "uint8" => ScalarType::U8,
            "short" | "int16" => ScalarType::I16,
            "ushort" | "uint16" => ScalarType::U16,
            "int" | "int32" => ScalarType::I32,
            "uint" | "uint32" => ScalarType::U32,
            "float" | "float32" => ScalarType::F32,
            "double" | "float64" => ScalarType::F64,
            _ => return None,
        })
    }

    /// One value decoded from the first [`Self::size`] bytes of `bytes`, stored
    /// little-endian or big-endian; `None` when `bytes` is shorter.
    ///
    /// ```
    /// use pointset_core::ScalarType;
    ///
    /// assert_eq!(ScalarType::I16.decode(&[0xff, 0xfe], true), Some(-2.0));
    /// assert_eq!(ScalarType::I16.decode(&[0xfe, 0xff], false), Some(-2.0));
    /// assert_eq!(ScalarType::F64.decode(&[0; 4], false), None);
    /// ```
    pub fn decode(self, bytes: &[u8], big_endian: bool) -> Option<f64> {
        /// The first `N` bytes, in little-endian order.
        fn word<const N: usize>(bytes: &[u8], big_endian: bool) -> Option<[u8; N]> {
            let mut out: [u8; N] = bytes.get(..N)?.try_into().ok()?;
            if big_endian {
                out.reverse();
            }
            Some(out)
        }
        Some(match self {
            ScalarType::I8 => f64::from(i8::from_le_bytes(word(bytes, big_endian)?)),
            ScalarType::U8 => f64::from(u8::from_le_bytes(word(bytes, big_endian)?)),
            ScalarType::I16 => f64::from(i16::from_le_bytes(word(bytes, big_endian)?)),
            ScalarType::U16 => f64::from(u16::from_le_bytes(word(bytes, big_endian)?)),
            ScalarType::I32 => f64::from(i32::from_le_bytes(word(bytes, big_endian)?)),
            ScalarType::U32 => f64::from(u32::from_le_bytes(word(bytes, big_endian)?)),
            ScalarType::F32 => f64::from(f32::from_le_bytes(word(bytes, big_endian)?)),
            ScalarType::F64 => f64::from_le_bytes(word(bytes, big_endian)?),
        })
    }

    /// Appends `value` as stored in this type ([`Self::quantize`]) to `buf`, little- or
    /// big-endian: the binary writers' encoding (PLY, PCD).
    pub(crate) fn encode(self, value: f64, big_endian: bool, buf: &mut Vec<u8>) {
        let v = self.quantize(value);
        macro_rules! bytes {
            ($t:ty) => {{
                let x = v as $t;
                if big_endian {
                    buf.extend_from_slice(&x.to_be_bytes())
                } else {
                    buf.extend_from_slice(&x.to_le_bytes())
                }
            }};
        }
        match self {
            ScalarType::I8 => bytes!(i8),
            ScalarType::U8 => bytes!(u8),
            ScalarType::I16 => bytes!(i16),
            ScalarType::U16 => bytes!(u16),
            ScalarType::I32 => bytes!(i32),
            ScalarType::U32 => bytes!(u32),
            ScalarType::F32 => bytes!(f32),
            ScalarType::F64 => bytes!(f64),
        }
    }

    /// Appends `value` as stored in this type ([`Self::quantize`]) to `buf` as text:
    /// integers whole, floats in the shortest form that reads back to the stored value.
    pub(crate) fn encode_text(self, value: f64, buf: &mut Vec<u8>) {
        use std::io::Write;
        let v = self.quantize(value);
        // Writing into a Vec cannot fail.
        let _ = match self {
            ScalarType::F32 => write!(buf, "{}", v as f32),
            ScalarType::F64 => write!(buf, "{v}"),
            _ => write!(buf, "{}", v as i64),
        };
    }

    /// Converts a value for storage: integers are rounded and clamped to the type's range,
    /// `F32` rounds to single precision.
    pub fn quantize(self, value: f64) -> f64 {
        match self {
            ScalarType::F64 => value,
            ScalarType::F32 => f64::from(value as f32),
            _ => {
                let (lo, hi) = self.range();
                value.round().clamp(lo, hi)
            }
        }
    }
}

impl fmt::Display for ScalarType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.ply_name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for t in ScalarType::ALL {
            assert_eq!(ScalarType::from_ply_name(t.ply_name()), Some(t));
        }
        assert_eq!(ScalarType::from_ply_name("uint8"), Some(ScalarType::U8));
        assert_eq!(ScalarType::from_ply_name("quad"), None);
    }

    #[test]
    fn quantize_clamps_integers() {
        assert_eq!(ScalarType::U8.quantize(300.4), 255.0);
        assert_eq!(ScalarType::I8.quantize(-3.6), -4.0);
        assert_eq!(ScalarType::F64.quantize(0.1), 0.1);
    }
}
