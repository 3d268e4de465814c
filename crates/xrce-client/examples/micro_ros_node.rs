//! A micro-ROS-like node: creates its entities exactly as micro-ROS Jazzy's `rmw_microxrcedds` does with binary
//! creation (participant named after the node, `rt/<topic>` with `std_msgs::msg::dds_::String_`, SetBool
//! services as requester/replier on `rq/<name>Request` / `rr/<name>Reply`, reliable volatile keep-last 10,
//! REUSE|REPLACE), then publishes, subscribes, serves and calls. Prints one JSON object per line, each with the
//! wall-clock time it happened (`wall_ns`): `created` (the entity's STATUS arrived), `written`, `sample` (with
//! `latency_ms` from the stamp in the sample), `request`, `call`, `reply` (with `rtt_ms`), `done`.
//!
//! Usage: `micro_ros_node [--agent 127.0.0.1] [--port 8888] [--key N] [--node NAME] [--domain N]
//!   [--pub TOPIC [--count 20] [--period-ms 100]] [--sub TOPIC] [--serve SERVICE] [--call SERVICE [--calls 5]]
//!   [--run-for-s 30]`
//!
//! With a ROS 2 node on the other side of the agent (`-m dds`), e.g.
//! `ros2 topic echo /xrce_chatter std_msgs/msg/String` for `--pub xrce_chatter`.

#[path = "ros_like/mod.rs"]
mod ros_like;

use std::time::Duration;

use ros_like::{run_micro_ros, Control, MicroRosPlan};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = ros_like::Args::parse(&[
        "agent",
        "port",
        "key",
        "node",
        "domain",
        "pub",
        "count",
        "period-ms",
        "sub",
        "serve",
        "call",
        "calls",
        "run-for-s",
    ])?;
    let plan = MicroRosPlan {
        agent: args.get("agent").unwrap_or("127.0.0.1").to_string(),
        port: args.num("port", 8888)?,
        // Two clients with one key are one client to the agent: derive a default from the process id.
        key: args.num("key", 0x5a00_0000 | std::process::id())?,
        node: args.get("node").unwrap_or("micro_ros_node").to_string(),
        domain: args.num("domain", 0)?,
        publish: args.pub_plan(20, 100)?,
        subscribe: args.get("sub").map(str::to_string),
        serve: args.get("serve").map(str::to_string),
        call: match args.get("call") {
            Some(s) => Some((s.to_string(), args.num("calls", 5)?)),
            None => None,
        },
        call_timeout_ms: 3000,
        run_for: Duration::from_secs(args.num("run-for-s", 30)?),
    };
    let control = Control::started();
    run_micro_ros(&plan, &control, &mut |e| println!("{}", e.to_json()))
}
