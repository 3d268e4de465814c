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
#
#   usage: scripts/footprint.sh --target TARGET [--run]
#
# On a microcontroller target (thumbv7em-none-eabihf: Cortex-M4; thumbv6m-none-eabi: Cortex-M0+;
# riscv32imc-unknown-none-elf), builds firmware/footprint instead (the same two publishers over the board's
# UART with the framed serial transport, the publisher over a packet transport without framing, and a baseline
# with the board's start-up, timer, console and fault handlers) and prints the same tables, plus how much of the
# difference is memcpy/memmove/memset (the board's byte loops; the host figures leave the libc's out). With --run
# (thumbv7em-none-eabihf only) both publishers also run in QEMU's mps2-an386 against our agent's pseudoterminal
# (`xrce-agent pseudoterminal -m ced`, built here) and print their RAM figures, peak stack included.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)

section() { size -A "$1" | awk -v s="$2" '$1 == s { print $2; found = 1 } END { if (!found) print 0 }'; }

# The sizes of the memory routines (memcpy, memmove, memset and their ARM run-time ABI forms) in an ELF.
mem_routines() {
  nm -S -t d "$1" | awk '$4 ~ /(^__aeabi_mem|compiler_builtins3mem|^mem(cpy|move|set|cmp)$)/ { s += $2 } END { print s + 0 }'
}

if [ "${1:-}" = --target ]; then
  target=${2:?usage: scripts/footprint.sh --target TARGET [--run]}
  (cd "$root/firmware" && cargo build --quiet --release -p xrce-firmware-footprint --target "$target")
  bin="$root/firmware/target/$target/release"
  echo "target $target (firmware/footprint, opt-level z, LTO, panic abort)"
  printf '%-22s %8s %8s %8s %8s\n' binary .text .rodata .data .bss
  for b in footprint-publisher footprint-minimal footprint-packet footprint-baseline; do
    printf '%-22s %8d %8d %8d %8d\n' "$b" "$(section "$bin/$b" .text)" "$(section "$bin/$b" .rodata)" \
      "$(section "$bin/$b" .data)" "$(section "$bin/$b" .bss)"
  done
  for p in publisher minimal packet; do
    for s in .text .rodata .data .bss; do
      d=$(( $(section "$bin/footprint-$p" $s) - $(section "$bin/footprint-baseline" $s) ))
      printf 'client + %-9s %-8s %8d B\n' "$p" "$s" "$d"
    done
    printf 'client + %-9s %-8s %8d B (of the .text above: memcpy/memmove/memset routines)\n' "$p" mem \
      $(( $(mem_routines "$bin/footprint-$p") - $(mem_routines "$bin/footprint-baseline") ))
  done
  if [ "${3:-}" = --run ]; then
    [ "$target" = thumbv7em-none-eabihf ] || { echo "--run: thumbv7em-none-eabihf only" >&2; exit 1; }
    cargo build --quiet --release -p xrce-agent --manifest-path "$root/Cargo.toml"
    log=$(mktemp)
    timeout 120 "$root/target/release/xrce-agent" pseudoterminal -m ced -v 0 >"$log" 2>&1 &
    agent=$!
    trap 'kill $agent 2>/dev/null || true; rm -f "$log"' EXIT
    for _ in $(seq 50); do grep -q '/dev/pts/' "$log" && break; sleep 0.1; done
    pty=$(grep -o '/dev/pts/[0-9]*' "$log" | head -n 1)
    for p in publisher minimal baseline; do
      echo "footprint-$p (QEMU mps2-an386, agent on $pty):"
      timeout 60 qemu-system-arm -M mps2-an386 -nographic -monitor none -semihosting-config enable=on,target=native \
        -serial "$pty" -kernel "$bin/footprint-$p" | sed 's/^/  /' || true
    done
  fi
  exit 0
fi

target=x86_64-unknown-linux-gnu
export CARGO_TARGET_DIR="$root/target/footprint"
cargo build --quiet --manifest-path "$root/crates/xrce-client/footprint/Cargo.toml" --profile footprint --target $target
bin="$CARGO_TARGET_DIR/$target/footprint"
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
