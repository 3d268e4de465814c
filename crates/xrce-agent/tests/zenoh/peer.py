"""A ROS 2 node as rmw_zenoh 0.2.x makes one, in Python over eclipse-zenoh, for the zenoh middleware's
end-to-end test (crates/xrce-agent/tests/zenoh.rs). It follows rmw_zenoh's formats from docs/zenoh.md: keys
`<domain>/<name>/<type>/<RIHS01 hash>`, liveliness tokens under `@ros2_lv`, the 33-byte attachment
(sequence number, source time, GID = XXH3-128 of the token), queries for service calls.

  peer.py router ENDPOINT          a Zenoh router listening on ENDPOINT (what `rmw_zenohd` is), until killed
  peer.py node ENDPOINT            a peer connected to the router; reads one command a line on stdin and
                                   answers each with one JSON line on stdout (commands below, `cmd_*`)
  peer.py bench-sub ENDPOINT KEY COUNT
                                   the latency of `xrce-bench ros --direction to-ros` samples (stamped
                                   std_msgs/UInt8MultiArray) on KEY, as ros_peer.py's bench-sub measures it
  peer.py bench-pub ENDPOINT KEY RATE PAYLOAD COUNT
                                   once a subscription's token for KEY's topic is seen: 2 s of warm-up
                                   samples, then COUNT stamped ones at RATE (`--direction from-ros`)

Waits end on the awaited event or after WAIT seconds; the Rust test asserts on what they report.
"""

import json
import os
import struct
import sys
import threading
import time

import xxhash
import zenoh
import zenoh.ext

WAIT = 20.0
CDR_LE = b"\x00\x01\x00\x00"


def gid_of(token):
    """rmw_zenoh's GID: XXH3-128 of the token, low 64 bits then high 64 bits, little endian."""
    h = xxhash.xxh3_128_intdigest(token.encode())
    return (h & (2**64 - 1)).to_bytes(8, "little") + (h >> 64).to_bytes(8, "little")


def attachment(seq, gid):
    return struct.pack("<qq", seq, time.time_ns()) + b"\x10" + gid


def parse_attachment(raw):
    if raw is None or len(raw) != 33 or raw[16] != 16:
        return None
    seq, ts = struct.unpack("<qq", raw[:16])
    return {"seq": seq, "ts": ts, "gid": raw[17:].hex()}


def config(mode, endpoint):
    c = zenoh.Config()
    c.insert_json5("mode", json.dumps(mode))
    c.insert_json5("scouting/multicast/enabled", "false")
    c.insert_json5("timestamping/enabled", "true")
    if os.environ.get("ZENOH_LEASE_MS"):  # the fleet test notices a cut link sooner than Zenoh's 10 s
        c.insert_json5("transport/link/tx/lease", os.environ["ZENOH_LEASE_MS"])
    if mode == "router":
        c.insert_json5("listen/endpoints", json.dumps([endpoint]))
        # rmw_zenohd's stock configuration: no forwarding between two peers that cannot reach each other.
        c.insert_json5("routing/router/peers_failover_brokering", "false")
    else:
        c.insert_json5("connect/endpoints", json.dumps([endpoint]))
        c.insert_json5("listen/endpoints", json.dumps(["tcp/127.0.0.1:0"]))
    return c


class Node:
    def __init__(self, endpoint):
        self.session = zenoh.open(config("peer", endpoint))
        self.zid = str(self.session.zid())
        self.cond = threading.Condition()
        self.tokens = set()
        self.samples = {}
        self.requests = []
        self.keep = []
        self.seq = {}
        self.lv = self.session.liveliness().declare_subscriber("@ros2_lv/**", self.on_token, history=True)
        self.node_token = "@ros2_lv/0/%s/0/0/NN/%%/%%/zenoh_peer" % self.zid
        self.keep.append(self.session.liveliness().declare_token(self.node_token))

    def on_token(self, sample):
        with self.cond:
            key = str(sample.key_expr)
            if sample.kind == zenoh.SampleKind.PUT:
                self.tokens.add(key)
            else:
                self.tokens.discard(key)
            self.cond.notify_all()

    def wait(self, done):
        deadline = time.time() + WAIT
        with self.cond:
            while not done() and time.time() < deadline:
                self.cond.wait(timeout=0.2)
            return done()

    def endpoint_token(self, eid, kind, name, type_name, type_hash, qos):
        return "@ros2_lv/0/%s/0/%d/%s/%%/%%/zenoh_peer/%s/%s/%s/%s" % (
            self.zid, eid, kind, name.replace("/", "%"), type_name, type_hash, qos)

    def collect(self, name):
        def on_sample(sample):
            raw = sample.attachment.to_bytes() if sample.attachment is not None else None
            with self.cond:
                self.samples.setdefault(name, []).append({
                    "payload": sample.payload.to_bytes().hex(), "attachment": parse_attachment(raw),
                    "received_ns": time.time_ns()})
                self.cond.notify_all()
        return on_sample

    # ---- commands: each returns the JSON object answered

    def cmd_zid(self):
        return {"zid": self.zid, "node_token": self.node_token}

    def cmd_gid(self, token):
        return {"gid": gid_of(token).hex()}

    def cmd_wait_token(self, part, state):
        want = state == "present"
        found = lambda: [t for t in self.tokens if part in t]
        ok = self.wait(lambda: bool(found()) == want)
        return {"ok": ok, "tokens": sorted(found())}

    def cmd_sub(self, name, key, durability="volatile", depth="10"):
        """A subscription on KEY; transient local ones ask late publishers' caches for DEPTH samples."""
        if durability == "transient_local":
            history = zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=int(depth))
            sub = zenoh.ext.declare_advanced_subscriber(
                self.session, key, self.collect(name), history=history,
                recovery=zenoh.ext.RecoveryConfig(heartbeat=True), subscriber_detection=True)
        else:
            sub = self.session.declare_subscriber(key, self.collect(name))
        self.keep.append(sub)
        return {"ok": True}

    def cmd_take(self, name, count):
        count = int(count)
        ok = self.wait(lambda: len(self.samples.get(name, [])) >= count)
        return {"ok": ok, "samples": self.samples.get(name, [])}

    def cmd_pub(self, key, token, payload_hex):
        """Publishes as an rmw_zenoh publisher whose token is TOKEN (declared on first use)."""
        if key not in self.seq:
            self.keep.append(self.session.liveliness().declare_token(token))
            self.seq[key] = [0, self.session.declare_publisher(key)]
        entry = self.seq[key]
        entry[0] += 1
        entry[1].put(CDR_LE + bytes.fromhex(payload_hex), attachment=attachment(entry[0], gid_of(token)))
        return {"ok": True, "seq": entry[0]}

    def cmd_serve(self, key, token):
        """A service server: replies to each request with its body reversed, echoing its sequence number and
        client GID in the attachment as rmw_zenoh's servers do."""
        def on_query(query):
            raw = query.attachment.to_bytes() if query.attachment is not None else None
            att = parse_attachment(raw)
            body = query.payload.to_bytes()[4:] if query.payload is not None else b""
            with self.cond:
                self.requests.append({"payload": body.hex(), "attachment": att})
                self.cond.notify_all()
            if att is not None:
                query.reply(query.key_expr, CDR_LE + body[::-1],
                            attachment=attachment(att["seq"], bytes.fromhex(att["gid"])))
        self.keep.append(self.session.liveliness().declare_token(token))
        self.keep.append(self.session.declare_queryable(key, on_query, complete=True))
        return {"ok": True}

    def cmd_served(self, count):
        count = int(count)
        ok = self.wait(lambda: len(self.requests) >= count)
        return {"ok": ok, "requests": self.requests}

    def cmd_call(self, key, token, seq, payload_hex):
        """A service client's call: one query with rmw_zenoh's attachment; the replies it got."""
        replies = self.session.get(
            key, payload=CDR_LE + bytes.fromhex(payload_hex), attachment=attachment(int(seq), gid_of(token)),
            target=zenoh.QueryTarget.ALL_COMPLETE, consolidation=zenoh.ConsolidationMode.NONE, timeout=WAIT)
        out = []
        for reply in replies:
            if reply.ok is not None:
                raw = reply.ok.attachment.to_bytes() if reply.ok.attachment is not None else None
                out.append({"payload": reply.ok.payload.to_bytes().hex(), "attachment": parse_attachment(raw)})
        return {"ok": bool(out), "replies": out}


WARMUP = 1 << 63
IDLE_TIMEOUT = 3.0


def bench_sub(endpoint, key, count):
    """Prints "ready", then one "result" line once COUNT measured samples came (or none for IDLE_TIMEOUT)."""
    session = zenoh.open(config("peer", endpoint))
    cond, arrivals, warmup = threading.Condition(), [], [0]

    def on_sample(sample):
        now = time.time_ns()
        # Encapsulation, then UInt8MultiArray: no dimensions, data_offset, data's length, data (the stamp first).
        sent, seq = struct.unpack_from("<QQ", sample.payload.to_bytes(), 4 + 12)
        with cond:
            if seq & WARMUP:
                warmup[0] += 1
            else:
                arrivals.append((now, sent, seq))
            cond.notify_all()

    sub = session.declare_subscriber(key, on_sample)
    print(json.dumps({"event": "ready"}), flush=True)
    with cond:
        seen = 0
        while len(arrivals) < count:
            cond.wait(timeout=IDLE_TIMEOUT)
            if arrivals and len(arrivals) == seen:
                break
            seen = len(arrivals)
    latencies = sorted((a - s) / 1e3 for a, s, _ in arrivals)

    def at(p):
        return latencies[min(max(-(-p * len(latencies) // 100), 1), len(latencies)) - 1] if latencies else None
    print(json.dumps({"event": "result", "received": len({q for _, _, q in arrivals}), "expected": count,
                      "warmup": warmup[0], "latency_us": {"p50": at(50), "p99": at(99), "max": at(100)}}),
          flush=True)
    del sub
    os._exit(0)  # Zenoh's threads would keep the interpreter alive


def bench_pub(endpoint, key, rate, payload, count):
    """Publishes like an rmw_zenoh publisher (attachment included) once the XRCE subscription's token is seen."""
    node = Node(endpoint)
    topic = key.split("/")[1]
    print(json.dumps({"event": "ready"}), flush=True)
    if not node.cmd_wait_token("/MS/", "present")["ok"] or not any(("%" + topic + "/") in t for t in node.tokens):
        print(json.dumps({"event": "result", "sent": 0, "error": "no subscription"}), flush=True)
        os._exit(1)
    token = node.endpoint_token(1, "MP", "/" + topic, key.split("/")[2], key.split("/")[3], "::,10:,:,:,,")
    node.keep.append(node.session.liveliness().declare_token(token))
    publisher, gid = node.session.declare_publisher(key), gid_of(token)
    # Encapsulation, UInt8MultiArray with no dimensions, data_offset 0, then `payload` bytes of data.
    head = CDR_LE + struct.pack("<III", 0, 0, max(payload, 16))
    period, sent = 1.0 / rate, [0]

    def at_rate(n, flag, seconds):
        done, nxt = 0, time.monotonic()
        end = nxt + seconds if seconds else None
        while (n is None or done < n) and (end is None or time.monotonic() < end):
            now = time.monotonic()
            if nxt > now:
                time.sleep(nxt - now)
            elif now - nxt > 5 * period:
                nxt = now
            nxt += period
            data = struct.pack("<QQ", time.time_ns(), flag | done) + bytes(max(payload, 16) - 16)
            sent[0] += 1
            publisher.put(head + data, attachment=attachment(sent[0], gid))
            done += 1
        return done

    warm = at_rate(None, WARMUP, 2.0)
    t0 = time.monotonic()
    n = at_rate(count, 0, None)
    window = time.monotonic() - t0
    time.sleep(1.0)
    print(json.dumps({"event": "result", "sent": n, "warmup": warm, "window_s": window,
                      "achieved_rate": n / window if window else 0.0}), flush=True)
    os._exit(0)


def main():
    mode, endpoint = sys.argv[1], sys.argv[2]
    if mode == "bench-pub":
        bench_pub(endpoint, sys.argv[3], float(sys.argv[4]), int(sys.argv[5]), int(sys.argv[6]))
    if mode == "bench-sub":
        bench_sub(endpoint, sys.argv[3], int(sys.argv[4]))
    if mode == "router":
        session = zenoh.open(config("router", endpoint))
        print(json.dumps({"router": str(session.zid())}), flush=True)
        while True:
            time.sleep(3600)
    node = Node(endpoint)
    print(json.dumps({"ready": True, "zid": node.zid}), flush=True)
    for line in sys.stdin:
        words = line.split()
        if not words:
            continue
        try:
            answer = getattr(node, "cmd_" + words[0])(*words[1:])
        except Exception as e:  # the test reads the error as a failed step
            answer = {"ok": False, "error": "%s: %s" % (type(e).__name__, e)}
        print(json.dumps(answer), flush=True)


if __name__ == "__main__":
    main()
