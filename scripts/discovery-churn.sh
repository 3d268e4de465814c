#!/usr/bin/env bash
# The agent's CPU and memory while ROS 2 participants and endpoints come and go around it (issue 21 item 7),
# in a fresh loopback-only network namespace: the agent (-m dds, udp4), two micro-ROS-like clients connected
# (xrce-bench ros: one publishing on rt/uros_a at 10 Hz, one subscribed to rt/uros_b), and an rclpy process
# (crates/xrce-agent/tests/ros2/ros_peer.py churn) that creates a new participant every 2 s (2 publishers, 2
# subscriptions on uros_a, uros_b and churn) and a publisher or subscription every 0.5 s in its own node.
# Measured over the churn only (the clients already connected): the agent's utime+stime, its RSS every 10 s,
# and the CPU time of each of its threads (by name: Fast DDS names its receive, event and listener threads).
#
# usage: scripts/discovery-churn.sh [SECONDS] [AGENT_ARG...]     (needs root for the namespace)
#   SECONDS         churn length (default 60)
#   AGENT_ARG...    more arguments of the agent (--eager-participant off, ...)
#   AGENT           the agent binary (default: target/release/xrce-agent, built here); any agent with the same
#                   command line (eProsima's MicroXRCEAgent) for a same-harness baseline
#   XRCE_ROS_VENV   the ROS 2 venv (default: target/ros2-venv, made by .ci/ros2-venv.sh)
#   XRCE_BENCH      default: target/release/xrce-bench, built here
#   CHURN_ARGS      more arguments of `ros_peer.py churn` (the idle baseline: `--participant-period 1e9
#                   --endpoint-period 1e9`, one participant that stays)
#   AGENT_LOG       a file: the agent's output goes there (RUST_LOG applies to our agent, as with -v)
#   PERF_OUT        a file: `perf record -g` of the agent during the churn goes there
# Last line: `CHURN cpu_s=… rss_start_kb=… rss_max_kb=… rss_end_kb=… participants=… endpoints=… switches=…`
# (switches: the agent's context switches during the churn, from `perf stat`, when perf is installed).
set -euo pipefail
if [ "${1:-}" = --inside ]; then
  shift
  secs=$1
  shift
  out=$(mktemp -d)
  "$AGENT" udp4 -p 8888 -v 0 "$@" >"$out/agent.log" 2>&1 &
  agent=$!
  trap 'kill "$agent" "${clients[@]}" 2>/dev/null || true; wait 2>/dev/null || true; rm -rf "$out"' EXIT
  sleep 1
  clients=()
  total=$((secs + 20))
  "$XRCE_BENCH" ros --direction to-ros --node uros_a --topic uros_a --rate 10 --payload 64 \
    --duration "${total}s" --warmup 1s --timeout "$((total + 30))s" >"$out/uros_a.log" 2>&1 &
  clients+=($!)
  "$XRCE_BENCH" ros --direction from-ros --node uros_b --topic uros_b --payload 64 --rate 10 \
    --duration "${total}s" --idle-timeout "${total}s" --timeout "${total}s" >"$out/uros_b.log" 2>&1 &
  clients+=($!)
  sleep 4
  ticks=$(getconf CLK_TCK)
  # utime + stime of a /proc stat file (the fields after the parenthesised name).
  cpu() { sed 's/.*) //' "$1" 2>/dev/null | awk '{ print $12 + $13 }'; }
  rss() { awk '/^VmRSS/ { print $2 }' "/proc/$agent/status"; }
  declare -A before
  for t in /proc/"$agent"/task/*; do before[${t##*/}]=$(cpu "$t/stat"); done
  cpu0=$(cpu "/proc/$agent/stat")
  rss0=$(rss)
  rss_max=$rss0
  echo "agent pid $agent, ${#before[@]} threads, RSS ${rss0} kB; churn for ${secs} s"
  PYTHONUNBUFFERED=1 LD_LIBRARY_PATH="$XRCE_ROS_VENV/lib" AMENT_PREFIX_PATH="$XRCE_ROS_VENV" \
    RMW_IMPLEMENTATION=rmw_fastrtps_cpp FASTDDS_BUILTIN_TRANSPORTS=UDPv4 ROS_LOG_DIR="$out/roslog" \
    "$XRCE_ROS_VENV/bin/python" "$PEER" --node churn churn --seconds "$secs" \
    --topic uros_a --topic uros_b --topic churn ${CHURN_ARGS:-} >"$out/churn.log" 2>&1 &
  churn=$!
  # Context switches of the agent's threads, the dead ones included (a count the machine's load hardly
  # moves, unlike CPU time).
  stat_pid=
  if command -v perf >/dev/null; then
    perf stat -x, -e context-switches -p "$agent" -o "$out/perfstat" -- sleep "$secs" >/dev/null 2>&1 &
    stat_pid=$!
  fi
  if [ -n "${PERF_OUT:-}" ]; then
    perf record -q -F 499 -g -p "$agent" -o "$PERF_OUT" -- sleep "$secs" >/dev/null 2>&1 &
  fi
  start=$(date +%s)
  while kill -0 "$churn" 2>/dev/null; do
    sleep 10
    r=$(rss)
    echo "t=$(( $(date +%s) - start ))s RSS ${r} kB"
    [ "$r" -gt "$rss_max" ] && rss_max=$r
  done
  wait "$churn" || { echo "the churn process failed:" >&2; tail -5 "$out/churn.log" >&2; exit 1; }
  cpu1=$(cpu "/proc/$agent/stat")
  rss1=$(rss)
  echo "busiest threads (CPU s during the churn; Fast DDS' threads carry the name of the thread that made them):"
  for t in /proc/"$agent"/task/*; do
    id=${t##*/}
    echo "$id $(cat "$t/comm") $(( $(cpu "$t/stat") - ${before[$id]:-0} ))"
  done | sort -k3 -rn | head -12 | awk -v hz="$ticks" '{ printf "  %-8s %-16s %6.2f\n", $1, $2, $3 / hz }'
  counts=$(grep -o '"participants": [0-9]*, "endpoints": [0-9]*' "$out/churn.log" | tr -d '",:' \
    | awk '{ print $1 "=" $2, $3 "=" $4 }')
  switches=
  if [ -n "$stat_pid" ]; then
    wait "$stat_pid" || true
    switches=" switches=$(awk -F, '/context-switches/ { print $1 }' "$out/perfstat")"
  fi
  [ -n "${AGENT_LOG:-}" ] && cp "$out/agent.log" "$AGENT_LOG"
  echo "CHURN cpu_s=$(awk -v a="$cpu0" -v b="$cpu1" -v hz="$ticks" 'BEGIN { printf "%.2f", (b - a) / hz }') \
rss_start_kb=$rss0 rss_max_kb=$rss_max rss_end_kb=$rss1 $counts$switches"
  exit 0
fi

cd "$(dirname "$0")/.."
secs=${1:-60}
shift || true
export XRCE_ROS_VENV=${XRCE_ROS_VENV:-$PWD/target/ros2-venv}
[ -x "$XRCE_ROS_VENV/bin/python" ] || { echo "no venv at $XRCE_ROS_VENV (run .ci/ros2-venv.sh $XRCE_ROS_VENV)" >&2; exit 2; }
if [ -z "${AGENT:-}" ] || [ -z "${XRCE_BENCH:-}" ]; then
  cargo build -q --release -p xrce-agent -p xrce-bench
fi
export AGENT=${AGENT:-$PWD/target/release/xrce-agent} XRCE_BENCH=${XRCE_BENCH:-$PWD/target/release/xrce-bench}
export PEER=$PWD/crates/xrce-agent/tests/ros2/ros_peer.py
netns=../shared/dds-peers/netns.sh
ns=xrce-churn-$$
trap 'ip netns del "$ns" 2>/dev/null || true' EXIT
"$netns" "$ns" "$PWD/scripts/discovery-churn.sh" --inside "$secs" "$@"
