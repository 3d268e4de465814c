//! The pre-shared-key token in CREATE_CLIENT (`SessionCore::set_pre_shared_key`), as our agent checks it.
#![cfg(feature = "psk")]

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

/// Reconnection (the `reconnect` feature, on with `std`) re-creates the session with a fresh token.
#[cfg(feature = "reconnect")]
mod reconnect {
    use super::*;
    use xrce_client::session::Reconnect;
    use xrce_proto::object::AgentRepresentation;
    use xrce_proto::submessage::{Info, StatusAgent};
    use xrce_proto::{
        BaseObjectReply, BaseObjectRequest, Endianness, MessageHeader, ResultStatus, StatusCode, StreamId,
    };

    fn agent_says(core: &mut SessionCore<'_>, sub: &Submessage<'_>, now: i64) {
        let header = MessageHeader::new(0x01, StreamId::NONE, 0, ClientKey::from_u32(0xAABB_CCDD));
        let mut buf = [0u8; 128];
        let n = message::encode_single(&mut buf, &header, sub, Endianness::Little).expect("encode");
        core.handle_input(&buf[..n], now, &mut ());
    }

    #[test]
    fn a_session_recreated_after_a_loss_carries_a_fresh_token() {
        const PSK: &[u8] = b"0123456789abcdef0123456789abcdef";
        const MS: i64 = 1_000_000;
        let key = ClientKey::from_u32(0xAABB_CCDD);
        let mut core: SessionCore<'_> = SessionCore::new(0x01, 0xAABB_CCDD, 512);
        core.set_reconnect(Some(Reconnect::default()));
        core.set_pre_shared_key(PSK, 7);
        core.create_session(0);
        let first = create_client_properties(&mut core, 0).0.expect("token");
        assert_eq!(verify(PSK, key, 0x01, &first), Ok(7));
        let ok = StatusAgent { result: ResultStatus::new(StatusCode::OK), agent: AgentRepresentation::EPROSIMA };
        agent_says(&mut core, &Submessage::StatusAgent(ok), MS);
        // The agent dropped the session (a ghost timeout, say) without restarting: it answers a probe with "not
        // known", the client creates the session again, and a replay of its old token would be refused.
        core.reconnect(2 * MS);
        let mut buf = [0u8; 512];
        while core.poll_transmit(3 * MS, &mut buf).is_some() {}
        let unknown = Info {
            reply: BaseObjectReply {
                related_request: BaseObjectRequest::default(),
                result: ResultStatus { status: StatusCode::OK, implementation_status: 0 },
            },
            config: None,
            activity: None,
        };
        agent_says(&mut core, &Submessage::Info(unknown), 4 * MS);
        let again = create_client_properties(&mut core, 5 * MS).0.expect("a new CREATE_CLIENT with a token");
        assert_eq!(verify(PSK, key, 0x01, &again), Ok(8));
    }
}
