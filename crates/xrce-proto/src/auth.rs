//! Pre-shared-key proof in CREATE_CLIENT (our extension; eProsima has none): the client sends the property
//! [`AUTH_PROPERTY`] holding a token `v1.<nonce>.<mac>`, where `nonce` is 16 hex digits the client picks
//! (never twice for one key) and `mac` is HMAC-SHA256 keyed with the pre-shared key over a domain tag, the
//! client key, the session id and the nonce, in 64 hex digits. The agent recomputes the MAC and refuses a
//! nonce it has seen for that key (replay). The token proves the key is held; it encrypts nothing.
//!
//! HMAC-SHA256 comes from RustCrypto's `hmac` and `sha2` (no_std, no heap, constant-time verification):
//! hand-written cryptography is a liability.

use hmac::{Hmac, Mac};
use sha2::Sha256;

use crate::ClientKey;

/// The CREATE_CLIENT property carrying the token.
pub const AUTH_PROPERTY: &str = "xrce_rs_auth";
/// Length of a token in bytes (ASCII): `v1.` + 16 + `.` + 64.
pub const TOKEN_LEN: usize = 3 + 16 + 1 + 64;

const PREFIX: &[u8; 3] = b"v1.";
/// Separates these MACs from any other use of the same key.
const DOMAIN: &[u8] = b"xrce-rs-auth-v1";

type HmacSha256 = Hmac<Sha256>;

/// A token, ready to be sent as the [`AUTH_PROPERTY`] value.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct Token([u8; TOKEN_LEN]);

impl core::fmt::Debug for Token {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl Token {
    /// The token of `key`/`session_id` with `nonce`, under `psk`.
    pub fn new(psk: &[u8], key: ClientKey, session_id: u8, nonce: u64) -> Self {
        let mut out = [0u8; TOKEN_LEN];
        let (prefix, rest) = out.split_at_mut(PREFIX.len());
        crate::bytes::copy(prefix, PREFIX);
        let (nonce_hex, rest) = rest.split_at_mut(16);
        write_hex(&nonce.to_be_bytes(), nonce_hex);
        let (dot, mac_hex) = rest.split_at_mut(1);
        crate::bytes::copy(dot, b".");
        write_hex(&mac(psk, key, session_id, nonce).finalize().into_bytes(), mac_hex);
        Self(out)
    }

    /// The token as the property value.
    pub fn as_str(&self) -> &str {
        // Only ASCII is ever written into it.
        core::str::from_utf8(&self.0).unwrap_or("")
    }
}

/// Why a token was not accepted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TokenError {
    /// Not of the form `v1.<16 hex>.<64 hex>`.
    Malformed,
    /// The MAC does not match: another key, or a token for another client key or session id.
    BadMac,
}

impl core::fmt::Display for TokenError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Malformed => "malformed authentication token",
            Self::BadMac => "authentication token does not match the pre-shared key",
        })
    }
}

/// Checks `token` for `key`/`session_id` under `psk`; the nonce it carries, for the caller's replay check.
pub fn verify(psk: &[u8], key: ClientKey, session_id: u8, token: &str) -> Result<u64, TokenError> {
    let bytes = token.as_bytes();
    if bytes.len() != TOKEN_LEN || !bytes.starts_with(PREFIX) || bytes.get(19) != Some(&b'.') {
        return Err(TokenError::Malformed);
    }
    let mut nonce = [0u8; 8];
    let mut tag = [0u8; 32];
    let (Some(nonce_hex), Some(mac_hex)) = (bytes.get(3..19), bytes.get(20..)) else {
        return Err(TokenError::Malformed);
    };
    if !read_hex(nonce_hex, &mut nonce) || !read_hex(mac_hex, &mut tag) {
        return Err(TokenError::Malformed);
    }
    let nonce = u64::from_be_bytes(nonce);
    mac(psk, key, session_id, nonce).verify_slice(&tag).map_err(|_| TokenError::BadMac)?;
    Ok(nonce)
}

fn mac(psk: &[u8], key: ClientKey, session_id: u8, nonce: u64) -> HmacSha256 {
    // HMAC takes keys of any length (long ones are hashed first), so this cannot fail.
    let mut m = match HmacSha256::new_from_slice(psk) {
        Ok(m) => m,
        Err(_) => unreachable_hmac(),
    };
    m.update(DOMAIN);
    m.update(&key.0);
    m.update(&[session_id]);
    m.update(&nonce.to_be_bytes());
    m
}

#[cold]
fn unreachable_hmac() -> HmacSha256 {
    // `new_from_slice` only fails for MACs with a fixed key size; HMAC has none. An all-zero key keeps this
    // total without a panic.
    <HmacSha256 as hmac::digest::KeyInit>::new(&Default::default())
}

fn write_hex(bytes: &[u8], out: &mut [u8]) {
    let digit = |n: u8| if n < 10 { b'0' + n } else { b'a' + (n - 10) };
    for (b, pair) in bytes.iter().zip(out.chunks_exact_mut(2)) {
        if let [hi, lo] = pair {
            *hi = digit(b >> 4);
            *lo = digit(b & 0x0f);
        }
    }
}

fn read_hex(hex: &[u8], out: &mut [u8]) -> bool {
    if hex.len() != 2 * out.len() {
        return false;
    }
    for (pair, o) in hex.chunks_exact(2).zip(out.iter_mut()) {
        let (Some(hi), Some(lo)) = (pair.first().and_then(|&c| nibble(c)), pair.get(1).and_then(|&c| nibble(c))) else {
            return false;
        };
        *o = (hi << 4) | lo;
    }
    true
}

fn nibble(c: u8) -> Option<u8> {
    match c {
        b'0'..=b'9' => Some(c - b'0'),
        b'a'..=b'f' => Some(c - b'a' + 10),
        b'A'..=b'F' => Some(c - b'A' + 10),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::ToString;

    use super::*;

    const KEY: ClientKey = ClientKey([0xAA, 0xBB, 0xCC, 0xDD]);

    #[test]
    fn a_token_verifies_under_its_key_only() {
        let t = Token::new(b"secret", KEY, 0x01, 42);
        assert_eq!(t.as_str().len(), TOKEN_LEN);
        assert!(t.as_str().starts_with("v1.000000000000002a."));
        assert_eq!(verify(b"secret", KEY, 0x01, t.as_str()), Ok(42));
        assert_eq!(verify(b"other", KEY, 0x01, t.as_str()), Err(TokenError::BadMac));
        assert_eq!(verify(b"secret", ClientKey([0xAA, 0xBB, 0xCC, 0xDE]), 0x01, t.as_str()), Err(TokenError::BadMac));
        assert_eq!(verify(b"secret", KEY, 0x02, t.as_str()), Err(TokenError::BadMac));
    }

    #[test]
    fn the_mac_is_rfc_2104_hmac_sha256() {
        // Same input computed independently (Python: hmac.new(b"k", b"xrce-rs-auth-v1" + bytes.fromhex(
        // "aabbccdd" "01" "0000000000000001"), "sha256").hexdigest()).
        let t = Token::new(b"k", KEY, 0x01, 1);
        assert_eq!(&t.as_str()[20..], EXPECTED_MAC);
    }

    const EXPECTED_MAC: &str = "2b293fafdf4ba59a7ec0775071cd849bf203f956a14db19045ddb0702a793f6f";

    #[test]
    fn malformed_tokens_are_refused_without_panicking() {
        let good = Token::new(b"k", KEY, 1, 7);
        let s = good.as_str();
        let cut = &s[..TOKEN_LEN - 1];
        let v2 = s.replace("v1.", "v2.");
        let not_hex = s.replacen('0', "g", 1);
        for bad in ["", "v1.", cut, &v2, &not_hex, "v1.é"] {
            assert_eq!(verify(b"k", KEY, 1, bad), Err(TokenError::Malformed), "{bad}");
        }
        let _ = s.to_string();
        let upper = s.to_ascii_uppercase().replacen("V1.", "v1.", 1);
        assert_eq!(verify(b"k", KEY, 1, &upper), Ok(7));
    }
}
