//! What the fuzz campaign found in the client's session core (docs/fuzzing.md), one test per finding.

use xrce_client::prelude::*;
use xrce_client::session::{PingState, MILLIS};
use xrce_client::SessionState;

/// STATUS_AGENT accepting session 0x81.
const STATUS_AGENT: [u8; 19] =
    [0x81, 0, 0, 0, 0x04, 0x01, 0x0B, 0, 0, 0, 0x58, 0x52, 0x43, 0x45, 0x01, 0x00, 0x01, 0x0F, 0x00];

fn established<'a>(now: i64) -> SessionCore<'a> {
    let mut core = SessionCore::new(0x81, 0xAABB_CCDD, 512);
    core.create_session(now);
    let mut out = [0u8; 512];
    while core.poll_transmit(now, &mut out).is_some() {}
    core.handle_input(&STATUS_AGENT, now, &mut ());
    assert_eq!(core.state(), SessionState::Established);
    core
}

/// A ping asked, then the session created (or deleted) again before the ping went out: the ping's retry was
/// left due at the old time, which only an established session sends, so `poll_timeout` kept answering a
/// deadline in the past (an event loop built on it would spin) until the session came back.
#[test]
fn a_pending_ping_fails_when_the_session_is_created_or_deleted_again() {
    let mut out = [0u8; 512];
    for recreate in [true, false] {
        let mut core = established(0);
        core.ping(100, 3, 0);
        assert_eq!(core.ping_state(), PingState::Pending);
        if recreate {
            core.create_session_retries(1, 0);
        } else {
            core.delete_session_retries(1, 0);
        }
        assert_eq!(core.ping_state(), PingState::Failed, "leaving the established session fails the ping");
        let later = 20_000 * MILLIS;
        while core.poll_transmit(later, &mut out).is_some() {}
        if let Some(deadline) = core.poll_timeout() {
            assert!(deadline >= later, "deadline {deadline} is before now {later}");
        }
    }
}
