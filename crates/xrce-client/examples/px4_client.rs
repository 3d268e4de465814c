//! A PX4-like client: creates its entities as PX4's `uxrce_dds_client` does (time sync first; participant by
//! XML named `px4_micro_xrce_dds`; per topic a topic, publisher and datawriter in binary, best effort + transient
//! local + keep-last depth 0, written on the best-effort stream; readers best effort on `rt/fmu/in/<topic>`; a
//! reliable SetBool replier on `rq/fmu/<name>Request` / `rr/fmu/<name>Reply`). Payloads are
//! `std_msgs/String` so that any ROS 2 node can read them. Prints one JSON object per line (see
//! `micro_ros_node`).
//!
//! Usage: `px4_client [--agent 127.0.0.1] [--port 8888] [--key N] [--domain N] [--pub TOPIC [--count 200]
//!   [--period-ms 10]] [--sub TOPIC] [--serve NAME] [--run-for-s 30]`
//!
//! E.g. `--pub vehicle_status` publishes `/fmu/out/vehicle_status` (`ros2 topic echo --qos-reliability
//! best_effort /fmu/out/vehicle_status std_msgs/msg/String`).

#[path = "ros_like/mod.rs"]
mod ros_like;

use std::time::Duration;

use ros_like::{run_px4, Control, Px4Plan};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = ros_like::Args::parse(&[
        "agent",
        "port",
        "key",
        "domain",
        "pub",
        "count",
        "period-ms",
        "sub",
        "serve",
        "run-for-s",
    ])?;
    let plan = Px4Plan {
        agent: args.get("agent").unwrap_or("127.0.0.1").to_string(),
        port: args.num("port", 8888)?,
        // Two clients with one key are one client to the agent: derive a default from the process id.
        key: args.num("key", 0x9f00_0000 | std::process::id())?,
        domain: args.num("domain", 0)?,
        publish: args.pub_plan(200, 10)?,
        subscribe: args.get("sub").map(str::to_string),
        serve: args.get("serve").map(str::to_string),
        run_for: Duration::from_secs(args.num("run-for-s", 30)?),
    };
    let control = Control::started();
    run_px4(&plan, &control, &mut |e| println!("{}", e.to_json()))
}
