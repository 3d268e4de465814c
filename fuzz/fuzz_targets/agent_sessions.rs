//! The agent core driven by sessions rather than bytes (structure-aware, `arbitrary`): several clients create
//! sessions (keyed, keyless, again from another address), create entities by XML, reference and binary (valid,
//! invalid, duplicated, deleted), write (whole and in FRAGMENTs), read, play HEARTBEAT/ACKNACK games, lose and
//! repeat messages, let time pass and vanish. After every step: no panic, everything the agent sends parses,
//! and the client table, object tables and transmit queue stay within the configured bounds. The sequence ends
//! on a clean link: a client writes samples reliably to its own reader, and each must arrive once, in order.
#![no_main]

use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

use libfuzzer_sys::fuzz_target;
use xrce_agent::core::{AgentCore, CoreConfig};
use xrce_agent::middleware::ced::Ced;
use xrce_agent::middleware::profiles::StoreProfiles;
use xrce_agent::profile::ProfileStore;
use xrce_fuzz::sessions::{CleanLink, Client, Step, CLEAN_SAMPLES, CLIENTS};

/// Small limits, so that a short sequence reaches every one of them.
fn config() -> CoreConfig {
    CoreConfig {
        max_clients: 3,
        max_objects_per_client: 12,
        max_read_tasks_per_client: 2,
        max_streams_per_client: 4,
        reliable_window: 4,
        max_pending_per_stream: 8,
        max_reassembly_size: 4096,
        max_buffered_bytes_per_client: 8192,
        max_transmit_queue: 16,
        heartbeat_period: Duration::from_millis(200),
        client_dead_time: Duration::from_secs(2),
        remove_silent_clients_after: Some(Duration::from_secs(6)),
        ..CoreConfig::default()
    }
}

/// Messages the core may hold for the shell: per client its stream outbox and its control messages (256),
/// plus replies outside any session (bounded by the same limit).
fn transmit_bound(config: &CoreConfig, clients: usize) -> usize {
    (clients + 1) * (config.max_transmit_queue + 256)
}

/// The sequence ends on a clean link ([`CleanLink`]): a client the agent still holds (else the first) writes
/// and reads its own topic; every sample must arrive once, in order.
fn clean_link(core: &mut AgentCore<u8, Ced>, clients: &mut [Client; CLIENTS], now: &mut Instant, out: &mut Vec<u8>) {
    let registered = core.client_keys();
    let index = clients.iter().position(|c| registered.contains(&c.key)).unwrap_or(0);
    let client = &mut clients[index];
    let mut link = CleanLink::default();
    // Until the agent has nothing more for the client (at most 3 rounds of 1 ms), acknowledging each round.
    let mut pump = |core: &mut AgentCore<u8, Ced>, link: &mut CleanLink, client: &Client, now: &mut Instant| {
        for _ in 0..3 {
            *now += Duration::from_millis(1);
            core.handle_timeout(*now);
            core.poll_middleware(*now);
            let mut heard = false;
            while let Some(endpoint) = core.poll_transmit(*now, out) {
                if endpoint == client.endpoint {
                    link.observe(out);
                    heard = true;
                }
            }
            if !heard {
                break;
            }
            if let Some(ack) = link.acknack(client) {
                core.handle_datagram(client.endpoint, &ack, *now);
            }
        }
    };
    for datagram in CleanLink::setup(client) {
        core.handle_datagram(client.endpoint, &datagram, *now);
        pump(core, &mut link, client, now);
    }
    assert_eq!(link.session_status, Some(0), "the clean link's session was refused");
    for index in 0..CLEAN_SAMPLES {
        if let Some(datagram) = CleanLink::write(client, index) {
            core.handle_datagram(client.endpoint, &datagram, *now);
        }
        pump(core, &mut link, client, now);
    }
    let written: Vec<Vec<u8>> = (0..CLEAN_SAMPLES).map(CleanLink::sample).collect();
    assert_eq!(link.delivered, written, "samples written on a clean link: each once, in order");
}

fuzz_target!(|steps: Vec<Step>| {
    let config = config();
    // Parsed once: the refs file is the same for every input (12 % of the time when parsed per input).
    static REFS: OnceLock<ProfileStore> = OnceLock::new();
    let store = REFS.get_or_init(|| ProfileStore::from_xml_str(xrce_fuzz::sessions::REFS).unwrap_or_default()).clone();
    let mut core = AgentCore::new(config.clone(), Ced::new(Arc::new(StoreProfiles::with_store(store))));
    let mut clients: [Client; CLIENTS] = core::array::from_fn(Client::new);
    let mut now = Instant::now();
    let mut out = Vec::new();
    for step in steps.iter().take(256) {
        if let Step::Time { millis } = step {
            now += Duration::from_millis(u64::from(*millis));
            core.handle_timeout(now);
        } else if let Step::Vanish { client } = step {
            let c = &mut clients[usize::from(*client) % CLIENTS];
            core.forget_endpoint(c.endpoint);
            c.vanish();
        } else {
            for (endpoint, datagram) in xrce_fuzz::sessions::datagrams(step, &mut clients) {
                core.handle_datagram(endpoint, &datagram, now);
            }
        }
        core.poll_middleware(now);
        let registered = core.client_keys().len();
        assert!(registered <= config.max_clients, "{registered} clients registered");
        assert!(core.object_count() <= registered * config.max_objects_per_client);
        assert!(core.pending_transmits() <= transmit_bound(&config, registered));
        while let Some(endpoint) = core.poll_transmit(now, &mut out) {
            xrce_fuzz::assert_parses(&out, "agent");
            if let Some(c) = clients.iter_mut().find(|c| c.endpoint == endpoint) {
                c.observe(&out);
            }
        }
        if let Some(t) = core.poll_timeout() {
            assert!(t + Duration::from_secs(1) >= now, "a deadline more than a second in the past");
        }
    }
    clean_link(&mut core, &mut clients, &mut now, &mut out);
    // Two minutes in 5 s ticks: longer than remove_silent_clients_after plus its probes.
    for _ in 0..24 {
        now += Duration::from_secs(5);
        core.handle_timeout(now);
        while core.poll_transmit(now, &mut out).is_some() {}
    }
    assert!(core.client_keys().is_empty(), "silent clients are removed after remove_silent_clients_after");
});
