#!/usr/bin/env bash
# The Zenoh fleet test (docs/zenoh.md, "Fleets"; crates/xrce-agent/tests/zenoh/fleet.py): a "ground" network
# namespace with a Zenoh router and a ROS-like checker, and ROBOTS "robot" namespaces, each joined only to ground
# by its own veth pair (198.18.<i>.1 ground side, 198.18.<i>.2 robot side; nothing else, so no Zenoh traffic can
# leave the machine), each running `xrce-agent -m zenoh` and a micro-ROS-like node in namespace /uav_<i>. Robot
# 1's link is cut, then restored. Needs root. Prints the FLEET lines and its duration.
#
# usage: scripts/zenoh-fleet.sh [ROBOTS]        (default 2)
# environment: XRCE_ZENOH_VENV (default target/zenoh-venv, made by .ci/zenoh.sh), XRCE_ROS_VENV (default
#   target/ros2-venv, .ci/ros2-venv.sh; the type hashes), AGENT (an agent binary built
#   with the zenoh feature; default: the debug one, built here with --all-features as .ci/run's)
set -euo pipefail
cd "$(dirname "$0")/.."
robots=${1:-2}
[ "$(id -u)" = 0 ] || { echo "zenoh-fleet.sh needs root (network namespaces)" >&2; exit 2; }
start=$(date +%s)
venv=$(cd "${XRCE_ZENOH_VENV:-target/zenoh-venv}" && pwd)
# The agents' type hashes (std_msgs): the Jazzy venv of .ci/ros2-venv.sh.
export AMENT_PREFIX_PATH=$(cd "${XRCE_ROS_VENV:-target/ros2-venv}" && pwd)
target=${CARGO_TARGET_DIR:-$PWD/target}
[ -n "${AGENT:-}" ] || cargo build -q -p xrce-agent --all-features
cargo build -q -p xrce-client --example micro_ros_node
agent=${AGENT:-$target/debug/xrce-agent}
node=$target/debug/examples/micro_ros_node

ground=xzg-$$
prefix=xzr-$$-
cleanup() {
  for i in $(seq 1 "$robots"); do ip netns del "$prefix$i" 2>/dev/null || true; done
  ip netns del "$ground" 2>/dev/null || true
}
trap cleanup EXIT
ip netns add "$ground"
ip -n "$ground" link set lo up
for i in $(seq 1 "$robots"); do
  ns=$prefix$i
  ip netns add "$ns"
  ip -n "$ns" link set lo up
  ip -n "$ground" link add "robot$i" type veth peer name up0 netns "$ns"
  ip -n "$ground" addr add "198.18.$i.1/24" dev "robot$i"
  ip -n "$ns" addr add "198.18.$i.2/24" dev up0
  ip -n "$ground" link set "robot$i" up
  ip -n "$ns" link set up0 up
done
ip netns exec "$ground" "$venv/bin/python" crates/xrce-agent/tests/zenoh/fleet.py "$robots" "$agent" "$node" "$prefix"
echo "Zenoh fleet step: $(( $(date +%s) - start )) s"
