//! Fuzzes the 96-bit tag payload decoder: any 16 bytes, and any hex text.
//! A payload that decodes must encode back to the same 96 bits.
#![no_main]
use libfuzzer_sys::fuzz_target;
use waymark::tags::TagPayload;

fuzz_target!(|data: &[u8]| {
    if data.len() >= 16 {
        let bits = u128::from_le_bytes(data[..16].try_into().unwrap()) & ((1u128 << 96) - 1);
        if let Ok(p) = TagPayload::decode(bits) {
            assert_eq!(p.encode().expect("a decoded payload encodes"), bits);
        }
    }
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = TagPayload::from_hex(text);
    }
});
