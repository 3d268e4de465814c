//! Message decoding: header, submessage iteration, every submessage payload and binary blobs must never panic
//! on arbitrary bytes, and whatever decodes must survive encode → decode unchanged.
#![no_main]

use libfuzzer_sys::fuzz_target;
use xrce_proto::message::{parse, MessageBuilder};
use xrce_proto::{Endianness, ObjectVariant, Submessage};

fuzz_target!(|data: &[u8]| {
    let Ok((header, raws)) = parse(data) else { return };
    for raw in raws {
        let Ok(raw) = raw else { break };
        let Ok(sub) = raw.decode() else { continue };
        let endian = raw.header.endianness();
        if let Submessage::Create(c) = sub {
            if let ObjectVariant::Entity(e) = c.variant {
                let _ = e.binary(Endianness::Little);
                let _ = e.binary(Endianness::Big);
            }
        }
        let mut buf = vec![0u8; data.len() + 64];
        let mut builder = MessageBuilder::new(&mut buf, &header).expect("header fits");
        if builder.push(&sub, endian).is_err() {
            continue;
        }
        let n = builder.finish();
        let (again_header, mut again) = parse(&buf[..n]).expect("re-encoded message parses");
        assert_eq!(again_header, header);
        let again = again.next().expect("one submessage").expect("in bounds").decode().expect("decodes");
        assert_eq!(again, sub);
    }
});
