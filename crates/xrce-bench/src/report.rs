//! Printing results: aligned tables for people, JSON lines for scripts.

use crate::latency::LatencyResult;
use crate::sessions::SessionsResult;
use crate::throughput::ThroughputResult;
use crate::udp_ceiling::CeilingResult;

/// A result that prints as a table row.
pub trait Row {
    /// Column titles.
    fn headers() -> Vec<&'static str>;
    /// The cells.
    fn cells(&self) -> Vec<String>;
}

/// An aligned table: titles, a rule, rows (numbers right-aligned).
pub fn table(headers: &[&str], rows: &[Vec<String>]) -> String {
    let mut widths: Vec<usize> = headers.iter().map(|h| h.chars().count()).collect();
    for r in rows {
        for (w, c) in widths.iter_mut().zip(r) {
            *w = (*w).max(c.chars().count());
        }
    }
    let line = |cells: &mut dyn Iterator<Item = &str>| {
        let mut s = String::new();
        for (i, (c, w)) in cells.zip(&widths).enumerate() {
            if i > 0 {
                s.push_str("  ");
            }
            s.push_str(&format!("{c:>w$}"));
        }
        s.trim_end().to_string()
    };
    let mut out = line(&mut headers.iter().copied());
    out.push('\n');
    out.push_str(widths.iter().map(|w| "-".repeat(*w)).collect::<Vec<_>>().join("  ").trim_end());
    out.push('\n');
    for r in rows {
        out.push_str(&line(&mut r.iter().map(String::as_str)));
        out.push('\n');
    }
    out
}

/// Rows of results as a table.
pub fn rows<R: Row>(results: &[R]) -> String {
    let cells: Vec<Vec<String>> = results.iter().map(Row::cells).collect();
    table(&R::headers(), &cells)
}

/// One JSON line.
pub fn json_line<T: serde::Serialize>(v: &T) -> String {
    serde_json::to_string(v).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
}

fn k(v: f64) -> String {
    if v >= 10_000.0 {
        format!("{:.1}k", v / 1000.0)
    } else {
        format!("{v:.0}")
    }
}

fn opt<T>(v: Option<T>, f: impl FnOnce(T) -> String) -> String {
    v.map_or_else(|| "-".into(), f)
}

fn mib(kib: u64) -> String {
    format!("{:.1}", kib as f64 / 1024.0)
}

impl Row for ThroughputResult {
    fn headers() -> Vec<&'static str> {
        vec![
            "mode",
            "payload",
            "P",
            "S",
            "mtu",
            "hist",
            "sent/s",
            "recv/s",
            "loss %",
            "dup",
            "ooo",
            "blocked",
            "agent cpu %",
            "agent peak MiB",
        ]
    }
    fn cells(&self) -> Vec<String> {
        vec![
            self.mode.into(),
            self.payload.to_string(),
            self.publishers.to_string(),
            self.subscribers.to_string(),
            self.mtu.to_string(),
            if self.sub_history != self.history {
                format!("{}/{}", self.history, self.sub_history)
            } else {
                self.history.to_string()
            },
            k(self.sent_per_s),
            k(self.received_per_s),
            format!("{:.2}", self.loss_pct),
            self.duplicates.to_string(),
            self.out_of_order.to_string(),
            self.would_block.to_string(),
            opt(self.agent, |a| format!("{:.0}", a.cpu_percent)),
            opt(self.agent, |a| mib(a.peak_rss_kib)),
        ]
    }
}

impl Row for LatencyResult {
    fn headers() -> Vec<&'static str> {
        vec!["mode", "payload", "samples", "lost", "min µs", "p50 µs", "p90 µs", "p99 µs", "max µs"]
    }
    fn cells(&self) -> Vec<String> {
        let r = &self.rtt_us;
        vec![
            self.mode.into(),
            self.payload.to_string(),
            self.samples.to_string(),
            self.lost.to_string(),
            format!("{:.0}", r.min),
            format!("{:.0}", r.p50),
            format!("{:.0}", r.p90),
            format!("{:.0}", r.p99),
            format!("{:.0}", r.max),
        ]
    }
}

impl Row for SessionsResult {
    fn headers() -> Vec<&'static str> {
        vec![
            "clients",
            "ok",
            "failed",
            "seconds",
            "clients/s",
            "p50 ms",
            "p99 ms",
            "agent RSS start MiB",
            "after warm-up MiB",
            "after MiB",
            "per client B",
            "incl. one-off B",
            "agent cpu %",
        ]
    }
    fn cells(&self) -> Vec<String> {
        vec![
            self.clients.to_string(),
            self.ok.to_string(),
            self.failed.to_string(),
            format!("{:.2}", self.elapsed_s),
            format!("{:.0}", self.clients_per_s),
            format!("{:.1}", self.create_ms.p50),
            format!("{:.1}", self.create_ms.p99),
            opt(self.agent_rss_start_kib, mib),
            opt(self.agent_rss_before_kib, mib),
            opt(self.agent_rss_after_kib, mib),
            opt(self.agent_rss_per_client_b, |b| format!("{b:.0}")),
            opt(self.agent_rss_per_client_total_b, |b| format!("{b:.0}")),
            opt(self.agent, |a| format!("{:.0}", a.cpu_percent)),
        ]
    }
}

impl Row for CeilingResult {
    fn headers() -> Vec<&'static str> {
        vec!["payload", "sent/s", "recv/s", "loss %", "echo p50 µs", "echo p99 µs"]
    }
    fn cells(&self) -> Vec<String> {
        vec![
            self.payload.to_string(),
            k(self.sent_per_s),
            k(self.received_per_s),
            format!("{:.2}", self.loss_pct),
            format!("{:.0}", self.echo_rtt_us.p50),
            format!("{:.0}", self.echo_rtt_us.p99),
        ]
    }
}

impl Row for crate::ros::RosResult {
    fn headers() -> Vec<&'static str> {
        vec!["direction", "payload", "rate", "hist", "written", "received", "p50 µs", "p99 µs", "agent µs/sample"]
    }
    fn cells(&self) -> Vec<String> {
        let direction = match self.direction {
            Some(crate::ros::Direction::ToRos) => "to-ros",
            Some(crate::ros::Direction::FromRos) => "from-ros",
            None => "",
        };
        let from_ros = self.direction == Some(crate::ros::Direction::FromRos);
        let lat = |v: f64| if from_ros { format!("{v:.0}") } else { "-".into() };
        vec![
            direction.into(),
            self.payload.to_string(),
            format!("{:.0}", self.rate),
            self.history.to_string(),
            self.written.to_string(),
            self.received.to_string(),
            lat(self.latency_us.p50),
            lat(self.latency_us.p99),
            self.agent_cpu_us_per_sample.map_or_else(|| "-".into(), |v| format!("{v:.1}")),
        ]
    }
}
