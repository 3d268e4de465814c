//! The serde `Serializer` writing CDR through a [`Writer`].

use core::fmt::{self, Write as _};

use serde::ser::{self, Serialize};

use super::{Error, Result};
use crate::cdr::Writer;

/// A serde serializer that writes XCDR v1 through a [`Writer`], aligning relative to the writer's origin.
///
/// The writer never fails mid-way: running out of buffer is reported by [`Writer::finish`] together with the
/// size needed. The serializer itself returns an error only for values CDR cannot express.
pub struct Serializer<'w, 'b> {
    w: &'w mut Writer<'b>,
}

impl<'w, 'b> Serializer<'w, 'b> {
    /// A serializer writing at the writer's position.
    pub fn new(writer: &'w mut Writer<'b>) -> Self {
        Self { w: writer }
    }

    /// The underlying writer.
    pub fn writer(&mut self) -> &mut Writer<'b> {
        self.w
    }
}

/// Counts the bytes a `Display` implementation produces.
struct Counter(usize);

impl fmt::Write for Counter {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        self.0 = self.0.saturating_add(s.len());
        Ok(())
    }
}

/// Writes what a `Display` implementation produces into the CDR writer, counting it.
struct Sink<'s, 'b> {
    w: &'s mut Writer<'b>,
    written: usize,
}

impl fmt::Write for Sink<'_, '_> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        self.w.write_bytes(s.as_bytes());
        self.written = self.written.saturating_add(s.len());
        Ok(())
    }
}

impl<'s, 'w, 'b> ser::Serializer for &'s mut Serializer<'w, 'b> {
    type Ok = ();
    type Error = Error;
    type SerializeSeq = Compound<'s, 'w, 'b>;
    type SerializeTuple = Compound<'s, 'w, 'b>;
    type SerializeTupleStruct = Compound<'s, 'w, 'b>;
    type SerializeTupleVariant = Compound<'s, 'w, 'b>;
    type SerializeMap = Compound<'s, 'w, 'b>;
    type SerializeStruct = Compound<'s, 'w, 'b>;
    type SerializeStructVariant = Compound<'s, 'w, 'b>;

    fn serialize_bool(self, v: bool) -> Result<()> {
        self.w.write_bool(v);
        Ok(())
    }

    fn serialize_i8(self, v: i8) -> Result<()> {
        self.w.write_i8(v);
        Ok(())
    }

    fn serialize_i16(self, v: i16) -> Result<()> {
        self.w.write_i16(v);
        Ok(())
    }

    fn serialize_i32(self, v: i32) -> Result<()> {
        self.w.write_i32(v);
        Ok(())
    }

    fn serialize_i64(self, v: i64) -> Result<()> {
        self.w.write_i64(v);
        Ok(())
    }

    fn serialize_i128(self, _v: i128) -> Result<()> {
        Err(Error::Unsupported("128-bit integers"))
    }

    fn serialize_u8(self, v: u8) -> Result<()> {
        self.w.write_u8(v);
        Ok(())
    }

    fn serialize_u16(self, v: u16) -> Result<()> {
        self.w.write_u16(v);
        Ok(())
    }

    fn serialize_u32(self, v: u32) -> Result<()> {
        self.w.write_u32(v);
        Ok(())
    }

    fn serialize_u64(self, v: u64) -> Result<()> {
        self.w.write_u64(v);
        Ok(())
    }

    fn serialize_u128(self, _v: u128) -> Result<()> {
        Err(Error::Unsupported("128-bit integers"))
    }

    fn serialize_f32(self, v: f32) -> Result<()> {
        self.w.write_f32(v);
        Ok(())
    }

    fn serialize_f64(self, v: f64) -> Result<()> {
        self.w.write_f64(v);
        Ok(())
    }

    /// IDL `char`: one ISO 8859-1 byte; chars above `U+00FF` are refused.
    fn serialize_char(self, v: char) -> Result<()> {
        let byte = u8::try_from(v).map_err(|_| Error::Unsupported("char outside ISO 8859-1"))?;
        self.w.write_u8(byte);
        Ok(())
    }

    fn serialize_str(self, v: &str) -> Result<()> {
        self.w.write_string(v);
        Ok(())
    }

    fn serialize_bytes(self, v: &[u8]) -> Result<()> {
        self.w.write_octet_seq(v);
        Ok(())
    }

    fn serialize_none(self) -> Result<()> {
        self.w.write_bool(false);
        Ok(())
    }

    fn serialize_some<T: Serialize + ?Sized>(self, value: &T) -> Result<()> {
        self.w.write_bool(true);
        value.serialize(self)
    }

    fn serialize_unit(self) -> Result<()> {
        Ok(())
    }

    fn serialize_unit_struct(self, _name: &'static str) -> Result<()> {
        Ok(())
    }

    fn serialize_unit_variant(self, _name: &'static str, variant_index: u32, _variant: &'static str) -> Result<()> {
        self.w.write_u32(variant_index);
        Ok(())
    }

    fn serialize_newtype_struct<T: Serialize + ?Sized>(self, _name: &'static str, value: &T) -> Result<()> {
        value.serialize(self)
    }

    fn serialize_newtype_variant<T: Serialize + ?Sized>(
        self,
        _name: &'static str,
        variant_index: u32,
        _variant: &'static str,
        value: &T,
    ) -> Result<()> {
        self.w.write_u32(variant_index);
        value.serialize(self)
    }

    fn serialize_seq(self, len: Option<usize>) -> Result<Compound<'s, 'w, 'b>> {
        let len = len.ok_or(Error::Unsupported("sequence of unknown length"))?;
        self.w.write_seq_len(len);
        Ok(Compound::counted(self, len))
    }

    fn serialize_tuple(self, _len: usize) -> Result<Compound<'s, 'w, 'b>> {
        Ok(Compound::fixed(self))
    }

    fn serialize_tuple_struct(self, _name: &'static str, _len: usize) -> Result<Compound<'s, 'w, 'b>> {
        Ok(Compound::fixed(self))
    }

    fn serialize_tuple_variant(
        self,
        _name: &'static str,
        variant_index: u32,
        _variant: &'static str,
        _len: usize,
    ) -> Result<Compound<'s, 'w, 'b>> {
        self.w.write_u32(variant_index);
        Ok(Compound::fixed(self))
    }

    fn serialize_map(self, len: Option<usize>) -> Result<Compound<'s, 'w, 'b>> {
        let len = len.ok_or(Error::Unsupported("map of unknown length"))?;
        self.w.write_seq_len(len);
        Ok(Compound::counted(self, len))
    }

    fn serialize_struct(self, _name: &'static str, _len: usize) -> Result<Compound<'s, 'w, 'b>> {
        Ok(Compound::fixed(self))
    }

    fn serialize_struct_variant(
        self,
        _name: &'static str,
        variant_index: u32,
        _variant: &'static str,
        _len: usize,
    ) -> Result<Compound<'s, 'w, 'b>> {
        self.w.write_u32(variant_index);
        Ok(Compound::fixed(self))
    }

    /// A string built by a `Display` implementation, formatted twice (once to learn its length) without
    /// allocating.
    fn collect_str<T: fmt::Display + ?Sized>(self, value: &T) -> Result<()> {
        let mut counter = Counter(0);
        write!(counter, "{value}").map_err(|_| Error::Unsupported("Display implementation failed"))?;
        self.w.write_seq_len(counter.0.saturating_add(1));
        let mut sink = Sink { w: self.w, written: 0 };
        write!(sink, "{value}").map_err(|_| Error::Unsupported("Display implementation failed"))?;
        if sink.written != counter.0 {
            return Err(Error::LengthMismatch);
        }
        self.w.write_u8(0);
        Ok(())
    }

    fn is_human_readable(&self) -> bool {
        false
    }
}

/// Serializes the parts of a sequence, map, tuple, struct or variant.
pub struct Compound<'s, 'w, 'b> {
    ser: &'s mut Serializer<'w, 'b>,
    /// Element count announced on the wire (sequences and maps), checked at the end.
    announced: Option<usize>,
    count: usize,
}

impl<'s, 'w, 'b> Compound<'s, 'w, 'b> {
    fn counted(ser: &'s mut Serializer<'w, 'b>, len: usize) -> Self {
        Self { ser, announced: Some(len), count: 0 }
    }

    fn fixed(ser: &'s mut Serializer<'w, 'b>) -> Self {
        Self { ser, announced: None, count: 0 }
    }

    fn element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<()> {
        self.count = self.count.saturating_add(1);
        value.serialize(&mut *self.ser)
    }

    fn finish(self) -> Result<()> {
        match self.announced {
            Some(n) if n != self.count => Err(Error::LengthMismatch),
            _ => Ok(()),
        }
    }
}

impl ser::SerializeSeq for Compound<'_, '_, '_> {
    type Ok = ();
    type Error = Error;

    fn serialize_element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<()> {
        self.element(value)
    }

    fn end(self) -> Result<()> {
        self.finish()
    }
}

impl ser::SerializeTuple for Compound<'_, '_, '_> {
    type Ok = ();
    type Error = Error;

    fn serialize_element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<()> {
        self.element(value)
    }

    fn end(self) -> Result<()> {
        self.finish()
    }
}

impl ser::SerializeTupleStruct for Compound<'_, '_, '_> {
    type Ok = ();
    type Error = Error;

    fn serialize_field<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<()> {
        self.element(value)
    }

    fn end(self) -> Result<()> {
        self.finish()
    }
}

impl ser::SerializeTupleVariant for Compound<'_, '_, '_> {
    type Ok = ();
    type Error = Error;

    fn serialize_field<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<()> {
        self.element(value)
    }

    fn end(self) -> Result<()> {
        self.finish()
    }
}

impl ser::SerializeMap for Compound<'_, '_, '_> {
    type Ok = ();
    type Error = Error;

    fn serialize_key<T: Serialize + ?Sized>(&mut self, key: &T) -> Result<()> {
        self.element(key)
    }

    fn serialize_value<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<()> {
        value.serialize(&mut *self.ser)
    }

    fn end(self) -> Result<()> {
        self.finish()
    }
}

impl ser::SerializeStruct for Compound<'_, '_, '_> {
    type Ok = ();
    type Error = Error;

    fn serialize_field<T: Serialize + ?Sized>(&mut self, _key: &'static str, value: &T) -> Result<()> {
        self.element(value)
    }

    /// CDR members cannot be left out: the reader would take the next member for this one.
    fn skip_field(&mut self, _key: &'static str) -> Result<()> {
        Err(Error::Unsupported("skipping a struct field (skip_serializing_if)"))
    }

    fn end(self) -> Result<()> {
        self.finish()
    }
}

impl ser::SerializeStructVariant for Compound<'_, '_, '_> {
    type Ok = ();
    type Error = Error;

    fn serialize_field<T: Serialize + ?Sized>(&mut self, _key: &'static str, value: &T) -> Result<()> {
        self.element(value)
    }

    /// CDR members cannot be left out: the reader would take the next member for this one.
    fn skip_field(&mut self, _key: &'static str) -> Result<()> {
        Err(Error::Unsupported("skipping a struct field (skip_serializing_if)"))
    }

    fn end(self) -> Result<()> {
        self.finish()
    }
}
