#!/usr/bin/env bash
# Footprint of xrce-client for the hello-world publisher profile (MTU 512, one reliable output and one reliable
# input stream, history 4, 2 KiB each) and for the minimal publisher (same program, output history 4 in 256 B,
# input history 2 in 64 B) on x86_64-unknown-linux-gnu, opt-level "z", LTO, panic = "abort", no_std.
#
#   usage: scripts/footprint.sh [AGENT_PORT]
#
# Builds crates/xrce-client/footprint (`#![no_std]` `#![no_main]` publishers and an empty baseline, linked with
# -nostartfiles against the shared libc for mem* and system calls only), prints .text/.rodata/.data/.bss of
# each and the differences. With AGENT_PORT, also runs both publishers against an agent on 127.0.0.1:AGENT_PORT
# (e.g. `MicroXRCEAgent udp4 -p 8888 -m ced`) and prints their RAM figures, peak stack included.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
target=x86_64-unknown-linux-gnu
export CARGO_TARGET_DIR="$root/target/footprint"
cargo build --quiet --manifest-path "$root/crates/xrce-client/footprint/Cargo.toml" --profile footprint --target $target
bin="$CARGO_TARGET_DIR/$target/footprint"

section() { size -A "$1" | awk -v s="$2" '$1 == s { print $2; found = 1 } END { if (!found) print 0 }'; }
printf '%-22s %8s %8s %8s %8s\n' binary .text .rodata .data .bss
for b in footprint-publisher footprint-minimal footprint-baseline; do
  printf '%-22s %8d %8d %8d %8d\n' "$b" "$(section "$bin/$b" .text)" "$(section "$bin/$b" .rodata)" \
    "$(section "$bin/$b" .data)" "$(section "$bin/$b" .bss)"
done
for p in publisher minimal; do
  for s in .text .rodata .data .bss; do
    d=$(( $(section "$bin/footprint-$p" $s) - $(section "$bin/footprint-baseline" $s) ))
    printf 'client + %-9s %-8s %8d B\n' "$p" "$s" "$d"
  done
done
if [ $# -ge 1 ]; then
  for p in publisher minimal; do
    echo "footprint-$p:"
    "$bin/footprint-$p" "$1" || true
  done
fi
