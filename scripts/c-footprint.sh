#!/usr/bin/env bash
# Footprint of a C hello-world publisher on the C library (docs/c-api.md): crates/xrce-client-c/footprint/
# publisher.c linked with the no_std library (custom transport over the platform's UDP socket) built with the
# footprint profile (opt-level z, LTO, panic abort), minus an empty C program linked the same way. The libc
# (shared) is not counted, as in scripts/footprint.sh. Optional argument: an agent port to run it against.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
export CARGO_TARGET_DIR="$root/target/c-footprint"
cargo build --quiet -p xrce-client-c --no-default-features --profile footprint
lib="$CARGO_TARGET_DIR/footprint"
src="$root/crates/xrce-client-c/footprint"
flags=(-Os -ffunction-sections -fdata-sections -Wl,--gc-sections -I "$root/crates/xrce-client-c/include")
cc "${flags[@]}" "$src/publisher.c" -o "$lib/c-publisher" -L "$lib" -lmicroxrcedds_client -lmicrocdr
cc "${flags[@]}" "$src/empty.c" -o "$lib/c-empty"

section() { size -A "$1" | awk -v s="$2" '$1 == s { print $2; found = 1 } END { if (!found) print 0 }'; }
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
