//! The pieces of the benchmarks that need no agent: parsing, statistics, reports, the UDP ceiling.

use std::time::Duration;

use xrce_bench::client::history_for;
use xrce_bench::procstat::{parse_stat, parse_status};
use xrce_bench::report::{json_line, table};
use xrce_bench::udp_ceiling::{self, CeilingConfig};
use xrce_bench::{client_key, parse_duration, Percentiles, SampleHeader};

#[test]
fn durations() {
    assert_eq!(parse_duration("5s"), Ok(Duration::from_secs(5)));
    assert_eq!(parse_duration("5"), Ok(Duration::from_secs(5)));
    assert_eq!(parse_duration("250ms"), Ok(Duration::from_millis(250)));
    assert_eq!(parse_duration("1.5s"), Ok(Duration::from_millis(1500)));
    assert_eq!(parse_duration("2m"), Ok(Duration::from_secs(120)));
    assert_eq!(parse_duration("40us"), Ok(Duration::from_micros(40)));
    assert!(parse_duration("5 parsecs").is_err());
    assert!(parse_duration("").is_err());
}

#[test]
fn proc_stat_with_spaces_and_parentheses_in_the_name() {
    let stat = "1234 (Micro XRCE) (agent)) S 1 1234 1234 0 -1 4194560 1000 0 0 0 250 75 0 0 20 0 4 0 100 \
                123456789 1792 18446744073709551615 0 0 0 0 0 0 0 0 0 0 0 0 17 1 0 0 0 0 0";
    assert_eq!(parse_stat(stat), Some(325));
    assert_eq!(parse_stat("garbage"), None);
    let status = "Name:\tMicroXRCEAgent\nVmPeak:\t  300000 kB\nVmHWM:\t    9000 kB\nVmRSS:\t    7168 kB\n";
    assert_eq!(parse_status(status), (Some(7168), Some(9000)));
    assert_eq!(parse_status("Name: x\n"), (None, None));
}

#[test]
fn proc_of_this_process() {
    let s = xrce_bench::procstat::sample(std::process::id()).unwrap();
    assert!(s.rss_kib > 0 && s.hwm_kib >= s.rss_kib);
}

#[test]
fn percentiles_nearest_rank() {
    let mut v: Vec<f64> = (1..=100).rev().map(f64::from).collect();
    let p = Percentiles::of(&mut v);
    assert_eq!((p.count, p.min, p.p50, p.p90, p.p99, p.max), (100, 1.0, 50.0, 90.0, 99.0, 100.0));
    assert!((p.mean - 50.5).abs() < 1e-9);
    assert_eq!(Percentiles::of(&mut []), Percentiles::default());
    assert_eq!(Percentiles::of(&mut [7.0]).p99, 7.0);
}

#[test]
fn sample_header_round_trip_and_truncation() {
    let h = SampleHeader { publisher: 3, seq: 0xDEAD_BEEF, sent_ns: 42 };
    let mut buf = [0xFFu8; 32];
    h.write(&mut buf);
    assert_eq!(SampleHeader::read(&buf), Some(h));
    let mut short = [0u8; 8];
    h.write(&mut short);
    assert_eq!(SampleHeader::read(&short), None);
}

#[test]
fn keys_are_distinct_and_never_zero() {
    let mut keys: Vec<u32> = (0..20_000).map(|i| client_key(0x1234_5678, i)).collect();
    assert!(keys.iter().all(|&k| k != 0));
    keys.sort_unstable();
    keys.dedup();
    assert_eq!(keys.len(), 20_000);
}

#[test]
fn fragment_history() {
    assert_eq!(history_for(16, 512, 8), 8);
    assert_eq!(history_for(4096, 512, 8), 16);
    assert_eq!(history_for(1024, 512, 1), 4);
    assert!(history_for(60_000, 512, 8).is_power_of_two());
}

#[test]
fn table_aligns_and_json_is_one_line() {
    let t = table(&["a", "long title"], &[vec!["12345".into(), "1".into()], vec!["1".into(), "22".into()]]);
    let lines: Vec<&str> = t.lines().collect();
    assert_eq!(lines, vec!["    a  long title", "-----  ----------", "12345           1", "    1          22"]);
    let j = json_line(&Percentiles::default());
    assert!(j.starts_with('{') && !j.contains('\n'));
}

#[test]
fn udp_ceiling_smoke() {
    let cfg = CeilingConfig { payload: 16, duration: Duration::from_millis(200), echo_samples: 200 };
    let r = udp_ceiling::run(&cfg, &|_| {}).unwrap();
    assert!(r.sent > 0 && r.received_per_s > 0.0);
    assert_eq!(r.echo_rtt_us.count, 200);
}
