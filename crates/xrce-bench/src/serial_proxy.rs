//! `serial-proxy`: a serial line as boards have it, between two pseudoterminals (one for a firmware in QEMU, one
//! for the agent): every byte in either direction may be dropped or get one bit flipped, and what passes may
//! arrive split into pieces with gaps between them, at set rates and from a seed.
//!
//! [`ByteFaults`] is the fault model alone, a pure function of the bytes and its seeded PRNG (tested here);
//! [`run`] (Linux) owns the two pseudoterminals. The proxy keeps the terminals' master sides: a side's device
//! (`/dev/pts/N`) can be closed and opened again (the agent restarted) while the other side stays connected,
//! and bytes for a side nobody has open are discarded, as a UART with nobody listening loses them.

use crate::lossy::Rng;

/// What the line does to bytes. Probabilities are per byte, in `0.0..=1.0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ByteFaultConfig {
    /// Probability that a byte is lost.
    pub drop: f64,
    /// Probability that a byte that is not lost has one bit flipped.
    pub corrupt: f64,
    /// Largest piece a run of bytes is split into (0: no splitting, runs pass as read).
    pub split: usize,
    /// Seed of the PRNG.
    pub seed: u64,
}

impl Default for ByteFaultConfig {
    /// A perfect line.
    fn default() -> Self {
        Self { drop: 0.0, corrupt: 0.0, split: 0, seed: 1 }
    }
}

/// What happened on one direction of the line.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct ByteStats {
    /// Bytes read from the sender.
    pub bytes: u64,
    /// Bytes lost on purpose.
    pub dropped: u64,
    /// Bytes with a flipped bit.
    pub corrupted: u64,
    /// Pieces written (more than the reads when splitting).
    pub pieces: u64,
    /// Bytes discarded because nobody had the receiving side open (or it would not take them).
    pub no_receiver: u64,
}

/// One direction's faults: seeded, so a run is reproducible byte for byte for the same input.
#[derive(Debug, Clone)]
pub struct ByteFaults {
    cfg: ByteFaultConfig,
    rng: Rng,
}

impl ByteFaults {
    /// Faults as `cfg` says, seeded with `cfg.seed`.
    pub const fn new(cfg: ByteFaultConfig) -> Self {
        Self { cfg, rng: Rng::new(cfg.seed) }
    }

    /// Passes `input` through the line: appends to `out` what survives (possibly corrupted) and counts it.
    /// Every byte consumes the same random draws whatever the rates, so two lines with the same seed but other
    /// rates meet the same draws.
    pub fn apply(&mut self, input: &[u8], out: &mut Vec<u8>, stats: &mut ByteStats) {
        for &b in input {
            stats.bytes += 1;
            let (d, c, bit) = (self.rng.unit(), self.rng.unit(), self.rng.next_u64() % 8);
            if d < self.cfg.drop {
                stats.dropped += 1;
                continue;
            }
            if c < self.cfg.corrupt {
                stats.corrupted += 1;
                out.push(b ^ (1 << bit));
            } else {
                out.push(b);
            }
        }
    }

    /// The lengths of the pieces `len` bytes go out in (one piece without splitting); they add up to `len`.
    pub fn pieces(&mut self, len: usize) -> Vec<usize> {
        if self.cfg.split == 0 || len == 0 {
            return vec![len];
        }
        let mut left = len;
        let mut pieces = Vec::new();
        while left > 0 {
            let max = i64::try_from(self.cfg.split.min(left)).unwrap_or(1);
            let n = usize::try_from(self.rng.range(1, max)).unwrap_or(1).clamp(1, left);
            pieces.push(n);
            left -= n;
        }
        pieces
    }
}

/// Counters of a proxy run, per direction.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct SerialProxyStats {
    /// `"serial-proxy"`.
    pub bench: &'static str,
    /// Side A → side B.
    pub a_to_b: ByteStats,
    /// Side B → side A.
    pub b_to_a: ByteStats,
}

#[cfg(target_os = "linux")]
pub use io::{run, SerialProxy};

#[cfg(target_os = "linux")]
mod io {
    use std::fs::File;
    use std::io::{Read, Write};
    use std::os::fd::AsFd;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::{Arc, Mutex};
    use std::time::{Duration, Instant};

    use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
    use nix::sys::termios;

    use super::{ByteFaultConfig, ByteFaults, ByteStats, SerialProxyStats};
    use crate::BenchError;

    fn to_io(e: nix::Error) -> std::io::Error {
        std::io::Error::from_raw_os_error(e as i32)
    }

    /// One side: the master of a pseudoterminal whose device a firmware's QEMU or the agent opens.
    struct Side {
        master: File,
        name: String,
    }

    impl Side {
        /// A pseudoterminal in raw mode (the settings stay with it while the master is open), its device
        /// closed until someone opens it.
        fn new() -> Result<Self, BenchError> {
            let pty = nix::pty::openpty(None, None).map_err(to_io)?;
            let mut t = termios::tcgetattr(&pty.slave).map_err(to_io)?;
            termios::cfmakeraw(&mut t);
            termios::tcsetattr(&pty.slave, termios::SetArg::TCSANOW, &t).map_err(to_io)?;
            let name = nix::unistd::ttyname(&pty.slave).map_err(to_io)?.display().to_string();
            Ok(Self { master: File::from(pty.master), name })
        }
    }

    /// The proxy's two pseudoterminals, ready to [`run`].
    pub struct SerialProxy {
        a: Side,
        b: Side,
    }

    impl std::fmt::Debug for SerialProxy {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.debug_struct("SerialProxy").field("a", &self.a.name).field("b", &self.b.name).finish()
        }
    }

    impl SerialProxy {
        /// Opens both pseudoterminals.
        pub fn open() -> Result<Self, BenchError> {
            Ok(Self { a: Side::new()?, b: Side::new()? })
        }

        /// The devices of side A and side B.
        pub fn devices(&self) -> (&str, &str) {
            (&self.a.name, &self.b.name)
        }
    }

    /// Whether `file` (a master) has its device open on the other end: a master polls `POLLHUP` otherwise.
    fn peer_present(file: &File, timeout_ms: u16) -> (bool, bool) {
        let mut fds = [PollFd::new(file.as_fd(), PollFlags::POLLIN)];
        match poll(&mut fds, PollTimeout::from(timeout_ms)) {
            Ok(_) => {
                let ev = fds.first().and_then(PollFd::revents).unwrap_or(PollFlags::empty());
                (!ev.contains(PollFlags::POLLHUP), ev.contains(PollFlags::POLLIN))
            }
            Err(_) => (false, false),
        }
    }

    /// Moves bytes from `src` to `dst` through `faults` until `stop` or `deadline`.
    #[allow(clippy::too_many_arguments)]
    fn pump(
        mut src: File,
        mut dst: File,
        mut faults: ByteFaults,
        gap: Duration,
        stop: &AtomicBool,
        deadline: Option<Instant>,
        stats: &Mutex<ByteStats>,
    ) {
        let mut buf = [0u8; 256];
        let mut out = Vec::with_capacity(buf.len());
        while !stop.load(Ordering::Relaxed) && deadline.is_none_or(|d| Instant::now() < d) {
            let (present, readable) = peer_present(&src, 20);
            if !readable {
                if !present {
                    // Nobody on the sending side: nothing to read until someone opens its device.
                    std::thread::sleep(Duration::from_millis(10));
                }
                continue;
            }
            let n = match src.read(&mut buf) {
                Ok(n) => n,
                Err(_) => {
                    std::thread::sleep(Duration::from_millis(10));
                    continue;
                }
            };
            let mut s = stats.lock().map_or_else(|e| *e.into_inner(), |g| *g);
            out.clear();
            faults.apply(buf.get(..n).unwrap_or(&[]), &mut out, &mut s);
            let mut at = 0;
            let pieces = faults.pieces(out.len());
            let count = pieces.len();
            for (i, len) in pieces.into_iter().enumerate() {
                let piece = out.get(at..at + len).unwrap_or(&[]);
                at += len;
                s.pieces += 1;
                if !peer_present(&dst, 0).0 || dst.write_all(piece).is_err() {
                    s.no_receiver += piece.len() as u64;
                }
                if i + 1 < count && !gap.is_zero() {
                    std::thread::sleep(gap);
                }
            }
            if let Ok(mut g) = stats.lock() {
                *g = s;
            }
        }
    }

    /// Runs the proxy: A → B and B → A, each through its own [`ByteFaults`] (seeds `seed` and `seed + 1`), a
    /// piece after another `gap` apart, until `stop` is set or `duration` is over.
    pub fn run(
        proxy: SerialProxy,
        cfg: ByteFaultConfig,
        gap: Duration,
        stop: &Arc<AtomicBool>,
        duration: Option<Duration>,
    ) -> Result<SerialProxyStats, BenchError> {
        let deadline = duration.map(|d| Instant::now() + d);
        let (ab, ba) = (Arc::new(Mutex::new(ByteStats::default())), Arc::new(Mutex::new(ByteStats::default())));
        let (a_read, a_write) = (proxy.a.master.try_clone()?, proxy.a.master);
        let (b_read, b_write) = (proxy.b.master.try_clone()?, proxy.b.master);
        let up = {
            let (stop, stats) = (Arc::clone(stop), Arc::clone(&ab));
            let faults = ByteFaults::new(cfg);
            std::thread::spawn(move || pump(a_read, b_write, faults, gap, &stop, deadline, &stats))
        };
        let down = {
            let (stop, stats) = (Arc::clone(stop), Arc::clone(&ba));
            let faults = ByteFaults::new(ByteFaultConfig { seed: cfg.seed.wrapping_add(1), ..cfg });
            std::thread::spawn(move || pump(b_read, a_write, faults, gap, &stop, deadline, &stats))
        };
        for t in [up, down] {
            t.join().map_err(|_| BenchError::Thread("serial proxy pump".into()))?;
        }
        let get = |m: &Mutex<ByteStats>| m.lock().map_or_else(|e| *e.into_inner(), |g| *g);
        Ok(SerialProxyStats { bench: "serial-proxy", a_to_b: get(&ab), b_to_a: get(&ba) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(drop: f64, corrupt: f64, split: usize, seed: u64) -> ByteFaults {
        ByteFaults::new(ByteFaultConfig { drop, corrupt, split, seed })
    }

    #[test]
    fn a_perfect_line_passes_every_byte_in_one_piece() {
        let input: Vec<u8> = (0..=255).collect();
        let (mut out, mut stats) = (Vec::new(), ByteStats::default());
        let mut f = line(0.0, 0.0, 0, 7);
        f.apply(&input, &mut out, &mut stats);
        assert_eq!(out, input);
        assert_eq!(stats, ByteStats { bytes: 256, ..ByteStats::default() });
        assert_eq!(f.pieces(256), vec![256]);
    }

    #[test]
    fn drops_and_corruptions_follow_their_rates() {
        let input = vec![0u8; 100_000];
        let (mut out, mut stats) = (Vec::new(), ByteStats::default());
        line(0.01, 0.02, 0, 3).apply(&input, &mut out, &mut stats);
        assert_eq!(stats.bytes, 100_000);
        assert_eq!(out.len() as u64, stats.bytes - stats.dropped);
        assert!((800..1200).contains(&stats.dropped), "{stats:?}");
        assert!((1600..2400).contains(&stats.corrupted), "{stats:?}");
        // A corrupted zero byte has exactly one bit set.
        assert_eq!(out.iter().filter(|b| **b != 0).count() as u64, stats.corrupted);
        assert!(out.iter().all(|b| b.count_ones() <= 1));
    }

    #[test]
    fn a_dead_line_drops_everything() {
        let (mut out, mut stats) = (Vec::new(), ByteStats::default());
        line(1.0, 0.0, 0, 1).apply(&[1, 2, 3], &mut out, &mut stats);
        assert!(out.is_empty());
        assert_eq!(stats.dropped, 3);
    }

    #[test]
    fn pieces_add_up_and_stay_within_the_split() {
        let mut f = line(0.0, 0.0, 5, 9);
        for len in [1usize, 4, 5, 6, 100, 1000] {
            let p = f.pieces(len);
            assert_eq!(p.iter().sum::<usize>(), len);
            assert!(p.iter().all(|n| (1..=5).contains(n)), "{p:?}");
        }
    }

    #[test]
    fn the_same_seed_gives_the_same_line() {
        let input: Vec<u8> = (0..200u8).collect();
        let run = |seed| {
            let (mut out, mut stats) = (Vec::new(), ByteStats::default());
            let mut f = line(0.05, 0.05, 8, seed);
            f.apply(&input, &mut out, &mut stats);
            (out, stats, f.pieces(200))
        };
        assert_eq!(run(11), run(11));
        assert_ne!(run(11).0, run(12).0);
    }
}
