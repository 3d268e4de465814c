#!/usr/bin/env bash
# The firmware in QEMU against our agent over a serial line (docs/mcu.md), as CI runs it (.ci/run):
#
#   scripts/mcu-ci.sh            # install what is missing, build, run every scenario below
#   scripts/mcu-ci.sh noise      # only the noisy-line runs, at MCU_NOISE="DROP CORRUPT SPLIT" (default 0.001 0.001 8)
#
# Installs what is missing (the rustup targets; gcc-arm-none-eabi, libnewlib-arm-none-eabi, qemu-system-arm),
# builds the Rust firmware (firmware/), our C library for thumbv7em-none-eabihf and the C firmware
# (firmware/c), the agent, the serial proxy (xrce-bench) and the host examples, then runs each firmware in QEMU's
# mps2-an386 with UART0 on a pseudoterminal served by one agent (`-m ced`, `--config`: UDP on 127.0.0.1 for
# the host programs and the serial line). Each firmware ends through semihosting with its own verdict (exit
# code and PASS/FAIL); the host side's output is checked here. Then the same with the agent restarted in the
# middle (the line goes through our serial proxy, whose device outlives the agent), then over a noisy line.
# Every program runs under `timeout`.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
export CARGO_TERM_COLOR=never
mode=${1:-all}
start_all=$(date +%s)

step() { printf '\n--- %s\n' "$*"; }
fail() { echo "FAIL: $*" >&2; exit 1; }

step "tools"
for t in thumbv7em-none-eabihf thumbv6m-none-eabi riscv32imc-unknown-none-elf; do
  rustup target list --installed 2>/dev/null | grep -qx "$t" || rustup target add "$t"
done
need=()
command -v arm-none-eabi-gcc >/dev/null 2>&1 || need+=(gcc-arm-none-eabi)
[ -d /usr/lib/arm-none-eabi/newlib ] || need+=(libnewlib-arm-none-eabi)
command -v qemu-system-arm >/dev/null 2>&1 || need+=(qemu-system-arm)
if [ ${#need[@]} -gt 0 ]; then
  apt_log=$(mktemp)
  if ! { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      "${need[@]}"; } >"$apt_log" 2>&1; then
    cat "$apt_log" >&2
    exit 1
  fi
  rm -f "$apt_log"
fi
arm-none-eabi-gcc --version | head -n 1
qemu-system-arm --version | head -n 1

step "build"
build_start=$(date +%s)
cargo build -q --release -p xrce-agent -p xrce-bench
# The host programs: the workspace's examples as `cargo test --workspace --all-features` (CI's step before this
# one) builds them, so nothing is built again there.
cargo build -q --workspace --all-features --examples
(cd firmware && cargo build -q --release)
cargo build -q -p xrce-client-c --no-default-features --profile footprint --target thumbv7em-none-eabihf
clib=$root/target/thumbv7em-none-eabihf/footprint
make -s -C firmware/c LIB="$clib" all check
# The C firmware linked with cross-language LTO as well (the build docs/mcu.md gives for the smallest firmware):
# it runs the same C scenario below, and its footprint against eProsima's 15,808 B is printed.
scripts/c-footprint.sh --target thumbv7em-none-eabihf --lto | grep 'client + C publisher'
echo "build: $(( $(date +%s) - build_start )) s"
agent=$root/target/release/xrce-agent
proxy_bin=$root/target/release/xrce-bench
ex=$root/target/debug/examples
fw=$root/firmware/target/thumbv7em-none-eabihf/release
cfw=$clib/firmware-c
cfw_lto=$root/target/c-lto/thumbv7em-none-eabihf/footprint/firmware-c

work=$(mktemp -d)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  if [ "${MCU_KEEP:-0}" = 1 ]; then echo "logs kept in $work"; else rm -rf "$work"; fi
}
trap cleanup EXIT
port=$((21000 + RANDOM % 20000))

# wait_for FILE PATTERN SECONDS: until FILE holds a line matching PATTERN.
wait_for() {
  local i
  for ((i = 0; i < $3 * 10; i++)); do
    grep -q -- "$2" "$1" 2>/dev/null && return 0
    sleep 0.1
  done
  echo "no \"$2\" in $1 after $3 s:" >&2
  cat "$1" >&2 || true
  return 1
}

# agent_start NAME CONFIG: starts the agent on CONFIG (log $work/NAME.log); sets agent_pid.
agent_start() {
  timeout 300 "$agent" --config "$2" >"$work/$1.log" 2>&1 &
  agent_pid=$!
  pids+=("$agent_pid")
}

agent_stop() {
  kill "$agent_pid" 2>/dev/null || true
  wait "$agent_pid" 2>/dev/null || true
}

# qemu_start NAME ELF DEVICE SECONDS ARGS...: the firmware in QEMU with UART0 on DEVICE, its console (semihosting)
# in $work/NAME.fw; sets qemu_pid.
qemu_start() {
  local name=$1 elf=$2 dev=$3 secs=$4
  shift 4
  timeout "$secs" qemu-system-arm -M mps2-an386 -nographic -monitor none \
    -semihosting-config enable=on,target=native -serial "$dev" -kernel "$elf" -append "$*" \
    >"$work/$name.fw" 2>&1 &
  qemu_pid=$!
  pids+=("$qemu_pid")
}

# qemu_verdict NAME: waits for the firmware; it must exit 0 having printed PASS.
qemu_verdict() {
  local rc=0
  wait "$qemu_pid" || rc=$?
  sed 's/^/    fw | /' "$work/$1.fw"
  [ "$rc" = 0 ] && grep -q '^PASS' "$work/$1.fw" || fail "$1: firmware exit code $rc"
}

# fw_value NAME LABEL: the number the firmware printed after "LABEL: ".
fw_value() { sed -n "s/^$2: \([0-9]*\)$/\1/p" "$work/$1.fw" | tail -n 1; }

# ids_consecutive FILE FIRST LAST: the ids of "Received topic: …, id: N" lines are FIRST..LAST, each once, in
# order.
ids_consecutive() {
  local got want
  got=$(sed -n 's/^Received topic: .*, id: \([0-9]*\)$/\1/p' "$1" | tr '\n' ' ')
  want=$(seq "$2" "$3" | tr '\n' ' ')
  [ "$got" = "$want" ] || { echo "ids: $got" >&2; echo "want: $want" >&2; return 1; }
}

# ids_after_back FILE LAST: the ids received after the host subscriber's last "Agent back" run without gap or
# repetition to LAST; prints the first of them.
ids_after_back() {
  awk -v last="$2" '
    /^Agent back/ { back = 1; n = 0; next }
    back && /^Received topic:/ { id = $NF + 0; if (n == 0) first = id; else if (id != prev + 1) bad = 1; prev = id; n++ }
    END { if (!back || n == 0 || bad || prev != last) exit 1; print first }' "$1"
}

# hello_subscriber NAME MODE COUNT: the host's subscribe_hello_world (reliable) or _best_effort over UDP.
hello_subscriber() {
  local bin=$ex/subscribe_hello_world
  [ "$2" = best-effort ] && bin=$ex/subscribe_hello_world_best_effort
  timeout 60 "$bin" 127.0.0.1 "$port" "$3" >"$work/$1.host" 2>&1 &
  host_pid=$!
  pids+=("$host_pid")
}

run_direct() {
  step "over the agent's pseudoterminal (agent --config: udp4 on 127.0.0.1:$port + pseudoterminal)"
  cat >"$work/direct.toml" <<EOF
middleware = "ced"
[[transport]]
kind = "udp4"
port = $port
[[transport]]
kind = "pseudoterminal"
EOF
  agent_start agent-direct "$work/direct.toml"
  wait_for "$work/agent-direct.log" "Pseudo-Serial device opened at" 10
  local pty
  pty=$(sed -n 's/.*Pseudo-Serial device opened at \(\/dev\/[^ ]*\).*/\1/p' "$work/agent-direct.log" | head -n 1)
  echo "agent's pseudoterminal: $pty"

  for m in reliable best-effort; do
    local t0=$SECONDS
    echo "Rust publisher, $m: 30 samples 50 ms apart -> host subscribe_hello_world$([ "$m" = best-effort ] && echo _best_effort)"
    hello_subscriber "pub-$m" "$m" 30
    sleep 1
    qemu_start "pub-$m" "$fw/publisher" "$pty" 60 "$m" 30 50
    qemu_verdict "pub-$m"
    wait "$host_pid" 2>/dev/null || true
    if [ "$m" = reliable ]; then
      ids_consecutive "$work/pub-$m.host" 0 29 || fail "host subscriber, reliable: not 0..29 in order"
    else
      local n
      n=$(grep -c '^Received topic:' "$work/pub-$m.host" || true)
      [ "$n" -ge 15 ] || fail "host subscriber, best effort: $n of 30"
    fi
    echo "  host received $(grep -c '^Received topic:' "$work/pub-$m.host") of 30 ($((SECONDS - t0)) s)"
  done

  local t0=$SECONDS
  echo "Rust subscriber, reliable: rt/chatter <- host micro_ros_node --pub chatter (40 samples, 30 ms apart)"
  qemu_start sub-reliable "$fw/subscriber" "$pty" 60 reliable rt/chatter 40 40
  wait_for "$work/sub-reliable.fw" '^ready' 20
  timeout 30 "$ex/micro_ros_node" --port "$port" --node talker --pub chatter --count 40 --period-ms 30 \
    >"$work/sub-reliable.host" 2>&1
  qemu_verdict sub-reliable
  echo "  ($((SECONDS - t0)) s)"

  t0=$SECONDS
  echo "Rust subscriber, best effort: rt/fmu/out/status <- host px4_client --pub status (40 samples, 30 ms apart)"
  qemu_start sub-best-effort "$fw/subscriber" "$pty" 60 best-effort rt/fmu/out/status 40 10
  wait_for "$work/sub-best-effort.fw" '^ready' 20
  timeout 30 "$ex/px4_client" --port "$port" --pub status --count 40 --period-ms 30 \
    >"$work/sub-best-effort.host" 2>&1
  qemu_verdict sub-best-effort
  echo "  ($((SECONDS - t0)) s)"

  t0=$SECONDS
  echo "Rust requester (5 requests) -> host reply_adder"
  timeout 60 "$ex/reply_adder" 127.0.0.1 "$port" >"$work/requester.host" 2>&1 &
  local replier_pid=$!
  pids+=("$replier_pid")
  sleep 1
  qemu_start requester "$fw/requester" "$pty" 60 5
  qemu_verdict requester
  kill "$replier_pid" 2>/dev/null || true
  echo "  ($((SECONDS - t0)) s)"

  t0=$SECONDS
  echo "Rust replier (3 requests) <- host request_adder"
  qemu_start replier "$fw/replier" "$pty" 60 3 30
  wait_for "$work/replier.fw" '^ready' 20
  timeout 60 "$ex/request_adder" 127.0.0.1 "$port" >"$work/replier.host" 2>&1 &
  local requester_pid=$!
  pids+=("$requester_pid")
  qemu_verdict replier
  kill "$requester_pid" 2>/dev/null || true
  grep -q '^Reply received: 2 ' "$work/replier.host" || fail "host request_adder: no reply from the firmware"
  echo "  host: $(grep -c '^Reply received' "$work/replier.host") replies ($((SECONDS - t0)) s)"

  local name elf
  for name in c-app c-app-lto; do
    elf=$cfw/app.elf
    [ "$name" = c-app-lto ] && elf=$cfw_lto/app.elf
    t0=$SECONDS
    echo "C firmware ($([ "$name" = c-app-lto ] && echo "cross-language LTO" || echo "gcc's link")): 20 HelloWorld ->" \
      "host subscribe_hello_world, rt/chatter (40) <- host micro_ros_node"
    hello_subscriber "$name" reliable 20
    qemu_start "$name" "$elf" "$pty" 60 20 40 40 50
    wait_for "$work/$name.fw" '^ready' 20
    timeout 30 "$ex/micro_ros_node" --port "$port" --node talker --pub chatter --count 40 --period-ms 30 \
      >"$work/$name.pub" 2>&1
    qemu_verdict "$name"
    wait "$host_pid" 2>/dev/null || true
    ids_consecutive "$work/$name.host" 0 19 || fail "host subscriber: not 0..19 from the C firmware ($name)"
    echo "  ($((SECONDS - t0)) s)"
  done
  agent_stop
}

# proxy_start NAME [ARGS...]: our serial proxy (xrce-bench serial-proxy) between two pseudoterminals; sets
# dev_fw (QEMU's side), dev_agent (the agent's) and proxy_pid.
proxy_start() {
  local name=$1
  shift
  proxy_stop_file=$work/$name.stop
  timeout 300 "$proxy_bin" serial-proxy --json --stop-file "$proxy_stop_file" "$@" >"$work/$name.proxy" 2>&1 &
  proxy_pid=$!
  pids+=("$proxy_pid")
  wait_for "$work/$name.proxy" '^B ' 10
  dev_fw=$(sed -n 's/^A //p' "$work/$name.proxy")
  dev_agent=$(sed -n 's/^B //p' "$work/$name.proxy")
  cat >"$work/$name.toml" <<EOF
middleware = "ced"
[[transport]]
kind = "udp4"
port = $port
[[transport]]
kind = "serial"
dev = "$dev_agent"
EOF
}

# proxy_stop: the proxy stops and prints its counters (the last line of $work/NAME.proxy).
proxy_stop() {
  touch "$proxy_stop_file"
  wait "$proxy_pid" 2>/dev/null || true
}

# restart_agent NAME AFTER_PATTERN FILE: once FILE shows AFTER_PATTERN, stops the agent, waits a second and starts
# it again on the same configuration (the proxy keeps the firmware's line).
restart_agent() {
  wait_for "$3" "$2" 30
  sleep 0.5
  agent_stop
  echo "  agent stopped"
  sleep 1
  agent_start "$1-again" "$work/$1.toml"
  echo "  agent started again"
}

run_restart() {
  step "agent restarted in the middle (the line through the serial proxy, whose device outlives the agent)"
  local t0=$SECONDS first
  echo "Rust publisher, reliable: 60 samples 100 ms apart -> host subscribe_hello_world; agent restarted"
  proxy_start restart-pub
  agent_start restart-pub "$work/restart-pub.toml"
  hello_subscriber restart-pub reliable 1000000
  sleep 1
  qemu_start restart-pub "$fw/publisher" "$dev_fw" 90 reliable 60 100
  restart_agent restart-pub '^entities created' "$work/restart-pub.fw"
  qemu_verdict restart-pub
  sleep 1
  kill "$host_pid" 2>/dev/null || true
  [ "$(fw_value restart-pub 'sessions restored')" -ge 1 ] || fail "the publisher's session did not come back"
  first=$(ids_after_back "$work/restart-pub.host" 59) ||
    { cat "$work/restart-pub.host" >&2; fail "host subscriber: a gap after the restart"; }
  echo "  host: ids $first..59 after the restart, none missing; $(grep -c '^Received topic' "$work/restart-pub.host") in all ($((SECONDS - t0)) s)"
  agent_stop
  proxy_stop

  t0=$SECONDS
  echo "Rust subscriber, reliable: 150 samples 40 ms apart from host micro_ros_node; agent restarted"
  proxy_start restart-sub
  agent_start restart-sub "$work/restart-sub.toml"
  qemu_start restart-sub "$fw/subscriber" "$dev_fw" 90 reliable rt/chatter 150 60
  wait_for "$work/restart-sub.fw" '^ready' 20
  timeout 60 "$ex/micro_ros_node" --port "$port" --node talker --pub chatter --count 150 --period-ms 40 \
    >"$work/restart-sub.host" 2>&1 &
  local pub_pid=$!
  pids+=("$pub_pid")
  restart_agent restart-sub '^received index 20$' "$work/restart-sub.fw"
  qemu_verdict restart-sub
  wait "$pub_pid" 2>/dev/null || true
  [ "$(fw_value restart-sub 'sessions restored')" -ge 1 ] || fail "the subscriber's session did not come back"
  echo "  ($((SECONDS - t0)) s)"
  agent_stop
  proxy_stop

  t0=$SECONDS
  echo "C firmware: 60 HelloWorld 100 ms apart, 150 chatter samples 40 ms apart; agent restarted"
  proxy_start restart-c
  agent_start restart-c "$work/restart-c.toml"
  hello_subscriber restart-c reliable 1000000
  qemu_start restart-c "$cfw/app.elf" "$dev_fw" 90 60 150 60 100
  wait_for "$work/restart-c.fw" '^ready' 20
  timeout 60 "$ex/micro_ros_node" --port "$port" --node talker --pub chatter --count 150 --period-ms 40 \
    >"$work/restart-c.pub" 2>&1 &
  pub_pid=$!
  pids+=("$pub_pid")
  restart_agent restart-c '^received index 20$' "$work/restart-c.fw"
  qemu_verdict restart-c
  wait "$pub_pid" 2>/dev/null || true
  sleep 1
  kill "$host_pid" 2>/dev/null || true
  [ "$(fw_value restart-c 'sessions restored')" -ge 1 ] || fail "the C firmware's session did not come back"
  first=$(ids_after_back "$work/restart-c.host" 59) ||
    { cat "$work/restart-c.host" >&2; fail "host subscriber: a gap after the restart (C firmware)"; }
  echo "  host: ids $first..59 after the restart, none missing ($((SECONDS - t0)) s)"
  agent_stop
  proxy_stop
}

run_noise() {
  read -r drop corrupt split <<<"${MCU_NOISE:-0.001 0.001 8}"
  step "noisy line: each byte dropped with p=$drop, corrupted with p=$corrupt, runs split in pieces of 1..$split"
  local t0=$SECONDS
  echo "Rust publisher, reliable: 60 samples 50 ms apart -> host subscribe_hello_world"
  proxy_start noise-pub --drop "$drop" --corrupt "$corrupt" --split "$split" --seed 7
  agent_start noise-pub "$work/noise-pub.toml"
  hello_subscriber noise-pub reliable 60
  sleep 1
  qemu_start noise-pub "$fw/publisher" "$dev_fw" 120 reliable 60 50
  qemu_verdict noise-pub
  wait "$host_pid" 2>/dev/null || true
  ids_consecutive "$work/noise-pub.host" 0 59 || fail "host subscriber over the noisy line: not 0..59 in order"
  proxy_stop
  echo "  host: 0..59 in order; line: $(tail -n 1 "$work/noise-pub.proxy") ($((SECONDS - t0)) s)"
  agent_stop

  t0=$SECONDS
  echo "Rust subscriber, reliable: 100 samples 30 ms apart from host micro_ros_node"
  proxy_start noise-sub --drop "$drop" --corrupt "$corrupt" --split "$split" --seed 8
  agent_start noise-sub "$work/noise-sub.toml"
  qemu_start noise-sub "$fw/subscriber" "$dev_fw" 120 reliable rt/chatter 100 60
  wait_for "$work/noise-sub.fw" '^ready' 30
  timeout 60 "$ex/micro_ros_node" --port "$port" --node talker --pub chatter --count 100 --period-ms 30 \
    >"$work/noise-sub.host" 2>&1
  qemu_verdict noise-sub
  proxy_stop
  echo "  line: $(tail -n 1 "$work/noise-sub.proxy") ($((SECONDS - t0)) s)"
  agent_stop

  t0=$SECONDS
  echo "C firmware: 30 HelloWorld, 60 chatter samples"
  proxy_start noise-c --drop "$drop" --corrupt "$corrupt" --split "$split" --seed 9
  agent_start noise-c "$work/noise-c.toml"
  hello_subscriber noise-c reliable 30
  qemu_start noise-c "$cfw/app.elf" "$dev_fw" 120 30 60 60 50
  wait_for "$work/noise-c.fw" '^ready' 30
  timeout 60 "$ex/micro_ros_node" --port "$port" --node talker --pub chatter --count 60 --period-ms 30 \
    >"$work/noise-c.pub" 2>&1
  qemu_verdict noise-c
  wait "$host_pid" 2>/dev/null || true
  ids_consecutive "$work/noise-c.host" 0 29 || fail "host subscriber over the noisy line: not 0..29 from the C firmware"
  proxy_stop
  echo "  host: 0..29 in order; line: $(tail -n 1 "$work/noise-c.proxy") ($((SECONDS - t0)) s)"
  agent_stop
}

case $mode in
  all)
    run_direct
    run_restart
    run_noise
    ;;
  direct) run_direct ;;
  restart) run_restart ;;
  noise) run_noise ;;
  *) fail "unknown mode $mode (all, direct, restart, noise)" ;;
esac
echo
echo "mcu-ci ($mode): all passed in $(( $(date +%s) - start_all )) s"
