//! The XML entity descriptions (CREATE by XML and by reference, the strict profile parser and the tolerant
//! fallback) and `-r` reference files on arbitrary text: nothing may panic, and a profile a refs file defines is
//! found again under its name.
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use xrce_agent::middleware::describe::{describe, FallbackProfiles, ProfileSource};
use xrce_agent::middleware::profiles::StoreProfiles;
use xrce_agent::profile::{parse_entity_xml, ProfileStore};
use xrce_proto::object::BinaryObject;
use xrce_proto::{Endianness, EntityVariant, ObjectId, ObjectKind, Representation};

#[derive(Arbitrary, Debug)]
struct Input<'a> {
    kind: u8,
    refs: &'a str,
    xml: &'a str,
    reference: &'a str,
    blob: &'a [u8],
    big_endian: bool,
}

fuzz_target!(|input: Input<'_>| {
    let kind = ObjectKind::from_nibble(input.kind);
    let _ = parse_entity_xml(kind, input.xml);
    let mut store = ProfileStore::new();
    let _ = store.merge_xml_str(input.refs);
    let _ = store.get(kind, input.reference);
    let store = StoreProfiles::with_store(store);
    let endian = if input.big_endian { Endianness::Big } else { Endianness::Little };
    for repr in [
        Representation::Xml(input.xml),
        Representation::Reference(input.reference),
        Representation::Binary(BinaryObject::Raw(input.blob)),
    ] {
        let variant = match kind {
            ObjectKind::Participant => EntityVariant::participant(repr, i16::from(input.kind)),
            _ => EntityVariant::child(kind, repr, ObjectId::new(1, ObjectKind::Participant)),
        };
        let _ = describe(&FallbackProfiles, &variant, endian, 0);
        let _ = describe(&store as &dyn ProfileSource, &variant, endian, 0);
    }
});
