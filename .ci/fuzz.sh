#!/usr/bin/env bash
# CI fuzz step: builds every cargo-fuzz target (nightly, AddressSanitizer, its own target dir fuzz/target) and
# runs each for FUZZ_SECONDS (12) from its kept corpus (fuzz/corpus/<target>; a fixed sample of 1,600 inputs
# where it holds more), two at a time (2 cores), with memory and per-input time limits. A crash, timeout, OOM
# or leak fails the step; its input is left in fuzz/artifacts/<target>/ and the log is printed. New inputs go
# to a scratch directory, never into the repository. Prints the time it took.
# Usage: .ci/fuzz.sh [TARGET...] (default: every target).
set -euo pipefail
cd "$(dirname "$0")/.."
start=$(date +%s)
# 12 s each, two at a time (agent_sessions replays its corpus for about 50 s whatever this says): about 110 s
# of runs, so that the whole step (cargo-fuzz's install, the build, the runs) stays under the 5 minutes issue 33
# allows on a fresh 2-core machine.
seconds=${FUZZ_SECONDS:-12}
parallel=${FUZZ_PARALLEL:-2}

if ! rustup run nightly cargo --version >/dev/null 2>&1; then
  rustup toolchain install nightly --profile minimal
fi
if ! cargo fuzz --version >/dev/null 2>&1; then
  # Unoptimised: cargo-fuzz only drives cargo and libFuzzer, and this compile is part of the step's time
  # (37 s of CPU against minutes optimised).
  cargo install cargo-fuzz --locked --debug
fi

# The dictionary of each target (none for the structure-aware ones: their input is not bytes on a wire).
dict_of() {
  case "$1" in
    message | agent_core | client_session) echo fuzz/dict/xrce.dict ;;
    serial_framing) echo fuzz/dict/serial.dict ;;
    tcp_framing | can_framing) echo fuzz/dict/tcp.dict ;;
    metrics_http) echo fuzz/dict/http.dict ;;
    config_toml) echo fuzz/dict/toml.dict ;;
    xml_profiles) echo fuzz/dict/xml.dict ;;
  esac
}

if [ $# -gt 0 ]; then
  targets=("$@")
else
  mapfile -t targets < <(cargo +nightly fuzz list)
fi
export CARGO_BUILD_JOBS=${CARGO_BUILD_JOBS:-2}
# No fake stacks for stack-use-after-return: a third of agent_sessions' time in the unoptimised build, for a
# class of bug safe Rust cannot have (the C library is Rust behind its extern "C" functions, which return no
# stack addresses). Leaks are still detected.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_stack_use_after_return=0}
# Unoptimised (`--dev`) and in 16 codegen units instead of cargo-fuzz's optimised single unit: a cold build of
# every target took 3m41s here against 7 min (16 units, optimised) and 10 min (cargo-fuzz's defaults), on a
# fresh clone where nothing is cached. The runs are slower (tens to hundreds of inputs a second): in CI they
# replay the kept corpus and explore a little; the campaign (docs/fuzzing.md) builds optimised. Debug
# assertions and overflow checks are on either way. `run` must be given the same flags, or it builds again.
build_flags=(--dev --codegen-units 16)
if [ $# -gt 0 ]; then
  for t in "${targets[@]}"; do cargo +nightly fuzz build "${build_flags[@]}" "$t"; done
else
  cargo +nightly fuzz build "${build_flags[@]}"
fi
built=$(date +%s)
echo "fuzz targets built in $((built - start)) s"

scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
# At most this many kept inputs a target: libFuzzer replays its whole corpus before it fuzzes, and
# agent_sessions' campaign corpus (3,145 inputs) takes 90 s to replay unoptimised. A larger corpus is sampled,
# every k-th input in name order (the same sample on every run); the campaign (docs/fuzzing.md) uses it all.
max_inputs=${FUZZ_MAX_INPUTS:-1600}

# The corpus directory a run reads: the kept one, or its sample in $scratch/<target>.sample.
seed_dir() {
  local t=$1 n every
  n=$(find "fuzz/corpus/$t" -type f | wc -l)
  if [ "$n" -le "$max_inputs" ]; then
    echo "fuzz/corpus/$t"
    return
  fi
  every=$(((n + max_inputs - 1) / max_inputs))
  mkdir -p "$scratch/$t.sample"
  find "fuzz/corpus/$t" -type f | sort | awk -v k="$every" 'NR % k == 0' | xargs -r cp -t "$scratch/$t.sample"
  echo "$scratch/$t.sample"
}

# Runs one target; its log goes to $scratch/<target>.log, its status to $scratch/<target>.rc.
run_one() {
  local t=$1 dict args seeds
  mkdir -p "$scratch/$t" "fuzz/corpus/$t" "fuzz/artifacts/$t"
  seeds=$(seed_dir "$t")
  args=(-max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1)
  dict=$(dict_of "$t")
  [ -n "$dict" ] && args+=(-dict="$dict")
  if cargo +nightly fuzz run "${build_flags[@]}" "$t" "$scratch/$t" "$seeds" -- "${args[@]}" >"$scratch/$t.log" 2>&1; then
    echo 0 >"$scratch/$t.rc"
  else
    echo 1 >"$scratch/$t.rc"
  fi
  printf '%-16s %s\n' "$t" "$(grep -E '^stat::number_of_executed_units' "$scratch/$t.log" | awk '{print $2 " runs"}')"
}

# A pool of `parallel` runs: the next target starts as soon as any run ends (a slow corpus replay, as
# agent_sessions' in an unoptimised build, does not hold the other slot idle).
running=0
for t in "${targets[@]}"; do
  run_one "$t" &
  running=$((running + 1))
  if [ "$running" -ge "$parallel" ]; then
    wait -n || true
    running=$((running - 1))
  fi
done
wait

failed=0
for t in "${targets[@]}"; do
  if [ "$(cat "$scratch/$t.rc")" != 0 ]; then
    echo "=== fuzz target $t failed:" >&2
    tail -n 60 "$scratch/$t.log" >&2
    failed=1
  fi
done
echo "fuzz step took $(($(date +%s) - start)) s (${#targets[@]} targets, ${seconds} s each, $parallel at a time)"
exit "$failed"
