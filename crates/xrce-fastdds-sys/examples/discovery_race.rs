//! Measures how often a new Fast DDS participant misses the answers to its first announcement: with a
//! participant `oracle` running (and whatever DDS peers run beside), it creates `N` participants one after
//! another (`OTHERS` more stay alive beside the oracle) and prints, for each, how long it took to discover every participant the oracle knows (and the
//! oracle), or `missed` when one stayed unknown for the whole wait. Fast DDS sends that first announcement
//! before it listens for answers (`RTPSParticipantImpl::enable`), so a peer that answers at once is not heard
//! until its next periodic announcement, 3 s later by default (docs/dds-engine.md).
//!
//! It starts DDS participants: run it only inside a loopback-only network namespace.
//!
//!   cargo build --release -p xrce-fastdds-sys --example discovery_race
//!   ../shared/dds-peers/netns.sh xrace target/release/examples/discovery_race [N] [WAIT_MS] [OTHERS]

use std::time::{Duration, Instant};

use xrce_fastdds_sys::{Participant, ParticipantConfig};

fn config(name: &str) -> ParticipantConfig {
    ParticipantConfig {
        domain: 0,
        name: name.to_owned(),
        whitelist: Vec::new(),
        announcements: (10, Duration::from_millis(50)),
        shared_memory: xrce_fastdds_sys::SHARED_MEMORY_BY_DEFAULT,
        ..ParticipantConfig::default()
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().map_or(Ok(20), |s| s.parse())?;
    let wait = Duration::from_millis(args.next().map_or(Ok(500), |s| s.parse())?);
    let extra: usize = args.next().map_or(Ok(0), |s| s.parse())?;
    let oracle = Participant::new(&config("race-oracle"))?;
    // Participants that stay, as the other nodes of a booting robot would.
    let _others =
        (0..extra).map(|i| Participant::new(&config(&format!("race-other-{i}")))).collect::<Result<Vec<_>, _>>()?;
    // Let the oracle discover what runs beside it.
    std::thread::sleep(Duration::from_millis(1500));
    let (mut missed, mut times) = (0, Vec::new());
    for i in 0..n {
        let created = Instant::now();
        let p = Participant::new(&config(&format!("race-{i}")))?;
        let made = created.elapsed();
        let mut missing = p.undiscovered(&oracle);
        while missing > 0 && created.elapsed() < wait {
            std::thread::sleep(Duration::from_micros(200));
            missing = p.undiscovered(&oracle);
        }
        let took = created.elapsed();
        if missing > 0 {
            missed += 1;
            println!("{i}: created in {:.1} ms, missed {missing} after {:.1} ms", ms(made), ms(took));
        } else {
            times.push(ms(took));
            println!("{i}: created in {:.1} ms, discovered all in {:.1} ms", ms(made), ms(took));
        }
        drop(p);
        std::thread::sleep(Duration::from_millis(100));
    }
    times.sort_by(f64::total_cmp);
    let median = times.get(times.len() / 2).copied().unwrap_or(f64::NAN);
    println!("participants={n} missed={missed} discovered_median_ms={median:.1}");
    Ok(())
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}
