#!/usr/bin/env python3
"""The ROS 2 side of xrce-rs's ROS 2 suite (crates/xrce-agent/tests/ros2.rs): one rclpy node per run.

Every line on stdout is one JSON object with an "event" key and wall-clock ("wall_ns", time.time_ns()) and
monotonic ("mono_ns") timestamps, so a test on the same machine can compare them with its own clock.

Modes (run `ros_peer.py MODE --help`):
  sub    subscribe to a topic; print each sample as it arrives, "matched" when a writer is matched
  pub    wait until the publisher matches a subscription, then publish N samples "<tag> <i> <wall_ns>"
  serve  serve a std_srvs/srv/SetBool service (success = data, message = "ros <data> <count>")
  call   wait for a SetBool service, call it N times, time each round trip
  graph  poll get_node_names_and_namespaces()/get_topic_names_and_types() until the expected nodes appear
  multi  several subscriptions, publishers and service clients at once (a boot storm's ROS side)
  bench-sub  latency of stamped std_msgs/UInt8MultiArray samples (xrce-bench ros --direction to-ros)
  bench-pub  publish stamped std_msgs/UInt8MultiArray samples at a rate (xrce-bench ros --direction from-ros)
  churn  participants and endpoints that come and go around the agent (scripts/discovery-churn.sh)

The bench modes (scripts/ros2-shm-bench.py runs them) share the layout of xrce-bench's `ros` command: `data`
starts with the send time (time.time_ns(), u64 little endian) and the sequence number (u64, bit 63 set for
warm-up samples); they print one "result" line.

Needs a ROS 2 Jazzy environment (the suite uses a venv: LD_LIBRARY_PATH=$VENV/lib AMENT_PREFIX_PATH=$VENV
RMW_IMPLEMENTATION=rmw_fastrtps_cpp, and FASTDDS_BUILTIN_TRANSPORTS=UDPv4 unless XRCE_ROS_SHM=1) and must run inside a loopback-only
network namespace (../shared/dds-peers/netns.sh).
"""

import argparse
import array
import json
import struct
import sys
import time

import rclpy
from rclpy.duration import Duration
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Int32, String, UInt8MultiArray
from std_srvs.srv import SetBool


def emit(event, **fields):
    line = {"event": event, "wall_ns": time.time_ns(), "mono_ns": time.monotonic_ns()}
    line.update(fields)
    print(json.dumps(line), flush=True)


def qos(args):
    profile = QoSProfile(
        reliability=ReliabilityPolicy.BEST_EFFORT if args.best_effort else ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if args.transient_local else DurabilityPolicy.VOLATILE,
        history=HistoryPolicy.KEEP_LAST,
        depth=args.depth,
    )
    if getattr(args, "deadline_ms", 0) > 0:
        # A deadline no XRCE writer offers: the reader never matches one (the agent's gate must not wait forever).
        profile.deadline = Duration(nanoseconds=int(args.deadline_ms * 1e6))
    return profile


MSG_TYPES = {"string": String, "int32": Int32}


def spin_until(node, done, timeout_s):
    deadline = time.monotonic() + timeout_s
    while rclpy.ok() and not done() and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=min(0.05, max(0.0, deadline - time.monotonic())))
    return done()


def run_sub(node, args):
    received = []

    def on_matched(info):
        emit("matched", count=info.current_count, change=info.current_count_change)

    def on_sample(msg):
        received.append(msg.data)
        emit("sample", data=msg.data, n=len(received))

    node.create_subscription(
        MSG_TYPES[args.type],
        args.topic,
        on_sample,
        qos(args),
        event_callbacks=SubscriptionEventCallbacks(matched=on_matched),
    )
    emit("ready", node=node.get_name(), topic=args.topic)
    spin_until(node, lambda: args.count > 0 and len(received) >= args.count, args.timeout)
    emit("done", received=len(received))


def run_pub(node, args):
    matched = []

    def on_matched(info):
        matched.append(info.current_count)
        emit("matched", count=info.current_count, change=info.current_count_change)

    publisher = node.create_publisher(
        MSG_TYPES[args.type],
        args.topic,
        qos(args),
        event_callbacks=PublisherEventCallbacks(matched=on_matched),
    )
    emit("ready", node=node.get_name(), topic=args.topic)
    if not spin_until(node, lambda: publisher.get_subscription_count() >= args.min_subscribers, args.timeout):
        emit("done", sent=0, error="no subscription matched")
        return
    emit("start", subscriptions=publisher.get_subscription_count())
    for i in range(args.count):
        msg = MSG_TYPES[args.type]()
        t = time.time_ns()
        if args.type == "string":
            msg.data = f"{args.tag} {i} {t}"
        else:
            msg.data = i
        publisher.publish(msg)
        emit("sent", i=i, t=t)
        spin_until(node, lambda: False, args.period_ms / 1000.0)
    # Stay a while so that reliable repairs can complete before the writer goes away.
    spin_until(node, lambda: False, args.linger)
    emit("done", sent=args.count)


def run_serve(node, args):
    served = []

    def on_request(request, response):
        served.append(request.data)
        response.success = bool(request.data)
        response.message = f"ros {str(request.data).lower()} {len(served)}"
        emit("request", data=bool(request.data), n=len(served))
        return response

    node.create_service(SetBool, args.service, on_request)
    emit("ready", node=node.get_name(), service=args.service)
    spin_until(node, lambda: args.count > 0 and len(served) >= args.count, args.timeout)
    # Let the last reply go out.
    spin_until(node, lambda: False, args.linger)
    emit("done", served=len(served))


def run_call(node, args):
    client = node.create_client(SetBool, args.service)
    emit("ready", node=node.get_name(), service=args.service)
    t0 = time.monotonic()
    deadline = t0 + args.timeout
    while not client.service_is_ready() and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.01)
    if not client.service_is_ready():
        emit("done", calls=0, ok=0, error="service not available")
        return
    emit("available", after_ms=(time.monotonic() - t0) * 1e3)
    ok = 0
    for i in range(args.count):
        request = SetBool.Request()
        request.data = i % 2 == 0
        start = time.monotonic()
        future = client.call_async(request)
        rclpy.spin_until_future_complete(node, future, timeout_sec=args.call_timeout)
        rtt_ms = (time.monotonic() - start) * 1e3
        if not future.done():
            client.remove_pending_request(future)
            emit("timeout", i=i, after_ms=rtt_ms)
            continue
        reply = future.result()
        ok += 1
        emit("reply", i=i, request=request.data, rtt_ms=rtt_ms, success=reply.success, message=reply.message)
    emit("done", calls=args.count, ok=ok)


def run_multi(node, args):
    """Several endpoints in one node, for a boot storm: subscriptions (reliable with --sub, best effort with
    --sub-be), publishers that publish --count samples "<tag> <i> <wall_ns>" every --period-ms once a
    subscription matched (--pub), and SetBool clients that call --calls times once the service is available
    (--call). Every event names its topic or service; stops when everything is done or at --timeout."""
    received = {}

    def on_sample_for(topic):
        def on_sample(msg):
            received[topic] = received.get(topic, 0) + 1
            emit("sample", topic=topic, data=msg.data, n=received[topic])

        return on_sample

    def on_matched_for(topic):
        def on_matched(info):
            emit("matched", topic=topic, count=info.current_count, change=info.current_count_change)

        return on_matched

    for topic, best_effort in [(t, False) for t in args.sub] + [(t, True) for t in args.sub_be]:
        profile = QoSProfile(
            reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.VOLATILE,
            history=HistoryPolicy.KEEP_LAST,
            depth=args.depth,
        )
        node.create_subscription(
            String,
            topic,
            on_sample_for(topic),
            profile,
            event_callbacks=SubscriptionEventCallbacks(matched=on_matched_for(topic)),
        )
    reliable = QoSProfile(
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.VOLATILE,
        history=HistoryPolicy.KEEP_LAST,
        depth=args.depth,
    )
    publishers = [{"topic": t, "pub": node.create_publisher(String, t, reliable), "sent": 0, "next": 0.0}
                  for t in args.pub]
    clients = [{"service": s, "client": node.create_client(SetBool, s), "t0": time.monotonic(), "calls": 0,
                "pending": None, "available": False} for s in args.call]
    emit("ready", node=node.get_name())
    deadline = time.monotonic() + args.timeout

    def finished():
        return (all(p["sent"] >= args.count for p in publishers)
                and all(c["calls"] >= args.calls and c["pending"] is None for c in clients)
                and all(received.get(t, 0) >= args.expect for t in args.sub))

    while rclpy.ok() and time.monotonic() < deadline and not finished():
        now = time.monotonic()
        for p in publishers:
            if p["sent"] < args.count and p["pub"].get_subscription_count() >= 1 and now >= p["next"]:
                msg = String()
                t = time.time_ns()
                msg.data = f"{args.tag} {p['sent']} {t}"
                p["pub"].publish(msg)
                emit("sent", topic=p["topic"], i=p["sent"], t=t)
                p["sent"] += 1
                p["next"] = now + args.period_ms / 1000.0
        for c in clients:
            if c["pending"] is not None:
                future, start, data, i = c["pending"]
                if future.done():
                    reply = future.result()
                    emit("reply", service=c["service"], i=i, request=data, rtt_ms=(now - start) * 1e3,
                         success=reply.success, message=reply.message)
                    c["pending"] = None
                elif now - start > args.call_timeout:
                    c["client"].remove_pending_request(future)
                    emit("timeout", service=c["service"], i=i)
                    c["pending"] = None
            elif c["calls"] < args.calls and c["client"].service_is_ready():
                if not c["available"]:
                    c["available"] = True
                    emit("available", service=c["service"], after_ms=(now - c["t0"]) * 1e3)
                request = SetBool.Request()
                request.data = c["calls"] % 2 == 0
                c["pending"] = (c["client"].call_async(request), now, request.data, c["calls"])
                c["calls"] += 1
        rclpy.spin_once(node, timeout_sec=0.005)
    # Let reliable repairs and the last replies complete.
    spin_until(node, lambda: False, args.linger)
    emit("done", received=received)


def run_graph(node, args):
    expect = set(args.expect)
    t0 = time.monotonic()

    def snapshot():
        nodes = [[name, ns] for name, ns in node.get_node_names_and_namespaces()]
        return nodes, [[name, list(types)] for name, types in node.get_topic_names_and_types()]

    def complete():
        names = {name for name, _ in snapshot()[0]}
        return expect <= names

    spin_until(node, complete, args.timeout)
    nodes, topics = snapshot()
    emit("graph", nodes=nodes, topics=topics, complete=complete(), after_ms=(time.monotonic() - t0) * 1e3)


WARMUP = 1 << 63


def percentiles(values):
    """Nearest-rank percentiles, as xrce-bench computes them."""
    values = sorted(values)
    n = len(values)
    if n == 0:
        return {"count": 0}

    def at(p):
        rank = -(-p * n // 100)
        return values[min(max(rank, 1), n) - 1]

    return {"count": n, "min": values[0], "p50": at(50), "p90": at(90), "p99": at(99), "max": values[-1],
            "mean": sum(values) / n}


def bench_qos(args):
    return QoSProfile(reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE,
                      history=HistoryPolicy.KEEP_LAST, depth=args.depth)


def run_bench_sub(node, args):
    """Receives stamped samples: the latency of each measured one (send time to the callback), until --count
    came or nothing came for --idle-timeout after the first."""
    arrivals = []
    warmup = [0]

    def on_sample(msg):
        now = time.time_ns()
        sent, seq = struct.unpack_from("<QQ", msg.data, 0)
        if seq & WARMUP:
            warmup[0] += 1
        else:
            arrivals.append((now, sent, seq))

    node.create_subscription(UInt8MultiArray, args.topic, on_sample, bench_qos(args))
    emit("ready", node=node.get_name(), topic=args.topic)
    deadline = time.monotonic() + args.timeout
    last = [None, 0]
    while rclpy.ok() and time.monotonic() < deadline and len(arrivals) < args.count:
        rclpy.spin_once(node, timeout_sec=0.05)
        if len(arrivals) != last[1]:
            last = [time.monotonic(), len(arrivals)]
        elif last[0] is not None and time.monotonic() - last[0] > args.idle_timeout:
            break
    seen, duplicates, out_of_order, highest, latencies = set(), 0, 0, -1, []
    for now, sent, seq in arrivals:
        if seq in seen:
            duplicates += 1
            continue
        seen.add(seq)
        if seq < highest:
            out_of_order += 1
        highest = max(highest, seq)
        latencies.append((now - sent) / 1e3)
    window = (arrivals[-1][0] - arrivals[0][0]) / 1e9 if len(arrivals) > 1 else 0.0
    # Which measured samples never came, as [first, last] runs (the first 20), and the longest silence.
    missing = []
    for seq in range(args.count):
        if seq not in seen:
            if missing and missing[-1][1] == seq - 1:
                missing[-1][1] = seq
            else:
                missing.append([seq, seq])
    gaps = [(b[0] - a[0], b[2]) for a, b in zip(arrivals, arrivals[1:])]
    gap_ns, gap_seq = max(gaps) if gaps else (0, 0)
    if args.dump:
        with open(args.dump, "w") as f:
            f.writelines(f"{seq} {sent} {now}\n" for now, sent, seq in arrivals)
    emit("result", received=len(seen), expected=args.count, warmup=warmup[0], duplicates=duplicates,
         out_of_order=out_of_order, window_s=window, latency_us=percentiles(latencies),
         missing_runs=len(missing), missing=missing[:20], max_arrival_gap_ms=gap_ns / 1e6,
         max_arrival_gap_seq=gap_seq)


def run_bench_pub(node, args):
    """Publishes stamped samples of --payload bytes at --rate once a subscription matched: warm-up samples for
    --warmup seconds, then --count measured ones."""
    publisher = node.create_publisher(UInt8MultiArray, args.topic, bench_qos(args))
    emit("ready", node=node.get_name(), topic=args.topic)
    if not spin_until(node, lambda: publisher.get_subscription_count() >= 1, args.timeout):
        emit("result", sent=0, error="no subscription matched")
        return
    msg = UInt8MultiArray()
    msg.data = array.array("B", bytes(max(args.payload, 16)))
    period = 1.0 / args.rate

    def publish_at_rate(count, flag, seconds):
        sent = 0
        nxt = time.monotonic()
        end = nxt + seconds if seconds else None
        while (count is None or sent < count) and (end is None or time.monotonic() < end):
            now = time.monotonic()
            if nxt > now:
                time.sleep(nxt - now)
            elif now - nxt > 5 * period:
                nxt = now
            nxt += period
            struct.pack_into("<QQ", msg.data, 0, time.time_ns(), flag | sent)
            publisher.publish(msg)
            sent += 1
        return sent

    warm = publish_at_rate(None, WARMUP, args.warmup)
    t0 = time.monotonic()
    sent = publish_at_rate(args.count, 0, None)
    window = time.monotonic() - t0
    # Stay a while so that reliable repairs can complete before the writer goes away.
    spin_until(node, lambda: False, args.linger)
    emit("result", sent=sent, warmup=warm, window_s=window, achieved_rate=sent / window if window else 0.0)


def run_churn(node, args):
    """ROS 2 discovery traffic around the agent: every --participant-period a new participant (its own rclpy
    context and node, with --endpoints publishers and as many subscriptions on the --topic topics, in turn)
    replaces the previous one, and every --endpoint-period this process's first node creates a publisher or
    a subscription and deletes its oldest once it has --endpoints. Publishers write one sample a second, so
    the agent's readers on those topics have something to carry."""
    topics = args.topic or ["churn"]
    profile = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=10)
    payload = UInt8MultiArray(data=array.array("B", bytes(64)))
    counts = {"participants": 0, "endpoints": 0}

    def endpoint(owner, i):
        topic = topics[i % len(topics)]
        counts["endpoints"] += 1
        if i % 2 == 0:
            return owner.create_publisher(UInt8MultiArray, topic, profile)
        return owner.create_subscription(UInt8MultiArray, topic, lambda _msg: None, profile)

    def spawn_participant():
        ctx = rclpy.Context()
        rclpy.init(context=ctx)
        n = rclpy.create_node(f"{node.get_name()}_p{counts['participants']}", context=ctx)
        counts["participants"] += 1
        held = [endpoint(n, i) for i in range(2 * args.endpoints)]
        return ctx, n, held

    def drop_participant(p):
        ctx, n, _held = p
        n.destroy_node()
        ctx.try_shutdown()

    own = []
    current = None
    started = time.monotonic()
    next_participant = next_endpoint = next_write = started
    while rclpy.ok() and time.monotonic() - started < args.seconds:
        now = time.monotonic()
        if now >= next_participant:
            if current is not None:
                drop_participant(current)
            current = spawn_participant()
            next_participant = now + args.participant_period
        if now >= next_endpoint:
            own.append(endpoint(node, counts["endpoints"]))
            if len(own) > args.endpoints:
                old = own.pop(0)
                (node.destroy_publisher if hasattr(old, "publish") else node.destroy_subscription)(old)
            next_endpoint = now + args.endpoint_period
        if now >= next_write:
            for e in own + (current[2] if current else []):
                if hasattr(e, "publish"):
                    e.publish(payload)
            next_write = now + 1.0
        rclpy.spin_once(node, timeout_sec=0.05)
    if current is not None:
        drop_participant(current)
    emit("result", **counts)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--node", default="ros_peer", help="node name")
    sub = parser.add_subparsers(dest="mode", required=True)

    def topic_args(p):
        p.add_argument("--topic", required=True)
        p.add_argument("--type", choices=sorted(MSG_TYPES), default="string")
        p.add_argument("--best-effort", action="store_true", help="best effort instead of reliable")
        p.add_argument("--transient-local", action="store_true", help="transient local instead of volatile")
        p.add_argument("--depth", type=int, default=10)
        p.add_argument("--deadline-ms", type=float, default=0.0, help="requested deadline (0: none)")

    p = sub.add_parser("sub", help="subscribe and print samples")
    topic_args(p)
    p.add_argument("--count", type=int, default=0, help="stop after this many samples (0: run until timeout)")
    p.add_argument("--timeout", type=float, default=30.0)

    p = sub.add_parser("pub", help="publish after a subscription matched")
    topic_args(p)
    p.add_argument("--count", type=int, default=20)
    p.add_argument("--period-ms", type=float, default=20.0)
    p.add_argument("--tag", default="ros")
    p.add_argument("--min-subscribers", type=int, default=1)
    p.add_argument("--timeout", type=float, default=30.0, help="how long to wait for a subscription")
    p.add_argument("--linger", type=float, default=1.0)

    p = sub.add_parser("serve", help="serve std_srvs/srv/SetBool")
    p.add_argument("--service", required=True)
    p.add_argument("--count", type=int, default=0, help="stop after this many requests (0: run until timeout)")
    p.add_argument("--timeout", type=float, default=30.0)
    p.add_argument("--linger", type=float, default=0.5)

    p = sub.add_parser("call", help="call std_srvs/srv/SetBool")
    p.add_argument("--service", required=True)
    p.add_argument("--count", type=int, default=5)
    p.add_argument("--timeout", type=float, default=30.0, help="how long to wait for the service")
    p.add_argument("--call-timeout", type=float, default=5.0)

    p = sub.add_parser("multi", help="several subscriptions, publishers and service clients in one node")
    p.add_argument("--sub", action="append", default=[], help="reliable subscription (repeatable)")
    p.add_argument("--sub-be", action="append", default=[], help="best-effort subscription (repeatable)")
    p.add_argument("--pub", action="append", default=[], help="publisher (repeatable)")
    p.add_argument("--call", action="append", default=[], help="SetBool service to call (repeatable)")
    p.add_argument("--depth", type=int, default=10)
    p.add_argument("--count", type=int, default=20, help="samples per publisher")
    p.add_argument("--expect", type=int, default=0, help="run until each --sub topic got this many samples")
    p.add_argument("--period-ms", type=float, default=20.0)
    p.add_argument("--tag", default="ros")
    p.add_argument("--calls", type=int, default=3, help="calls per service")
    p.add_argument("--call-timeout", type=float, default=5.0)
    p.add_argument("--timeout", type=float, default=30.0)
    p.add_argument("--linger", type=float, default=1.0)

    p = sub.add_parser("bench-sub", help="latency of stamped UInt8MultiArray samples")
    p.add_argument("--topic", required=True)
    p.add_argument("--depth", type=int, default=10)
    p.add_argument("--count", type=int, required=True, help="measured samples expected")
    p.add_argument("--idle-timeout", type=float, default=3.0)
    p.add_argument("--timeout", type=float, default=120.0)
    p.add_argument("--dump", help="write every measured arrival to this file (seq sent_ns arrival_ns a line)")

    p = sub.add_parser("bench-pub", help="publish stamped UInt8MultiArray samples at a rate")
    p.add_argument("--topic", required=True)
    p.add_argument("--depth", type=int, default=10)
    p.add_argument("--rate", type=float, required=True, help="samples per second")
    p.add_argument("--payload", type=int, required=True, help="bytes of data per sample (at least 16)")
    p.add_argument("--count", type=int, required=True, help="measured samples")
    p.add_argument("--warmup", type=float, default=2.0, help="seconds of warm-up samples after the match")
    p.add_argument("--timeout", type=float, default=30.0, help="how long to wait for a subscription")
    p.add_argument("--linger", type=float, default=1.0)

    p = sub.add_parser("churn", help="participants and endpoints that come and go")
    p.add_argument("--topic", action="append", default=[], help="topic of the endpoints (repeatable, in turn)")
    p.add_argument("--seconds", type=float, required=True)
    p.add_argument("--participant-period", type=float, default=2.0, help="seconds between participants")
    p.add_argument("--endpoint-period", type=float, default=0.5, help="seconds between endpoints")
    p.add_argument("--endpoints", type=int, default=2, help="publishers (and as many subscriptions) held")

    p = sub.add_parser("graph", help="print the ROS graph")
    p.add_argument("--expect", action="append", default=[], help="node name to wait for (repeatable)")
    p.add_argument("--timeout", type=float, default=10.0)

    args = parser.parse_args()
    rclpy.init()
    node = rclpy.create_node(args.node)
    try:
        {"sub": run_sub, "pub": run_pub, "serve": run_serve, "call": run_call, "graph": run_graph,
         "multi": run_multi, "bench-sub": run_bench_sub, "bench-pub": run_bench_pub, "churn": run_churn}[args.mode](
            node, args
        )
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
