#!/usr/bin/env python3
"""XRCE↔ROS through the agent, `-m zenoh` against `-m dds`, alternating (docs/zenoh.md, "Speed").

to-ros: a micro-ROS-like client (`xrce-bench ros --direction to-ros`: reliable, every write waiting for the
agent's acknowledgement as rmw_publish does) publishes stamped std_msgs/UInt8MultiArray samples at a rate; the ROS
side measures their latency: for `-m dds` an rclpy node (Jazzy, Fast DDS over UDPv4; ros_peer.py bench-sub), for
`-m zenoh` a Zenoh subscriber behind a router (tests/zenoh/peer.py bench-sub, eclipse-zenoh; what an rmw_zenoh
node receives). from-ros: the ROS side publishes (ros_peer.py / peer.py bench-pub), the client measures. Reported
per run: samples received of those sent, latency p50/p99, the agent's CPU per sample (xrce-bench's `/proc`
measure) and the achieved rate. Run as root inside a loopback-only namespace:

  ../shared/dds-peers/netns.sh xzb python3 scripts/zenoh-bench.py [--runs 3] [--seconds 10] [--rate 1000]

environment: AGENT (release agent with the zenoh feature; default target/release/xrce-agent), XRCE_BENCH
(default target/release/xrce-bench), XRCE_ROS_VENV (target/ros2-venv), XRCE_ZENOH_VENV (target/zenoh-venv).
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ZENOH_PEER = os.path.join(ROOT, "crates/xrce-agent/tests/zenoh/peer.py")
ROS_PEER = os.path.join(ROOT, "crates/xrce-agent/tests/ros2/ros_peer.py")
UINT8_ARRAY = "std_msgs::msg::dds_::UInt8MultiArray_"
UINT8_ARRAY_HASH = "RIHS01_5687e861b8d307a5e48b7515467ae7a5fc2daf805bd0ce6d8e9e604bade9f385"
PORT = 8888


def path(var, default):
    return os.path.abspath(os.environ.get(var, os.path.join(ROOT, default)))


def ready(proc, what, stream):
    for line in stream:
        if "ready" in line:
            return
    raise RuntimeError("%s ended before it was ready (exit %s)" % (what, proc.poll()))


def one_run(mw, direction, payload, rate, seconds):
    agent_bin, bench = path("AGENT", "target/release/xrce-agent"), path("XRCE_BENCH", "target/release/xrce-bench")
    ros_venv, zenoh_venv = path("XRCE_ROS_VENV", "target/ros2-venv"), path("XRCE_ZENOH_VENV", "target/zenoh-venv")
    count = round(rate * seconds)
    procs = []
    try:
        if mw == "zenoh":
            router = subprocess.Popen([os.path.join(zenoh_venv, "bin/python"), ZENOH_PEER, "router",
                                       "tcp/localhost:7447"], stdout=subprocess.PIPE, text=True)
            procs.append(router)
            router.stdout.readline()
        agent = subprocess.Popen([agent_bin, "udp4", "-p", str(PORT), "-m", mw, "-v", "2", "--ros-diagnostics", "off"],
                                 env=dict(os.environ, AMENT_PREFIX_PATH=ros_venv), stdout=subprocess.DEVNULL)
        procs.append(agent)
        time.sleep(1.0)
        key = "0/xrce_bench/%s/%s" % (UINT8_ARRAY, UINT8_ARRAY_HASH)
        zpy = os.path.join(zenoh_venv, "bin/python")
        env = dict(os.environ, LD_LIBRARY_PATH=os.path.join(ros_venv, "lib"), AMENT_PREFIX_PATH=ros_venv,
                   RMW_IMPLEMENTATION="rmw_fastrtps_cpp", FASTDDS_BUILTIN_TRANSPORTS="UDPv4", PYTHONUNBUFFERED="1")
        rclpy = [os.path.join(ros_venv, "bin/python"), ROS_PEER, "--node", "ros_bench"]
        common = ["--topic", "xrce_bench", "--count", str(count)]
        if direction == "to-ros":
            side = ([zpy, ZENOH_PEER, "bench-sub", "tcp/localhost:7447", key, str(count)] if mw == "zenoh"
                    else rclpy + ["bench-sub"] + common)
        else:
            side = ([zpy, ZENOH_PEER, "bench-pub", "tcp/localhost:7447", key, str(rate), str(payload), str(count)]
                    if mw == "zenoh" else rclpy + ["bench-pub", "--rate", str(rate), "--payload", str(payload)] + common)
        bench_cmd = [bench, "ros", "--agent", "127.0.0.1:%d" % PORT, "--direction", direction, "--topic", "xrce_bench",
                     "--rate", str(rate), "--payload", str(payload), "--duration", "%ss" % seconds,
                     "--agent-pid", str(agent.pid), "--json"]
        start_side = lambda: subprocess.Popen(side, env=env, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,  # noqa: E731
                                              text=True)
        if direction == "to-ros":
            sub = start_side()
            procs.append(sub)
            ready(sub, "subscriber", sub.stdout)
            out = subprocess.run(bench_cmd, capture_output=True, text=True, timeout=seconds + 120)
        else:
            client = subprocess.Popen(bench_cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            procs.append(client)
            ready(client, "xrce-bench", client.stderr)
            sub = start_side()
            procs.append(sub)
            out = subprocess.CompletedProcess(bench_cmd, 0, client.communicate(timeout=seconds + 120)[0], "")
        client = json.loads(out.stdout.strip().splitlines()[-1])
        result = next(json.loads(line) for line in sub.stdout if '"result"' in line)
        return {"middleware": mw, "direction": direction, "payload": payload, "client": client, "ros": result}
    finally:
        for p in reversed(procs):
            p.kill()
            p.wait()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--rate", type=float, default=1000.0)
    ap.add_argument("--payloads", default="16,1024")
    ap.add_argument("--directions", default="to-ros,from-ros")
    args = ap.parse_args()
    if sorted(os.listdir("/sys/class/net")) != ["lo"]:
        sys.exit("run inside a loopback-only namespace (../shared/dds-peers/netns.sh NAME python3 %s)" % sys.argv[0])
    rows = []
    for direction in args.directions.split(","):
        for payload in [int(p) for p in args.payloads.split(",")]:
            for _ in range(args.runs):
                for mw in ("dds", "zenoh"):  # alternating, so both see the same machine load
                    r = one_run(mw, direction, payload, args.rate, args.seconds)
                    print(json.dumps(r), flush=True)
                    rows.append(r)
    print("| direction | payload | middleware | runs | received / sent | p50 µs | p99 µs | agent CPU µs/sample (runs) |")
    print("|---|---|---|---|---|---|---|---|")
    for direction in args.directions.split(","):
        for payload in sorted({r["payload"] for r in rows}):
            for mw in ("dds", "zenoh"):
                rs = [r for r in rows if (r["direction"], r["payload"], r["middleware"]) == (direction, payload, mw)]
                if not rs:
                    continue
                # The receiver measures: the ROS side to ROS, the client from ROS.
                rx = [r["ros"] if direction == "to-ros" else r["client"] for r in rs]
                received = sum(x["received"] for x in rx)
                sent = sum(r["client"]["written"] if direction == "to-ros" else r["ros"]["sent"] for r in rs)
                cpus = [r["client"].get("agent_cpu_us_per_sample") or 0 for r in rs]
                print("| %s | %d B | %s | %d | %d / %d | %.0f | %.0f | %.0f (%.0f–%.0f) |" % (
                    direction, payload, mw, len(rs), received, sent,
                    statistics.median(x["latency_us"]["p50"] or 0 for x in rx),
                    statistics.median(x["latency_us"]["p99"] or 0 for x in rx),
                    statistics.median(cpus), min(cpus), max(cpus)))


if __name__ == "__main__":
    main()
