//! The pre-shared-key token in CREATE_CLIENT (`SessionCore::set_pre_shared_key`), as our agent checks it.

use xrce_client::session::SessionCore;
use xrce_proto::auth::{verify, AUTH_PROPERTY};
use xrce_proto::{message, ClientKey, Submessage};

/// The `xrce_rs_auth` and `xrce_rs_pack` properties of the next CREATE_CLIENT, as owned strings.
fn create_client_properties(core: &mut SessionCore<'_>, now: i64) -> (Option<String>, Option<String>) {
    let mut buf = [0u8; 512];
    let n = core.poll_transmit(now, &mut buf).expect("a CREATE_CLIENT");
    let (_, mut subs) = message::parse(&buf[..n]).expect("header");
    let raw = subs.next().expect("one submessage").expect("well formed");
    let Ok(Submessage::CreateClient(rep)) = raw.decode() else { panic!("not a CREATE_CLIENT") };
    (rep.property(AUTH_PROPERTY).map(str::to_owned), rep.property("xrce_rs_pack").map(str::to_owned))
}

#[test]
fn create_client_carries_a_token_the_agent_verifies_and_each_session_a_new_nonce() {
    const PSK: &[u8] = b"0123456789abcdef0123456789abcdef";
    let key = ClientKey::from_u32(0xAABB_CCDD);
    let mut core: SessionCore<'_> = SessionCore::new(0x01, 0xAABB_CCDD, 512);
    core.create_session(0);
    assert_eq!(create_client_properties(&mut core, 0), (None, None), "no property unless asked");

    core.set_pre_shared_key(PSK, 41);
    core.set_packed_input(true);
    core.create_session(0);
    let (token, pack) = create_client_properties(&mut core, 0);
    let token = token.expect("the token");
    assert_eq!(pack.as_deref(), Some("1"), "other properties still go");
    assert_eq!(verify(PSK, key, 0x01, &token), Ok(41));
    assert!(verify(b"another key of 32 bytes, wrong!!", key, 0x01, &token).is_err());
    // A retry of the same creation resends the same token.
    let retry = create_client_properties(&mut core, 1_000_000_001).0.expect("retry");
    assert_eq!(retry, token);
    // The next creation has a fresh nonce.
    core.create_session(2_000_000_000);
    let next = create_client_properties(&mut core, 2_000_000_000).0.expect("token");
    assert_eq!(verify(PSK, key, 0x01, &next), Ok(42));
}
