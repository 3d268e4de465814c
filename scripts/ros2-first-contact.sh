#!/usr/bin/env bash
# Repeats the ROS 2 suite (crates/xrce-agent/tests/ros2.rs) N times, each run in a fresh loopback-only network
# namespace, and prints one table per test from the ROS2-SUMMARY lines ("10 consecutive runs" of issue 11).
#
# usage: scripts/ros2-first-contact.sh [N] [TEST_FILTER]     (needs root for the namespace)
#   XRCE_ROS_VENV   the ROS 2 venv (default: target/ros2-venv, made by .ci/ros2-venv.sh)
#   AGENT=release   measure the release agent (built here) instead of the tests' debug binary
#   DISTRO=jazzy|kilted  the release agent built against that distribution's own Fast DDS (a venv of its wheels,
#                   .ci/ros2-venv.sh target/ros2-venv[-kilted] DISTRO, made here when missing) and its rclpy
#                   node, shared memory on both sides (XRCE_ROS_SHM=1)
#   XRCE_ROS_AGENT  any other agent binary with the same command line (eProsima's MicroXRCEAgent, say)
# The raw output of every run is kept in target/ros2-runs/run-K.log, the agent's log in agent-K.log.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-10}
filter=${2:-}
distro=${DISTRO:-}
case "$distro" in
  "") ;;
  jazzy) export XRCE_ROS_VENV=$(.ci/ros2-venv.sh target/ros2-venv jazzy) ;;
  kilted) export XRCE_ROS_VENV=$(.ci/ros2-venv.sh target/ros2-venv-kilted kilted) ;;
  *) echo "DISTRO: jazzy or kilted" >&2; exit 2 ;;
esac
export XRCE_ROS_VENV=${XRCE_ROS_VENV:-$PWD/target/ros2-venv}
# The first-contact thresholds are asserted here (the CI run only prints them; see tests/ros2.rs).
export XRCE_ROS_STRICT=${XRCE_ROS_STRICT:-1}
[ -x "$XRCE_ROS_VENV/bin/python" ] || { echo "no venv at $XRCE_ROS_VENV (run .ci/ros2-venv.sh $XRCE_ROS_VENV)" >&2; exit 2; }
netns=target/dds-peers/netns.sh
[ -x "$netns" ] || netns=../shared/dds-peers/netns.sh
if [ -n "$distro" ]; then
  AMENT_PREFIX_PATH=$XRCE_ROS_VENV CARGO_TARGET_DIR=target/$distro cargo build -q --release -p xrce-agent
  export XRCE_ROS_AGENT=$PWD/target/$distro/release/xrce-agent XRCE_ROS_SHM=1
elif [ "${AGENT:-}" = release ]; then
  cargo build -q --release -p xrce-agent
  export XRCE_ROS_AGENT=$PWD/target/release/xrce-agent
fi
# Build outside the namespace; only run inside it.
exe=$(cargo test -q -p xrce-agent --test ros2 --no-run --message-format=json 2>/dev/null \
  | grep '"name":"ros2","src_path"' | grep -o '"executable":"[^"]*"' | tail -1 | cut -d'"' -f4)
[ -x "$exe" ] || { echo "could not build the ros2 test" >&2; exit 2; }
out=target/ros2-runs${distro:+/$distro}
mkdir -p "$out"
ns=xros-rep-$$
trap 'ip netns del "$ns" 2>/dev/null || true' EXIT
echo "agent: ${XRCE_ROS_AGENT:-debug build (CARGO_BIN_EXE)}; node: $XRCE_ROS_VENV; $runs runs"
# The agent's log of each run (first-contact gate, participants created again) is kept beside it.
export RUST_LOG=${RUST_LOG:-xrce_agent=info,xrce_dds=debug}
for k in $(seq 1 "$runs"); do
  ip netns del "$ns" 2>/dev/null || true
  rm -f "$out/agent-$k.log"
  XRCE_AGENT_LOG=$PWD/$out/agent-$k.log \
    "$netns" "$ns" "$exe" --ignored --test-threads 1 --nocapture $filter >"$out/run-$k.log" 2>&1 || true
  grep -h '^ROS2-SUMMARY' "$out/run-$k.log" | sed "s/^ROS2-SUMMARY /run=$k /"
done > "$out/summary.txt"
# One table per test: a column per key, a row per run.
awk '
  { test=$2; row=$1; sub(/^run=/, "", row); line=row
    for (i = 3; i <= NF; i++) { n = split($i, kv, "="); if (n < 2) { line = line " " $i; continue }
      if (!(test SUBSEP kv[1] in seen)) { seen[test, kv[1]] = 1; keys[test] = keys[test] " " kv[1] }
      val[test, row, kv[1]] = kv[2] }
    if (!(test in rows)) order[++ntests] = test
    rows[test] = rows[test] " " row }
  END {
    for (t = 1; t <= ntests; t++) { test = order[t]; nk = split(keys[test], ks, " "); nr = split(rows[test], rs, " ")
      printf "\n%s\n%-4s", test, "run"; for (j = 1; j <= nk; j++) printf " %s", ks[j]; printf "\n"
      for (r = 1; r <= nr; r++) { printf "%-4s", rs[r]
        for (j = 1; j <= nk; j++) printf " %*s", length(ks[j]), val[test, rs[r], ks[j]]; printf "\n" }
      pass = 0; for (r = 1; r <= nr; r++) if (val[test, rs[r], "pass"] == "true") pass++
      printf "passed %d of %d\n", pass, nr } }' "$out/summary.txt"
