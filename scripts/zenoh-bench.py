#!/usr/bin/env python3
"""XRCE→ROS through the agent, `-m zenoh` against `-m dds`, alternating (docs/zenoh.md, "Speed").

A micro-ROS-like client (`xrce-bench ros --direction to-ros`: reliable, every write waiting for the agent's
acknowledgement as rmw_publish does) publishes stamped std_msgs/UInt8MultiArray samples at a rate; the ROS side
measures their latency: for `-m dds` an rclpy node (Jazzy, Fast DDS over UDPv4; ros_peer.py bench-sub), for
`-m zenoh` a Zenoh subscriber behind a router (tests/zenoh/peer.py bench-sub, eclipse-zenoh; what an rmw_zenoh
node receives). Reported per run: samples received of those sent, latency p50/p99, the agent's CPU per sample
(xrce-bench's `/proc` measure) and the achieved rate. Run as root inside a loopback-only namespace:

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


def one_run(mw, payload, rate, seconds):
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
        if mw == "zenoh":
            key = "0/xrce_bench/%s/%s" % (UINT8_ARRAY, UINT8_ARRAY_HASH)
            sub = subprocess.Popen([os.path.join(zenoh_venv, "bin/python"), ZENOH_PEER, "bench-sub",
                                    "tcp/localhost:7447", key, str(count)], stdout=subprocess.PIPE, text=True)
        else:
            env = dict(os.environ, LD_LIBRARY_PATH=os.path.join(ros_venv, "lib"), AMENT_PREFIX_PATH=ros_venv,
                       RMW_IMPLEMENTATION="rmw_fastrtps_cpp", FASTDDS_BUILTIN_TRANSPORTS="UDPv4", PYTHONUNBUFFERED="1")
            sub = subprocess.Popen([os.path.join(ros_venv, "bin/python"), ROS_PEER, "--node", "ros_bench", "bench-sub",
                                    "--topic", "xrce_bench", "--count", str(count)], env=env, stdout=subprocess.PIPE,
                                   stderr=subprocess.DEVNULL, text=True)
        procs.append(sub)
        ready(sub, "subscriber", sub.stdout)
        out = subprocess.run([bench, "ros", "--agent", "127.0.0.1:%d" % PORT, "--direction", "to-ros",
                              "--topic", "xrce_bench", "--rate", str(rate), "--payload", str(payload),
                              "--duration", "%ss" % seconds, "--agent-pid", str(agent.pid), "--json"],
                             capture_output=True, text=True, timeout=seconds + 120)
        client = json.loads(out.stdout.strip().splitlines()[-1])
        result = next(json.loads(l) for l in sub.stdout if '"result"' in l)
        return {"middleware": mw, "payload": payload, "client": client, "ros": result}
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
    args = ap.parse_args()
    if sorted(os.listdir("/sys/class/net")) != ["lo"]:
        sys.exit("run inside a loopback-only namespace (../shared/dds-peers/netns.sh NAME python3 %s)" % sys.argv[0])
    rows = []
    for payload in [int(p) for p in args.payloads.split(",")]:
        for run in range(args.runs):
            for mw in ("dds", "zenoh"):  # alternating, so both see the same machine load
                r = one_run(mw, payload, args.rate, args.seconds)
                print(json.dumps(r), flush=True)
                rows.append(r)
    print("| payload | middleware | runs | received / sent | p50 µs | p99 µs | agent CPU µs/sample | achieved rate /s |")
    print("|---|---|---|---|---|---|---|---|")
    for payload in sorted({r["payload"] for r in rows}):
        for mw in ("dds", "zenoh"):
            rs = [r for r in rows if r["payload"] == payload and r["middleware"] == mw]
            med = lambda f: statistics.median(f(r) for r in rs)  # noqa: E731
            received = sum(r["ros"]["received"] for r in rs)
            expected = sum(r["ros"]["expected"] for r in rs)
            cpu = med(lambda r: r["client"].get("agent_cpu_us_per_sample") or 0)
            print("| %d B | %s | %d | %d / %d | %.0f | %.0f | %.1f | %.0f |" % (
                payload, mw, len(rs), received, expected, med(lambda r: r["ros"]["latency_us"]["p50"] or 0),
                med(lambda r: r["ros"]["latency_us"]["p99"] or 0), cpu,
                med(lambda r: r["client"].get("achieved_rate") or 0)))


if __name__ == "__main__":
    main()
