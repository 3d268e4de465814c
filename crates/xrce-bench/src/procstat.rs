//! CPU and memory of another process (the agent), read from `/proc/PID/stat` and `/proc/PID/status`.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// One reading of a process.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ProcSample {
    /// User + system CPU time, in clock ticks.
    pub cpu_ticks: u64,
    /// Resident set size (`VmRSS`), KiB.
    pub rss_kib: u64,
    /// Peak resident set size since the process started (`VmHWM`), KiB.
    pub hwm_kib: u64,
}

/// `utime + stime` (fields 14 and 15) from the text of `/proc/PID/stat`. The command name (field 2) may hold
/// spaces and parentheses, so fields are counted after the last `)`.
pub fn parse_stat(text: &str) -> Option<u64> {
    let rest = text.get(text.rfind(')')? + 1..)?;
    // After ")": field 3 (state) is the first.
    let mut fields = rest.split_whitespace();
    let utime: u64 = fields.nth(11)?.parse().ok()?;
    let stime: u64 = fields.next()?.parse().ok()?;
    Some(utime + stime)
}

/// `(VmRSS, VmHWM)` in KiB from the text of `/proc/PID/status`.
pub fn parse_status(text: &str) -> (Option<u64>, Option<u64>) {
    let field = |name: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(name))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
    };
    (field("VmRSS:"), field("VmHWM:"))
}

/// Reads process `pid` now.
pub fn sample(pid: u32) -> std::io::Result<ProcSample> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat"))?;
    let status = std::fs::read_to_string(format!("/proc/{pid}/status"))?;
    let cpu_ticks = parse_stat(&stat).ok_or_else(|| std::io::Error::other("unparsable /proc/PID/stat"))?;
    let (rss, hwm) = parse_status(&status);
    Ok(ProcSample { cpu_ticks, rss_kib: rss.unwrap_or(0), hwm_kib: hwm.unwrap_or(0) })
}

/// Clock ticks per second (`getconf CLK_TCK`), 100 when it cannot be asked (the value on Linux x86_64).
pub fn clock_ticks() -> u64 {
    std::process::Command::new("getconf")
        .arg("CLK_TCK")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .and_then(|s| s.trim().parse().ok())
        .filter(|&t| t > 0)
        .unwrap_or(100)
}

/// What the agent used over a measured window.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct AgentUsage {
    /// CPU time over wall time, percent of one core (200 = two cores busy).
    pub cpu_percent: f64,
    /// Largest `VmRSS` sampled during the window, KiB.
    pub peak_rss_kib: u64,
    /// `VmRSS` at the start of the window, KiB.
    pub rss_start_kib: u64,
    /// `VmRSS` at the end of the window, KiB.
    pub rss_end_kib: u64,
    /// `VmHWM` at the end (peak over the agent's whole life), KiB.
    pub hwm_kib: u64,
}

/// Samples a process periodically on a thread from [`Monitor::start`] to [`Monitor::stop`].
#[derive(Debug)]
pub struct Monitor {
    pid: u32,
    first: ProcSample,
    started: Instant,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<u64>>,
}

impl Monitor {
    /// Starts sampling `pid` every `period`.
    pub fn start(pid: u32, period: Duration) -> std::io::Result<Self> {
        let first = sample(pid)?;
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        let thread = std::thread::Builder::new().name("agent-monitor".into()).spawn(move || {
            let mut peak = first.rss_kib;
            while !flag.load(Ordering::Relaxed) {
                std::thread::sleep(period);
                match sample(pid) {
                    Ok(s) => peak = peak.max(s.rss_kib),
                    Err(_) => break,
                }
            }
            peak
        })?;
        Ok(Self { pid, first, started: Instant::now(), stop, thread: Some(thread) })
    }

    /// Stops sampling and sums up the window.
    pub fn stop(mut self) -> std::io::Result<AgentUsage> {
        let last = sample(self.pid);
        let wall = self.started.elapsed().as_secs_f64();
        self.stop.store(true, Ordering::Relaxed);
        let peak = self.thread.take().and_then(|t| t.join().ok()).unwrap_or(0);
        let last = last?;
        let ticks = last.cpu_ticks.saturating_sub(self.first.cpu_ticks) as f64;
        let cpu_percent = if wall > 0.0 { ticks / clock_ticks() as f64 / wall * 100.0 } else { 0.0 };
        Ok(AgentUsage {
            cpu_percent,
            peak_rss_kib: peak.max(last.rss_kib),
            rss_start_kib: self.first.rss_kib,
            rss_end_kib: last.rss_kib,
            hwm_kib: last.hwm_kib,
        })
    }
}

impl Drop for Monitor {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}
