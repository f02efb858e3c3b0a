//! Hand-written `Deserialize` impls of the description's "this or that" values (arrays of a
//! fixed length, one transform step or a list, a colour or a texture table, a number or an
//! array), so that each mistake keeps its position and reason.

use super::*;
use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use std::fmt;

// The three "this or a list" values below get hand-written visitors rather than
// `#[serde(untagged)]`: an untagged enum buffers its input and answers every mistake with "data
// did not match any variant", losing the position and the reason.

impl<'de, T: Deserialize<'de>, const N: usize> Deserialize<'de> for Fixed<T, N> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<T, const N: usize>(std::marker::PhantomData<T>);
        impl<'de, T: Deserialize<'de>, const N: usize> Visitor<'de> for V<T, N> {
            type Value = Fixed<T, N>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                write!(f, "an array of {N} elements")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Fixed<T, N>, A::Error> {
                let mut items = Vec::with_capacity(N);
                while let Some(x) = seq.next_element()? {
                    if items.len() == N {
                        return Err(de::Error::invalid_length(N + 1, &self));
                    }
                    items.push(x);
                }
                let len = items.len();
                items
                    .try_into()
                    .map(Fixed)
                    .map_err(|_| de::Error::invalid_length(len, &self))
            }
        }
        d.deserialize_seq(V(std::marker::PhantomData))
    }
}

impl<'de> Deserialize<'de> for Color {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Color;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an array of 3 numbers or a texture table")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Color, A::Error> {
                Triple::deserialize(de::value::SeqAccessDeserializer::new(seq)).map(Color::Rgb)
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Color, A::Error> {
                TextureDesc::deserialize(de::value::MapAccessDeserializer::new(map))
                    .map(|t| Color::Texture(Box::new(t)))
            }
        }
        d.deserialize_any(V)
    }
}

impl<'de> Deserialize<'de> for TransformDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = TransformDesc;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a transform table or a list of transform tables")
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<TransformDesc, A::Error> {
                let step = TransformStep::deserialize(de::value::MapAccessDeserializer::new(map))?;
                Ok(TransformDesc(vec![step]))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<TransformDesc, A::Error> {
                let steps = Vec::deserialize(de::value::SeqAccessDeserializer::new(seq))?;
                Ok(TransformDesc(steps))
            }
        }
        d.deserialize_any(V)
    }
}

/// Visits a TOML number (integer or float) as f64.
macro_rules! visit_numbers {
    ($value:ty, $wrap:expr) => {
        fn visit_f64<E: de::Error>(self, v: f64) -> Result<$value, E> {
            Ok($wrap(v))
        }
        fn visit_i64<E: de::Error>(self, v: i64) -> Result<$value, E> {
            Ok($wrap(v as f64))
        }
        fn visit_u64<E: de::Error>(self, v: u64) -> Result<$value, E> {
            Ok($wrap(v as f64))
        }
    };
}

impl<'de> Deserialize<'de> for Scale {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Scale;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or an array of 3 numbers")
            }
            visit_numbers!(Scale, Scale::Uniform);
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Scale, A::Error> {
                Triple::deserialize(de::value::SeqAccessDeserializer::new(seq)).map(Scale::PerAxis)
            }
        }
        d.deserialize_any(V)
    }
}

impl<'de> Deserialize<'de> for ConeDeg {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = ConeDeg;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or an array of numbers")
            }
            visit_numbers!(ConeDeg, ConeDeg::All);
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<ConeDeg, A::Error> {
                Vec::deserialize(de::value::SeqAccessDeserializer::new(seq)).map(ConeDeg::PerSegment)
            }
        }
        d.deserialize_any(V)
    }
}

impl<'de> Deserialize<'de> for ScalarDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = ScalarDesc;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or a texture table")
            }
            visit_numbers!(ScalarDesc, ScalarDesc::Value);
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<ScalarDesc, A::Error> {
                TextureDesc::deserialize(de::value::MapAccessDeserializer::new(map))
                    .map(|t| ScalarDesc::Texture(Box::new(t)))
            }
        }
        d.deserialize_any(V)
    }
}
