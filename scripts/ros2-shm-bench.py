#!/usr/bin/env python3
"""Shared memory against UDP between the agent and a same-version rclpy node (issue 21, docs/ros2.md).

For every combination of distribution (the agent built against that distribution's Fast DDS, its rclpy),
transport (shm: the agent's default --dds-shm on and the node's default transports; udp: --dds-shm off and
FASTDDS_BUILTIN_TRANSPORTS=UDPv4), direction (to-ros: an XRCE client publishes, the rclpy node measures;
from-ros: the rclpy node publishes, the XRCE client measures; ros-to-ros, the control: an rclpy node publishes
to another, no agent) and load (rate x payload), one run in a fresh loopback-only network namespace with its
own /dev/shm (../shared/dds-peers/netns.sh): the agent, the rclpy node (crates/xrce-agent/tests/ros2/ros_peer.py
bench-sub / bench-pub), the micro-ROS-like client (xrce-bench ros) and a tcpdump of the UDP datagrams on lo
other than the XRCE client's all start from one process inside it.

Each run reports the latency percentiles of the measured samples (send time stamped in the sample,
CLOCK_REALTIME, to the receiver's callback), the samples lost, the agent's CPU time (utime + stime) per sample
over the measured window (at least 1000 samples: the CPU time comes in 10 ms ticks), the /dev/shm segments
seen mid-run and the DDS datagrams of 1000 bytes or more on lo (the user samples, when they go by UDP). Every
arrival is kept in run-K/arrivals.txt (seq, send and arrival ns). Then a table: median (min–max) over the
runs of every figure.

usage (as root, from anywhere):
  scripts/ros2-shm-bench.py [--runs 3] [--distros jazzy,kilted] [--transports shm,udp]
                            [--directions to-ros,from-ros,ros-to-ros] [--loads 1000x1024,50x32768] [--seconds 10]
Inputs (as scripts/ros2-first-contact.sh DISTRO=... makes them; paths relative to the workspace):
  XRCE_ROS_VENV_JAZZY    default: .ci/ros2-venv.sh target/ros2-venv jazzy (made when missing)
  XRCE_ROS_AGENT_JAZZY   default: built here with AMENT_PREFIX_PATH=<that venv> CARGO_TARGET_DIR=target/jazzy
                         cargo build --release -p xrce-agent
  XRCE_ROS_VENV_KILTED, XRCE_ROS_AGENT_KILTED   likewise (target/ros2-venv-kilted, target/kilted)
  XRCE_BENCH             default: target/release/xrce-bench, built here (cargo build --release -p xrce-bench)
Output: target/ros2-shm-bench/results.jsonl (one line per run), each run's logs beside it, the table on stdout.
"""

import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import threading
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
PEER = os.path.join(ROOT, "crates/xrce-agent/tests/ros2/ros_peer.py")
PORT = 8888
# Datagrams at least this long that are not the XRCE client's: user samples of 1 KiB and more (discovery
# datagrams are shorter).
BIG = 1000


def setup(distro):
    """The agent built against `distro`'s Fast DDS and the venv of its rclpy, as scripts/ros2-first-contact.sh
    makes them (the venv by .ci/ros2-venv.sh when missing, the agent built here), unless given."""
    d = distro.upper()
    venv = os.environ.get(f"XRCE_ROS_VENV_{d}")
    if not venv:
        out = "target/ros2-venv" if distro == "jazzy" else f"target/ros2-venv-{distro}"
        venv = subprocess.run([os.path.join(ROOT, ".ci/ros2-venv.sh"), out, distro], cwd=ROOT, check=True,
                              stdout=subprocess.PIPE, text=True).stdout.strip().splitlines()[-1]
    venv = os.path.abspath(os.path.join(ROOT, venv))
    agent = os.environ.get(f"XRCE_ROS_AGENT_{d}")
    if not agent:
        subprocess.run(["cargo", "build", "-q", "--release", "-p", "xrce-agent"], cwd=ROOT, check=True,
                       env=dict(os.environ, AMENT_PREFIX_PATH=venv, CARGO_TARGET_DIR=f"target/{distro}"))
        agent = os.path.join(ROOT, f"target/{distro}/release/xrce-agent")
    return agent, venv


# ---- inside the namespace: one run ------------------------------------------------------------------------


def read_json_lines(stream, sink, ready):
    for line in stream:
        line = line.strip()
        if not line:
            continue
        try:
            obj = json.loads(line)
        except ValueError:
            continue
        sink.append(obj)
        if obj.get("event") == "ready":
            ready.set()


def wait_ready(proc, ready_event, timeout, what):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if ready_event.wait(0.05):
            return
        if proc.poll() is not None:
            raise RuntimeError(f"{what} exited with {proc.returncode} before it was ready")
    raise RuntimeError(f"{what} not ready after {timeout} s")


def inner(cfg):
    out = cfg["dir"]
    os.makedirs(out, exist_ok=True)
    log = lambda name: open(os.path.join(out, name), "w")  # noqa: E731
    procs = []
    try:
        pcap = os.path.join(out, "lo.pcap")
        tcpdump = subprocess.Popen(["tcpdump", "-i", "lo", "-n", "-s", "128", "-w", pcap, f"udp and not port {PORT}"],
                                   stdout=subprocess.DEVNULL, stderr=log("tcpdump.log"))
        procs.append(tcpdump)
        time.sleep(0.5)
        control = cfg["direction"] == "ros-to-ros"
        agent = None
        if not control:
            agent = subprocess.Popen([cfg["agent"], "udp4", "-p", str(PORT), "--dds-shm",
                                      "on" if cfg["transport"] == "shm" else "off"],
                                     stdout=log("agent.log"), stderr=subprocess.STDOUT)
            procs.append(agent)
            time.sleep(1.0)
            if agent.poll() is not None:
                raise RuntimeError(f"agent exited with {agent.returncode}")
        venv = cfg["venv"]
        env = dict(os.environ, LD_LIBRARY_PATH=os.path.join(venv, "lib"), AMENT_PREFIX_PATH=venv,
                   RMW_IMPLEMENTATION="rmw_fastrtps_cpp", PYTHONUNBUFFERED="1")
        env.pop("FASTDDS_BUILTIN_TRANSPORTS", None)
        if cfg["transport"] == "udp":
            env["FASTDDS_BUILTIN_TRANSPORTS"] = "UDPv4"
        rate, payload = cfg["rate"], cfg["payload"]
        # At least 1000 samples per run: the agent's CPU time comes in 10 ms ticks.
        seconds = max(cfg["seconds"], 1000 / rate)
        count = round(rate * seconds)
        topic = "xrce_bench"
        arrivals = os.path.join(out, "arrivals.txt")
        depth = ["--depth", str(cfg["ros_depth"])]
        sub_args = ["bench-sub", "--topic", topic, "--count", str(count), "--dump", arrivals] + depth
        pub_args = ["bench-pub", "--topic", topic, "--count", str(count), "--rate", str(rate), "--payload",
                    str(payload)] + depth

        def start_node(name, extra):
            p = subprocess.Popen([os.path.join(venv, "bin/python"), PEER, "--node", name] + extra, env=env,
                                 stdout=subprocess.PIPE, stderr=log(f"{name}.log"), text=True)
            procs.append(p)
            lines, ready = [], threading.Event()
            threading.Thread(target=read_json_lines, args=(p.stdout, lines, ready), daemon=True).start()
            wait_ready(p, ready, 30, f"rclpy node {name}")
            return p, lines

        def start_bench():
            p = subprocess.Popen([cfg["bench"], "ros", "--agent", f"127.0.0.1:{PORT}", "--direction",
                                  cfg["direction"], "--topic", topic, "--rate", str(rate), "--payload", str(payload),
                                  "--duration", f"{seconds}s", "--agent-pid", str(agent.pid), "--json", "--dump",
                                  arrivals], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            procs.append(p)
            err = log("bench.log")
            ready = threading.Event()

            def pump():
                for line in p.stderr:
                    err.write(line)
                    err.flush()
                    if "ready" in line:
                        ready.set()

            threading.Thread(target=pump, daemon=True).start()
            wait_ready(p, ready, 30, "xrce-bench")
            return p

        bench = None
        if cfg["direction"] == "to-ros":
            node, node_lines = start_node("ros_bench", sub_args)
            bench = start_bench()
        elif cfg["direction"] == "from-ros":
            bench = start_bench()
            node, node_lines = start_node("ros_bench", pub_args)
        else:
            # The control: rclpy to rclpy, no agent (the DDS hop alone, in the same Python).
            sub, sub_lines = start_node("ros_bench_sub", sub_args)
            node, node_lines = start_node("ros_bench_pub", pub_args)
        # Mid-run (warm-up ~2 s, then the measured window): which shared-memory segments exist.
        time.sleep(3.0 + seconds / 2)
        shm = sorted(os.listdir("/dev/shm"))
        result = lambda lines: next((x for x in reversed(lines) if x.get("event") == "result"), {})  # noqa: E731
        if bench is not None:
            bench_out, _ = bench.communicate(timeout=seconds + 120)
            bench_result = json.loads(bench_out.strip().splitlines()[-1])
        node.wait(timeout=seconds + 60)
        node_result = result(node_lines)
        if control:
            sub.wait(timeout=60)
            bench_result = result(sub_lines)
    finally:
        for p in reversed(procs):
            if p.poll() is None:
                p.send_signal(signal.SIGINT)
        for p in reversed(procs):
            try:
                p.wait(timeout=5)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
    big = subprocess.run(["tcpdump", "-r", pcap, "-n", f"greater {BIG}"], capture_output=True, text=True).stdout
    every = subprocess.run(["tcpdump", "-r", pcap, "-n"], capture_output=True, text=True).stdout
    os.remove(pcap)
    if cfg["direction"] == "to-ros":
        samples, warmup = bench_result.get("written", 0), bench_result.get("warmup_written", 0)
        received = node_result.get("received", 0)
        latency = node_result.get("latency_us", {})
    else:
        # from-ros: the XRCE client received; ros-to-ros: the subscribing node (its result stands in).
        samples, warmup = node_result.get("sent", 0), node_result.get("warmup", 0)
        received = bench_result.get("received", 0)
        latency = bench_result.get("latency_us", {})
    return {
        "distro": cfg["distro"], "transport": cfg["transport"], "direction": cfg["direction"], "rate": rate,
        "payload": payload, "run": cfg["run"], "seconds": seconds, "sent": samples, "warmup": warmup,
        "received": received,
        "lost": max(0, samples - received),
        "p50_us": latency.get("p50"), "p99_us": latency.get("p99"), "max_us": latency.get("max"),
        "agent_cpu_us_per_sample": bench_result.get("agent_cpu_us_per_sample"),
        "agent_cpu_s": bench_result.get("agent_cpu_s"),
        "shm_segments": [s for s in shm if "fast" in s], "udp_datagrams": len(every.splitlines()),
        "udp_datagrams_ge_1000": len(big.splitlines()), "bench": bench_result, "node": node_result,
    }


# ---- outside: the matrix, the namespaces, the table -------------------------------------------------------


def fmt(values, scale=1.0, digits=0):
    vals = [v * scale for v in values if v is not None]
    if not vals:
        return "-"
    f = lambda v: f"{v:.{digits}f}"  # noqa: E731
    if len(vals) == 1:
        return f(vals[0])
    return f"{f(statistics.median(vals))} ({f(min(vals))}–{f(max(vals))})"


def table(results):
    """Two Markdown tables: the figures with the transports side by side (median (min–max) over the runs), then
    the evidence of the transport each run used."""
    transports = list(dict.fromkeys(r["transport"] for r in results))
    rows, evidence = {}, {}
    for r in results:
        rows.setdefault((r["distro"], r["rate"], r["payload"], r["direction"]), {}).setdefault(
            r["transport"], []).append(r)
        evidence.setdefault((r["distro"], r["direction"] == "ros-to-ros", r["transport"]), []).append(r)
    names = "/".join(t.upper() for t in transports)
    head = ["distro", "load", "direction", "runs"]
    head += [f"p50, ms ({t.upper()})" for t in transports] + [f"p99, ms ({t.upper()})" for t in transports]
    head += [f"agent CPU, µs/sample ({t.upper()})" for t in transports] + [f"lost ({names})"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for (distro, rate, payload, direction), by in rows.items():
        load = f"{rate:g} Hz × {payload // 1024} KiB" if payload % 1024 == 0 else f"{rate:g} Hz × {payload} B"
        arrow = {"to-ros": "XRCE→ROS", "from-ros": "ROS→XRCE", "ros-to-ros": "ROS→ROS, no agent"}[direction]
        runs = "/".join(str(len(by.get(t, []))) for t in transports)
        if len(set(runs.split("/"))) == 1:
            runs = runs.split("/")[0]
        cells = [distro, load, arrow, runs]
        cells += [fmt([r["p50_us"] for r in by.get(t, [])], 1e-3, 2) for t in transports]
        cells += [fmt([r["p99_us"] for r in by.get(t, [])], 1e-3, 2) for t in transports]
        cells += [fmt([r["agent_cpu_us_per_sample"] for r in by.get(t, [])]) for t in transports]
        sent = [sum(r["sent"] for r in by.get(t, [])) for t in transports]
        lost = " / ".join(f"{sum(r['lost'] for r in by.get(t, []))}" for t in transports)
        cells.append(f"{lost} of {sent[0]}" if len(set(sent)) == 1 else f"{lost} of {' / '.join(map(str, sent))}")
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "| distro | runs | transport | UDP datagrams ≥ 1000 B on lo per sample (warm-up included) | "
              "/dev/shm segments mid-run |", "|---|---|---|---|---|"]
    for (distro, control, transport), rs in evidence.items():
        what = f"{transport.upper()}" + (", no agent" if control else "")
        # The capture spans the warm-up too.
        dgrams = fmt([r["udp_datagrams_ge_1000"] / max(r["sent"] + r["warmup"], 1) for r in rs], digits=2)
        lines.append(f"| {distro} | {len(rs)} | {what} | {dgrams} | {fmt([len(r['shm_segments']) for r in rs])} |")
    return "\n".join(lines)


def outer(args):
    netns = os.path.join(ROOT, "target/dds-peers/netns.sh")
    if not os.access(netns, os.X_OK):
        netns = os.path.join(ROOT, "../shared/dds-peers/netns.sh")
    if not os.access(netns, os.X_OK):
        sys.exit("no netns.sh (../shared/dds-peers/netns.sh)")
    bench = os.environ.get("XRCE_BENCH")
    if not bench:
        subprocess.run(["cargo", "build", "-q", "--release", "-p", "xrce-bench"], cwd=ROOT, check=True)
        target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
        bench = os.path.join(target, "release/xrce-bench")
    setups = {}
    for distro in args.distros.split(","):
        agent, venv = setup(distro)
        if not os.access(agent, os.X_OK):
            sys.exit(f"no agent for {distro} at {agent}")
        if not os.access(os.path.join(venv, "bin/python"), os.X_OK):
            sys.exit(f"no venv for {distro} at {venv}")
        version = subprocess.run([agent, "--version"], capture_output=True, text=True).stdout.strip()
        print(f"{distro}: {version}; rclpy from {venv}", file=sys.stderr)
        setups[distro] = (agent, venv)
    loads = [tuple(int(x) for x in load.split("x")) for load in args.loads.split(",")]
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    results_path = os.path.join(out, "results.jsonl")
    results = []
    ns = f"xshm-{os.getpid()}"
    k = 0
    try:
        # Run after run of the whole matrix, so that a noisy minute spreads over every combination.
        for run in range(1, args.runs + 1):
            for distro, (agent, venv) in setups.items():
                for rate, payload in loads:
                    for direction in args.directions.split(","):
                        for transport in args.transports.split(","):
                            k += 1
                            cfg = {"distro": distro, "agent": agent, "venv": venv, "bench": bench,
                                   "transport": transport, "direction": direction, "rate": rate,
                                   "payload": payload, "seconds": args.seconds, "run": run,
                                   "ros_depth": args.ros_depth,
                                   "dir": os.path.join(out, f"run-{k:03d}")}
                            subprocess.run(["ip", "netns", "del", ns], stderr=subprocess.DEVNULL)
                            p = subprocess.run([netns, ns, sys.executable, os.path.abspath(__file__), "--inner",
                                                json.dumps(cfg)], capture_output=True, text=True)
                            line = next((x for x in reversed(p.stdout.splitlines()) if x.startswith("RESULT ")), None)
                            if line is None:
                                print(f"run {k} ({distro} {transport} {direction} {rate}x{payload}) failed:\n"
                                      f"{p.stdout[-2000:]}{p.stderr[-2000:]}", file=sys.stderr)
                                continue
                            r = json.loads(line[len("RESULT "):])
                            results.append(r)
                            with open(results_path, "a") as f:
                                f.write(json.dumps(r) + "\n")
                            print(f"run {k}: {distro} {transport:3} {direction:8} {rate}x{payload}: "
                                  f"p50 {r['p50_us']} µs, p99 {r['p99_us']} µs, agent "
                                  f"{r['agent_cpu_us_per_sample']} µs/sample, lost {r['lost']}/{r['sent']}, "
                                  f"big datagrams {r['udp_datagrams_ge_1000']}, shm {len(r['shm_segments'])}",
                                  file=sys.stderr, flush=True)
    finally:
        subprocess.run(["ip", "netns", "del", ns], stderr=subprocess.DEVNULL)
    print(table(results))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--distros", default="jazzy")
    parser.add_argument("--transports", default="shm,udp")
    parser.add_argument("--directions", default="to-ros,from-ros,ros-to-ros",
                        help="to-ros, from-ros, and ros-to-ros: rclpy to rclpy without the agent (the control)")
    parser.add_argument("--loads", default="1000x1024,50x32768", help="RATExPAYLOAD, comma separated")
    parser.add_argument("--seconds", type=float, default=10.0, help="measured window of each run")
    parser.add_argument("--ros-depth", type=int, default=10,
                        help="history depth of the rclpy endpoints (keep last; 10 is rclpy's default)")
    parser.add_argument("--out", default=os.path.join(ROOT, "target/ros2-shm-bench"))
    parser.add_argument("--table", metavar="RESULTS_JSONL", help="only print the table of a results file")
    parser.add_argument("--inner", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.inner:
        print("RESULT " + json.dumps(inner(json.loads(args.inner))), flush=True)
    elif args.table:
        with open(args.table) as f:
            print(table([json.loads(x) for x in f if x.strip()]))
    else:
        outer(args)


if __name__ == "__main__":
    main()
