//! The serde `Deserializer` reading CDR through a [`Reader`].

use serde::de::{self, DeserializeSeed, IntoDeserializer, Visitor};

use super::{Error, Result};
use crate::cdr::{self, Reader};

/// Nesting levels (structs, tuples, sequences, maps, options, enums, newtypes) a [`Deserializer`] accepts by
/// default; only recursive types can come near it.
pub const DEFAULT_MAX_DEPTH: usize = 64;

/// A serde deserializer that reads XCDR v1 through a [`Reader`], aligning relative to the reader's origin and
/// borrowing strings and byte sequences from its input.
///
/// CDR is not self-describing: the type being deserialized drives the reading, and `deserialize_any` is refused.
pub struct Deserializer<'r, 'de> {
    r: &'r mut Reader<'de>,
    /// Sequence and map elements still allowed over the whole value (every element but a zero-sized one takes
    /// at least one byte, so the input length bounds them).
    budget: usize,
    /// Nesting levels still allowed.
    depth: usize,
}

impl<'r, 'de> Deserializer<'r, 'de> {
    /// A deserializer reading at the reader's position, with an element budget of the bytes left and a
    /// nesting limit of [`DEFAULT_MAX_DEPTH`].
    pub fn new(reader: &'r mut Reader<'de>) -> Self {
        let budget = reader.remaining();
        Self { r: reader, budget, depth: DEFAULT_MAX_DEPTH }
    }

    /// Changes the nesting limit.
    pub fn set_max_depth(&mut self, depth: usize) {
        self.depth = depth;
    }

    /// The underlying reader.
    pub fn reader(&mut self) -> &mut Reader<'de> {
        self.r
    }

    /// Runs `f` one nesting level deeper.
    fn nested<T>(&mut self, f: impl FnOnce(&mut Self) -> Result<T>) -> Result<T> {
        self.depth = self.depth.checked_sub(1).ok_or(Error::TooDeep)?;
        let result = f(self);
        self.depth = self.depth.saturating_add(1);
        result
    }

    /// Reads a sequence or map count, checked against the bytes left and the element budget.
    fn read_count(&mut self) -> Result<usize> {
        let count = self.r.read_seq_len(1)?;
        let n = count as usize;
        self.budget = self.budget.checked_sub(n).ok_or(cdr::Error::SequenceTooLong(count))?;
        Ok(n)
    }

    /// Hands `n` consecutive elements to `visitor` and checks that it took them all.
    fn visit_elements<V: Visitor<'de>>(&mut self, n: usize, visitor: V) -> Result<V::Value> {
        self.nested(|de| {
            let mut access = Elements { de, left: n };
            let value = visitor.visit_seq(&mut access)?;
            if access.left == 0 {
                Ok(value)
            } else {
                Err(Error::LengthMismatch)
            }
        })
    }
}

/// Gives a visitor the elements of a sequence, tuple or struct, or the entries of a map.
struct Elements<'a, 'r, 'de> {
    de: &'a mut Deserializer<'r, 'de>,
    left: usize,
}

impl<'de> de::SeqAccess<'de> for Elements<'_, '_, 'de> {
    type Error = Error;

    fn next_element_seed<T: DeserializeSeed<'de>>(&mut self, seed: T) -> Result<Option<T::Value>> {
        if self.left == 0 {
            return Ok(None);
        }
        self.left = self.left.saturating_sub(1);
        seed.deserialize(&mut *self.de).map(Some)
    }

    fn size_hint(&self) -> Option<usize> {
        Some(self.left)
    }
}

impl<'de> de::MapAccess<'de> for Elements<'_, '_, 'de> {
    type Error = Error;

    fn next_key_seed<K: DeserializeSeed<'de>>(&mut self, seed: K) -> Result<Option<K::Value>> {
        if self.left == 0 {
            return Ok(None);
        }
        self.left = self.left.saturating_sub(1);
        seed.deserialize(&mut *self.de).map(Some)
    }

    fn next_value_seed<V: DeserializeSeed<'de>>(&mut self, seed: V) -> Result<V::Value> {
        seed.deserialize(&mut *self.de)
    }

    fn size_hint(&self) -> Option<usize> {
        Some(self.left)
    }
}

impl<'de> de::EnumAccess<'de> for &mut Deserializer<'_, 'de> {
    type Error = Error;
    type Variant = Self;

    fn variant_seed<V: DeserializeSeed<'de>>(self, seed: V) -> Result<(V::Value, Self)> {
        let index = self.r.read_u32()?;
        let value = seed.deserialize(IntoDeserializer::<Error>::into_deserializer(index))?;
        Ok((value, self))
    }
}

impl<'de> de::VariantAccess<'de> for &mut Deserializer<'_, 'de> {
    type Error = Error;

    fn unit_variant(self) -> Result<()> {
        Ok(())
    }

    fn newtype_variant_seed<T: DeserializeSeed<'de>>(self, seed: T) -> Result<T::Value> {
        seed.deserialize(self)
    }

    fn tuple_variant<V: Visitor<'de>>(self, len: usize, visitor: V) -> Result<V::Value> {
        self.visit_elements(len, visitor)
    }

    fn struct_variant<V: Visitor<'de>>(self, fields: &'static [&'static str], visitor: V) -> Result<V::Value> {
        self.visit_elements(fields.len(), visitor)
    }
}

impl<'de> de::Deserializer<'de> for &mut Deserializer<'_, 'de> {
    type Error = Error;

    /// Refused: CDR does not say what type comes next.
    fn deserialize_any<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value> {
        Err(Error::Unsupported("deserialize_any (CDR is not self-describing)"))
    }

    fn deserialize_bool<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        visitor.visit_bool(self.r.read_bool()?)
    }

    fn deserialize_i8<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        visitor.visit_i8(self.r.read_i8()?)
    }

    fn deserialize_i16<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        visitor.visit_i16(self.r.read_i16()?)
    }

    fn deserialize_i32<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        visitor.visit_i32(self.r.read_i32()?)
    }

    fn deserialize_i64<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        visitor.visit_i64(self.r.read_i64()?)
    }

    fn deserialize_i128<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value> {
        Err(Error::Unsupported("128-bit integers"))
    }

    fn deserialize_u8<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        visitor.visit_u8(self.r.read_u8()?)
    }

    fn deserialize_u16<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        visitor.visit_u16(self.r.read_u16()?)
    }

    fn deserialize_u32<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        visitor.visit_u32(self.r.read_u32()?)
    }

    fn deserialize_u64<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        visitor.visit_u64(self.r.read_u64()?)
    }

    fn deserialize_u128<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value> {
        Err(Error::Unsupported("128-bit integers"))
    }

    fn deserialize_f32<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        visitor.visit_f32(self.r.read_f32()?)
    }

    fn deserialize_f64<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        visitor.visit_f64(self.r.read_f64()?)
    }

    /// IDL `char`: one ISO 8859-1 byte, so every byte is a char.
    fn deserialize_char<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        visitor.visit_char(char::from(self.r.read_u8()?))
    }

    fn deserialize_str<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        visitor.visit_borrowed_str(self.r.read_string()?)
    }

    fn deserialize_string<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        self.deserialize_str(visitor)
    }

    fn deserialize_bytes<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        visitor.visit_borrowed_bytes(self.r.read_octet_seq()?)
    }

    fn deserialize_byte_buf<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        self.deserialize_bytes(visitor)
    }

    fn deserialize_option<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        if self.r.read_bool()? {
            self.nested(|de| visitor.visit_some(de))
        } else {
            visitor.visit_none()
        }
    }

    fn deserialize_unit<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        visitor.visit_unit()
    }

    fn deserialize_unit_struct<V: Visitor<'de>>(self, _name: &'static str, visitor: V) -> Result<V::Value> {
        visitor.visit_unit()
    }

    fn deserialize_newtype_struct<V: Visitor<'de>>(self, _name: &'static str, visitor: V) -> Result<V::Value> {
        self.nested(|de| visitor.visit_newtype_struct(de))
    }

    fn deserialize_seq<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        let n = self.read_count()?;
        self.visit_elements(n, visitor)
    }

    fn deserialize_tuple<V: Visitor<'de>>(self, len: usize, visitor: V) -> Result<V::Value> {
        self.visit_elements(len, visitor)
    }

    fn deserialize_tuple_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        len: usize,
        visitor: V,
    ) -> Result<V::Value> {
        self.visit_elements(len, visitor)
    }

    fn deserialize_map<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        let n = self.read_count()?;
        self.nested(|de| {
            let mut access = Elements { de, left: n };
            let value = visitor.visit_map(&mut access)?;
            if access.left == 0 {
                Ok(value)
            } else {
                Err(Error::LengthMismatch)
            }
        })
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value> {
        self.visit_elements(fields.len(), visitor)
    }

    fn deserialize_enum<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _variants: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value> {
        self.nested(|de| visitor.visit_enum(de))
    }

    /// Refused: field and variant names are not on the wire (structs are read by position, variants by index).
    fn deserialize_identifier<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value> {
        Err(Error::Unsupported("identifiers (CDR has no field names)"))
    }

    /// Refused: skipping a value needs to know its type.
    fn deserialize_ignored_any<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value> {
        Err(Error::Unsupported("ignoring a value (CDR is not self-describing)"))
    }

    fn is_human_readable(&self) -> bool {
        false
    }
}
