//! CAN FD framing: decoding any data field must not overread, and any message up to 63 bytes must survive
//! encode -> pad -> decode.
#![no_main]

use libfuzzer_sys::fuzz_target;
use xrce_proto::framing::can;

fuzz_target!(|data: &[u8]| {
    if let Ok(msg) = can::decode(data) {
        assert_eq!(Some(&(msg.len() as u8)), data.first());
        assert!(msg.len() <= can::MAX_MESSAGE_LEN);
    }
    let msg = &data[..data.len().min(can::MAX_MESSAGE_LEN)];
    let (frame, padded) = can::encode_padded(msg).expect("63 bytes at most");
    assert!(padded > msg.len() && can::padded_len(padded) == Some(padded));
    assert_eq!(can::decode(&frame[..padded]), Ok(msg));
    assert_eq!(can::dlc(padded).and_then(can::dlc_to_len), Some(padded));
});
