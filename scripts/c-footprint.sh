#!/usr/bin/env bash
# Footprint of a C hello-world publisher on the C library (docs/c-api.md): crates/xrce-client-c/footprint/
# publisher.c linked with the no_std library (custom transport over the platform's UDP socket) built with the
# footprint profile (opt-level z, LTO, panic abort), minus an empty C program linked the same way. The libc
# (shared) is not counted, as in scripts/footprint.sh. Optional argument: an agent port to run it against.
#
#   usage: scripts/c-footprint.sh [AGENT_PORT]
#          scripts/c-footprint.sh --target thumbv7em-none-eabihf [--lto] [--run]
#
# With --target thumbv7em-none-eabihf: the library built for the Cortex-M4 (`cargo build -p xrce-client-c
# --no-default-features --profile footprint --target thumbv7em-none-eabihf`), firmware/c/fp_publisher.c (the same
# publisher over the board's UART as a framed custom transport) and fp_empty.c (the board's start-up, timer,
# console and fault handler alone) linked with arm-none-eabi-gcc -Os and newlib-nano (make -C firmware/c); prints
# their sections and the differences. With --run, the publisher also runs in QEMU's mps2-an386 against our
# agent's pseudoterminal and prints its peak stack. With --lto, cross-language LTO: the library as one LLVM
# bitcode module (`cargo rustc ... --crate-type staticlib` with RUSTFLAGS=-Clinker-plugin-lto, in
# target/c-lto) and the firmware linked by the Rust toolchain's rust-lld (make -C firmware/c LTO=1), which
# optimises the library again with only what the C program calls as roots.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
section() { size -A "$1" | awk -v s="$2" '$1 == s { print $2; found = 1 } END { if (!found) print 0 }'; }

if [ "${1:-}" = --target ]; then
  target=${2:?usage: scripts/c-footprint.sh --target thumbv7em-none-eabihf [--lto] [--run]}
  [ "$target" = thumbv7em-none-eabihf ] || { echo "the C firmware is for thumbv7em-none-eabihf" >&2; exit 1; }
  lto=0 run=0
  for a in "${@:3}"; do
    case $a in
      --lto) lto=1 ;;
      --run) run=1 ;;
      *) echo "unknown option $a" >&2; exit 1 ;;
    esac
  done
  if [ $lto = 1 ]; then
    # One crate type, so rustc's own LTO merges the crates into one bitcode module (with the rlib type as well
    # it leaves one module per crate, which lld would only ThinLTO).
    RUSTFLAGS="${RUSTFLAGS:-} -Clinker-plugin-lto" CARGO_TARGET_DIR="$root/target/c-lto" \
      cargo rustc --quiet -p xrce-client-c --no-default-features --profile footprint --target "$target" \
      --crate-type staticlib --manifest-path "$root/Cargo.toml"
    lib="$root/target/c-lto/$target/footprint"
  else
    cargo build --quiet -p xrce-client-c --no-default-features --profile footprint --target "$target" \
      --manifest-path "$root/Cargo.toml"
    lib="$root/target/$target/footprint"
  fi
  make -s -C "$root/firmware/c" LIB="$lib" LTO=$lto all check
  out="$lib/firmware-c"
  linker=$([ $lto = 1 ] && echo "linked by rust-lld with LTO" || echo "arm-none-eabi-gcc's ld")
  echo "target $target (arm-none-eabi-gcc -Os, newlib-nano, library in the footprint profile, $linker)"
  printf '%-18s %8s %8s %8s %8s\n' binary .text .rodata .data .bss
  for b in fp-publisher fp-empty app; do
    printf '%-18s %8d %8d %8d %8d\n' "$b.elf" "$(section "$out/$b.elf" .text)" "$(section "$out/$b.elf" .rodata)" \
      "$(section "$out/$b.elf" .data)" "$(section "$out/$b.elf" .bss)"
  done
  for s in .text .rodata .data .bss; do
    printf 'client + C publisher %-8s %8d B\n' "$s" \
      "$(( $(section "$out/fp-publisher.elf" $s) - $(section "$out/fp-empty.elf" $s) ))"
  done
  if [ $run = 1 ]; then
    cargo build --quiet --release -p xrce-agent --manifest-path "$root/Cargo.toml"
    log=$(mktemp)
    timeout 120 "$root/target/release/xrce-agent" pseudoterminal -m ced -v 0 >"$log" 2>&1 &
    agent=$!
    trap 'kill $agent 2>/dev/null || true; rm -f "$log"' EXIT
    for _ in $(seq 50); do grep -q '/dev/pts/' "$log" && break; sleep 0.1; done
    pty=$(grep -o '/dev/pts/[0-9]*' "$log" | head -n 1)
    for b in fp-publisher fp-empty; do
      echo "$b.elf (QEMU mps2-an386, agent on $pty):"
      timeout 60 qemu-system-arm -M mps2-an386 -nographic -monitor none -semihosting-config enable=on,target=native \
        -serial "$pty" -kernel "$out/$b.elf" | sed 's/^/  /' || true
    done
  fi
  exit 0
fi

export CARGO_TARGET_DIR="$root/target/c-footprint"
cargo build --quiet -p xrce-client-c --no-default-features --profile footprint
lib="$CARGO_TARGET_DIR/footprint"
src="$root/crates/xrce-client-c/footprint"
flags=(-Os -ffunction-sections -fdata-sections -Wl,--gc-sections -I "$root/crates/xrce-client-c/include")
cc "${flags[@]}" "$src/publisher.c" -o "$lib/c-publisher" -L "$lib" -lmicroxrcedds_client -lmicrocdr
cc "${flags[@]}" "$src/empty.c" -o "$lib/c-empty"
printf '%-12s %8s %8s %8s %8s\n' binary .text .rodata .data .bss
for b in c-publisher c-empty; do
  printf '%-12s %8d %8d %8d %8d\n' "$b" "$(section "$lib/$b" .text)" "$(section "$lib/$b" .rodata)" \
    "$(section "$lib/$b" .data)" "$(section "$lib/$b" .bss)"
done
for s in .text .rodata .data .bss; do
  printf 'client + C publisher %-8s %8d B\n' "$s" "$(( $(section "$lib/c-publisher" $s) - $(section "$lib/c-empty" $s) ))"
done
if [ $# -ge 1 ]; then
  "$lib/c-publisher" 127.0.0.1 "$1" 5
fi
