#!/usr/bin/env python3
"""Writes the seed inputs of the byte-level fuzz targets into fuzz/seeds/<target>/ from eProsima's captured
traffic (tests/data/vectors/captures) and our own examples (docs/cli.md's configuration file, the refs file).
The kept corpora (fuzz/corpus/<target>) are these seeds plus what the fuzzer found, minimised with
`cargo fuzz cmin`; the seeds themselves are not kept (this script makes them again)."""
import hashlib
import os
import re
import struct
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
VECTORS = os.path.join(ROOT, "tests", "data", "vectors")
OUT = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "fuzz", "seeds")


def packets(path):
    """(direction 'C' or 'A', bytes) of every packet of a capture."""
    out, direction, data = [], None, []
    for line in open(path, encoding="utf-8"):
        head = re.match(r"\s*\d+\s+[\d.]+\s+(C|A)\(?\d*\)?->", line)
        if head:
            if direction:
                out.append((direction, bytes(data)))
            direction, data = head.group(1), []
        elif direction and re.fullmatch(r"\s+([0-9a-f]{2}\s*)+", line):
            data.extend(int(b, 16) for b in line.split())
    if direction:
        out.append((direction, bytes(data)))
    return out


def write(target, content):
    folder = os.path.join(OUT, target)
    os.makedirs(folder, exist_ok=True)
    name = hashlib.sha1(content).hexdigest()
    with open(os.path.join(folder, name), "wb") as f:
        f.write(content)


def ops(messages, op=0):
    """The agent_core / client_session layout: [op] [len_lo] [len_hi] [bytes]."""
    return b"".join(bytes([op]) + struct.pack("<H", len(m)) + m for m in messages)


def serial_frame(payload):
    """A serial frame of the transport (flag, addresses, length, payload, CRC-16/ARC, 0x7D escapes)."""
    def crc16_arc(data):
        crc = 0
        for b in data:
            crc ^= b
            for _ in range(8):
                crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
        return crc
    body = bytes([0, 0]) + struct.pack("<H", len(payload)) + payload + struct.pack("<H", crc16_arc(payload))
    escaped = b"".join(bytes([0x7D, b ^ 0x20]) if b in (0x7E, 0x7D) else bytes([b]) for b in body)
    return b"\x7e" + escaped


def main():
    captures = os.path.join(VECTORS, "captures")
    for name in sorted(os.listdir(captures)):
        if not name.endswith(".txt"):
            continue
        pkts = packets(os.path.join(captures, name))
        client = [p for d, p in pkts if d == "C"]
        agent = [p for d, p in pkts if d == "A"]
        for _, p in pkts:
            write("message", p)
            if len(p) <= 63:
                write("can_framing", p)
        write("agent_core", ops(client[:64]))
        write("client_session", ops(agent[:64]))
        for p in client[:8]:
            write("tcp_framing", bytes([95]) + struct.pack("<H", len(p)) + p)
            write("serial_framing", bytes([0]) + serial_frame(p))
    for request in [b"GET /metrics HTTP/1.1\r\nHost: localhost:9464\r\nAccept: */*\r\n\r\n",
                    b"\x07GET /metrics?x=1 HTTP/1.0\r\n\r\n", b"\x01POST /metrics HTTP/1.1\r\n\r\n"]:
        write("metrics_http", request if request[0] < 32 else b"\x40" + request)
    cli = open(os.path.join(ROOT, "docs", "cli.md"), encoding="utf-8").read()
    for block in re.findall(r"```toml\n(.*?)```", cli, re.S):
        write("config_toml", block.encode())
    write("config_toml", b'middleware = "ced"\n[[transport]]\nkind = "udp4"\nport = 8888\n')
    write("xml_profiles", open(os.path.join(VECTORS, "agent.refs"), "rb").read())


if __name__ == "__main__":
    main()
