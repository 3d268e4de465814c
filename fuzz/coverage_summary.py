#!/usr/bin/env python3
"""Line coverage of the fuzz targets per part of the code, after `cargo +nightly fuzz coverage TARGET` for each
target named: merges their profiles and prints covered / total lines of xrce-proto, the agent core
(crates/xrce-agent/src/core) and the C library (crates/xrce-client-c/src), plus every other crate directory.
Usage: [COVERAGE_TARGET_DIR=DIR] python3 fuzz/coverage_summary.py TARGET...   (needs llvm-tools-preview)"""
import glob
import json
import os
import subprocess
import sys
from collections import defaultdict

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TRIPLE = "x86_64-unknown-linux-gnu"
PARTS = ["crates/xrce-proto/src", "crates/xrce-agent/src/core", "crates/xrce-client-c/src",
         "crates/xrce-client/src", "crates/xrce-agent/src"]


def tool(name):
    found = glob.glob(os.path.expanduser(f"~/.rustup/toolchains/nightly-*/lib/rustlib/*/bin/{name}"))
    if not found:
        sys.exit(f"{name} not found: rustup component add llvm-tools-preview --toolchain nightly")
    return found[0]


def main():
    targets = sys.argv[1:]
    profiles = [os.path.join(ROOT, "fuzz", "coverage", t, "coverage.profdata") for t in targets]
    # cargo-fuzz 0.13 builds coverage into the main workspace's target dir, apart from the fuzz build.
    target_dir = os.environ.get("COVERAGE_TARGET_DIR", os.path.join(ROOT, "target"))
    binaries = [os.path.join(target_dir, TRIPLE, "coverage", TRIPLE, "release", t) for t in targets]
    merged = os.path.join(ROOT, "fuzz", "coverage", "merged.profdata")
    subprocess.run([tool("llvm-profdata"), "merge", "-sparse", *profiles, "-o", merged], check=True)
    objects = [binaries[0]] + [a for b in binaries[1:] for a in ("-object", b)]
    out = subprocess.run([tool("llvm-cov"), "export", "-summary-only", f"-instr-profile={merged}", *objects],
                         check=True, capture_output=True, text=True).stdout
    totals = defaultdict(lambda: [0, 0])
    for f in json.loads(out)["data"][0]["files"]:
        path = os.path.relpath(f["filename"], ROOT)
        lines = f["summary"]["lines"]
        for part in PARTS:
            if path.startswith(part + "/"):
                totals[part][0] += lines["covered"]
                totals[part][1] += lines["count"]
                break
    print(f"targets: {' '.join(targets)}")
    for part in PARTS:
        covered, count = totals[part]
        if count:
            label = part + (" (rest)" if part == "crates/xrce-agent/src" else "")
            print(f"{label:36} {covered:6} / {count:6} lines  {100 * covered / count:5.1f} %")


if __name__ == "__main__":
    main()
