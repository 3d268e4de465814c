//! What the ROS 2 suites (`ros2.rs`, one loopback namespace; `ros2_two_hosts.rs`, two namespaces joined by a
//! veth pair) share: the agent under test, rclpy nodes running `tests/ros2/ros_peer.py` (here or in the two-hosts
//! "ground" namespace), the micro-ROS-like and PX4-like XRCE clients in threads, and what their output means.
//! A test crate using it also declares `mod netns;` and `mod ros_like;` (the client examples' module).
#![allow(dead_code)]

use std::collections::BTreeSet;
use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::Ordering;
use std::sync::mpsc::{channel, Receiver};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use serde_json::Value;

use crate::netns::{require_isolated_namespace, AgentProcess};
use crate::ros_like::{self, Control, Event, MicroRosPlan, Px4Plan};

/// The ROS 2 discovery settings a node reads from its environment; [`RosPeer::start_in`] and
/// [`start_agent_env`] clear them, then set only those a test names.
pub const DISCOVERY_ENV: [&str; 3] = ["ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_STATIC_PEERS", "ROS_LOCALHOST_ONLY"];

/// The agent under test: `XRCE_ROS_AGENT` if set, else this crate's binary.
fn agent_bin() -> PathBuf {
    std::env::var_os("XRCE_ROS_AGENT").map_or_else(|| PathBuf::from(env!("CARGO_BIN_EXE_xrce-agent")), PathBuf::from)
}

/// The agent under test, with the test's environment.
pub fn start_agent(port: u16) -> AgentProcess {
    AgentProcess::start_bin_env(&agent_bin(), port, &[], &[], &[])
}

/// The agent under test with these extra arguments.
pub fn start_agent_args(port: u16, extra: &[&str]) -> AgentProcess {
    AgentProcess::start_bin_env(&agent_bin(), port, &[], &[], extra)
}

/// The agent under test with these environment variables, and none of [`DISCOVERY_ENV`] but those named.
pub fn start_agent_env(port: u16, env: &[(&str, &str)]) -> AgentProcess {
    AgentProcess::start_bin_env(&agent_bin(), port, &DISCOVERY_ENV, env, &[])
}

pub fn venv() -> PathBuf {
    PathBuf::from(std::env::var_os("XRCE_ROS_VENV").expect("set XRCE_ROS_VENV to the venv .ci/ros2-venv.sh built"))
}

/// Where a ROS node runs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Place {
    /// In the test's own (isolated) namespace.
    Here,
    /// In the named network namespace, the two-hosts "ground" (`scripts/two-hosts.sh`), with its own private
    /// `/dev/shm` as `shared/dds-peers/netns.sh` gives.
    Netns(String),
}

/// A `ros_peer.py` process; its JSON lines arrive on `lines`.
pub struct RosPeer {
    name: String,
    child: Child,
    lines: Receiver<Value>,
    pub seen: Vec<Value>,
    reader: Option<JoinHandle<()>>,
}

impl RosPeer {
    /// A node here, with the discovery settings of the test's environment.
    pub fn start(node: &str, args: &[&str]) -> Self {
        Self::spawn(Self::command(&Place::Here), node, args)
    }

    /// A node at `place` with these environment variables, and none of [`DISCOVERY_ENV`] but those named.
    pub fn start_in(place: &Place, node: &str, args: &[&str], env: &[(&str, &str)]) -> Self {
        let mut cmd = Self::command(place);
        for k in DISCOVERY_ENV {
            cmd.env_remove(k);
        }
        cmd.envs(env.iter().copied());
        Self::spawn(cmd, node, args)
    }

    /// The command that runs the venv's python at `place`.
    fn command(place: &Place) -> Command {
        let python = venv().join("bin/python");
        match place {
            Place::Here => {
                require_isolated_namespace();
                Command::new(python)
            }
            Place::Netns(ns) => {
                crate::netns::require_isolated_netns(ns);
                // `ip netns exec` gives the command its own mount namespace: a private /dev/shm there (Fast DDS
                // versions crash on each other's shared-memory segments).
                const PRIVATE_SHM: &str =
                    "mount -t tmpfs -o size=512m,mode=1777 ros-shm /dev/shm || echo no private /dev/shm >&2; exec \"$@\"";
                let mut cmd = Command::new("ip");
                cmd.args(["netns", "exec", ns, "sh", "-c", PRIVATE_SHM, "ros-peer-sh"]).arg(python);
                cmd
            }
        }
    }

    fn spawn(mut cmd: Command, node: &str, args: &[&str]) -> Self {
        let v = venv();
        let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/ros2/ros_peer.py");
        let logs = std::env::temp_dir().join("xrce-ros2-logs");
        crate::netns::ros_node_transports(&mut cmd);
        let mut child = cmd
            .arg(script)
            .args(["--node", node])
            .args(args)
            .env("LD_LIBRARY_PATH", v.join("lib"))
            .env("AMENT_PREFIX_PATH", &v)
            .env("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
            .env("ROS_LOG_DIR", logs)
            .env("PYTHONUNBUFFERED", "1")
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("ros_peer.py starts");
        let stdout = child.stdout.take().expect("piped stdout");
        let (tx, lines) = channel();
        let tag = node.to_string();
        let reader = std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                match serde_json::from_str::<Value>(&line) {
                    Ok(v) => {
                        if tx.send(v).is_err() {
                            break;
                        }
                    }
                    Err(_) => println!("[{tag}] {line}"),
                }
            }
        });
        Self { name: node.to_string(), child, lines, seen: Vec::new(), reader: Some(reader) }
    }

    /// The next line with `"event": event`, waiting up to `timeout` (lines before it are kept in `seen`).
    pub fn wait_for(&mut self, event: &str, timeout: Duration) -> Option<Value> {
        let deadline = Instant::now() + timeout;
        if let Some(v) = self.seen.iter().find(|v| v["event"] == event) {
            return Some(v.clone());
        }
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let v = self.lines.recv_timeout(left).ok()?;
            self.seen.push(v.clone());
            if v["event"] == event {
                return Some(v);
            }
        }
    }

    /// Waits until `done(seen)` or `timeout`, gathering lines.
    pub fn gather_until(&mut self, timeout: Duration, done: impl Fn(&[Value]) -> bool) {
        let deadline = Instant::now() + timeout;
        while !done(&self.seen) {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(v) => self.seen.push(v),
                Err(_) => break,
            }
        }
    }

    /// Waits for the process to exit by itself (killed after `timeout`); every line it printed.
    pub fn finish(mut self, timeout: Duration) -> Vec<Value> {
        let deadline = Instant::now() + timeout;
        while Instant::now() < deadline {
            if let Ok(Some(_)) = self.child.try_wait() {
                break;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        self.stop()
    }

    /// Stops the process now; every line it printed.
    pub fn stop(mut self) -> Vec<Value> {
        let _ = self.child.kill();
        let _ = self.child.wait();
        if let Some(r) = self.reader.take() {
            let _ = r.join();
        }
        while let Ok(v) = self.lines.try_recv() {
            self.seen.push(v);
        }
        for v in &self.seen {
            if v["event"] != "sample" && v["event"] != "sent" {
                println!("[{}] {v}", self.name);
            }
        }
        std::mem::take(&mut self.seen)
    }
}

impl Drop for RosPeer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// An XRCE client running in a thread; its events arrive on `events`.
pub struct Client {
    events: Receiver<Event>,
    seen: Vec<Event>,
    pub control: Arc<Control>,
    thread: Option<JoinHandle<Result<(), String>>>,
}

impl Client {
    pub fn micro_ros(plan: MicroRosPlan) -> Self {
        Self::spawn(Control::default(), move |control, sink| ros_like::run_micro_ros(&plan, control, sink))
    }

    /// A micro-ROS-like node that publishes from its STATUS OK on, as firmware does (no warm-up).
    pub fn micro_ros_started(plan: MicroRosPlan) -> Self {
        Self::spawn(Control::started(), move |control, sink| ros_like::run_micro_ros(&plan, control, sink))
    }

    pub fn px4(plan: Px4Plan) -> Self {
        Self::spawn(Control::default(), move |control, sink| ros_like::run_px4(&plan, control, sink))
    }

    pub fn px4_started(plan: Px4Plan) -> Self {
        Self::spawn(Control::started(), move |control, sink| ros_like::run_px4(&plan, control, sink))
    }

    pub fn spawn<F>(control: Control, run: F) -> Self
    where
        F: FnOnce(&Control, &mut dyn FnMut(Event)) -> Result<(), Box<dyn std::error::Error>> + Send + 'static,
    {
        let control = Arc::new(control);
        let (tx, events) = channel();
        let c = control.clone();
        let thread = std::thread::spawn(move || {
            let mut sink = |e: Event| {
                let _ = tx.send(e);
            };
            run(&c, &mut sink).map_err(|e| e.to_string())
        });
        Self { events, seen: Vec::new(), control, thread: Some(thread) }
    }

    pub fn wait_for(&mut self, pred: impl Fn(&Event) -> bool, timeout: Duration) -> Option<Event> {
        if let Some(e) = self.seen.iter().find(|e| pred(e)) {
            return Some(e.clone());
        }
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let e = self.events.recv_timeout(left).ok()?;
            self.seen.push(e.clone());
            if pred(&e) {
                return Some(e);
            }
        }
    }

    pub fn created(&mut self, entity: &str, timeout: Duration) -> Option<Event> {
        self.wait_for(|e| e.name == "created" && e.s("entity") == Some(entity) && e.b("ok") == Some(true), timeout)
    }

    /// Waits for the client to end (asking it to stop after `timeout`); every event.
    pub fn finish(mut self, timeout: Duration) -> Vec<Event> {
        let _ = self.wait_for(|e| e.name == "done", timeout);
        self.control.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            match t.join() {
                Ok(Ok(())) => {}
                Ok(Err(e)) => println!("client error: {e}"),
                Err(_) => println!("client thread panicked"),
            }
        }
        while let Ok(e) = self.events.try_recv() {
            self.seen.push(e);
        }
        for e in &self.seen {
            if e.name != "written" && e.name != "sample" {
                println!("[xrce] {}", e.to_json());
            }
        }
        std::mem::take(&mut self.seen)
    }
}

impl Drop for Client {
    fn drop(&mut self) {
        self.control.stop.store(true, Ordering::Relaxed);
    }
}

pub fn ms_between(from_ns: u64, to_ns: u64) -> f64 {
    (to_ns as f64 - from_ns as f64) / 1e6
}

pub fn wall(v: &Value) -> u64 {
    v["wall_ns"].as_u64().unwrap_or(0)
}

pub fn fmt_ms(v: Option<f64>) -> String {
    v.map_or_else(|| "none".into(), |x| format!("{x:.1}"))
}

pub fn micro_ros(port: u16, key: u32, node: &str) -> MicroRosPlan {
    MicroRosPlan {
        agent: "127.0.0.1".into(),
        port,
        key,
        node: node.into(),
        domain: 0,
        publish: None,
        subscribe: None,
        serve: None,
        call: None,
        call_timeout_ms: 2000,
        run_for: Duration::from_secs(15),
    }
}

/// Samples a ROS subscriber printed: (tag, index, receive wall ns).
pub fn ros_samples(lines: &[Value]) -> Vec<(String, u64, u64)> {
    lines
        .iter()
        .filter(|v| v["event"] == "sample")
        .filter_map(|v| {
            let (tag, i, _) = ros_like::parse_stamped(v["data"].as_str()?)?;
            Some((tag, i, wall(v)))
        })
        .collect()
}

/// Which written samples (index, write time) reached the ROS subscriber; the ones written after `after_ns`.
pub fn after_match(written: &[(u64, u64)], received: &[(String, u64, u64)], after_ns: u64) -> (usize, usize, Vec<u64>) {
    let got: BTreeSet<u64> = received.iter().map(|r| r.1).collect();
    let expected: Vec<u64> = written.iter().filter(|(_, t)| *t >= after_ns).map(|(i, _)| *i).collect();
    let missing: Vec<u64> = expected.iter().copied().filter(|i| !got.contains(i)).collect();
    (expected.len() - missing.len(), expected.len(), missing)
}

pub fn written(events: &[Event]) -> Vec<(u64, u64)> {
    events.iter().filter(|e| e.name == "written").filter_map(|e| Some((e.u("i")?, e.u("t")?))).collect()
}

/// Indices of `tag`'s samples in arrival order, from `(tag, index, wall)` triples.
pub fn indices(samples: &[(String, u64, u64)], tag: &str) -> Vec<u64> {
    samples.iter().filter(|s| s.0 == tag).map(|s| s.1).collect()
}
