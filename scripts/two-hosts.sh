#!/usr/bin/env bash
# ROS 2 across two hosts (issue 21, item 6; crates/xrce-agent/tests/ros2_two_hosts.rs): two network namespaces,
# "robot" (the agent and its XRCE clients, where the test binary runs) and "ground" (the rclpy nodes the tests
# start there), joined only to each other by a veth pair with addresses from 198.18.0.0/15 (the range reserved
# for benchmark tests). The pair is created inside the namespaces, never in the host's: no DDS traffic can leave
# the machine. Each namespace gets a private /dev/shm, as shared/dds-peers/netns.sh does. Needs root.
#
# usage: scripts/two-hosts.sh [--multicast on|off|both] [TEST_FILTER]
#   on    multicast crosses the link (MULTICAST flag on both ends, 224.0.0.0/4 routed to it), as on a LAN:
#         the `multicast_on::` tests (default discovery; ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST)
#   off   no multicast crosses it: the `multicast_off::` tests (ROS_STATIC_PEERS, and the control without)
#   both  (default) on, then off, each on fresh namespaces
# environment:
#   XRCE_ROS_VENV   the ROS 2 venv (default target/ros2-venv; .ci/ros2-venv.sh makes it)
#   AGENT=release   run the release agent (built here) instead of the tests' debug one
#   XRCE_ROS_AGENT  any other agent binary with the same command line
#   NETNS_SUFFIX    suffix of the namespaces' names (default: this script's PID), for runs side by side
# The output of each setting is kept in target/two-hosts/multicast-{on,off}.log; the ROS2-SUMMARY lines are
# printed again at the end.
set -euo pipefail
cd "$(dirname "$0")/.."

usage() { sed -n 's/^# \{0,1\}//; 8,19p' "$0" >&2; exit 2; }
mode=both
if [ "${1:-}" = --multicast ]; then
  mode=${2:-}
  shift 2 || usage
fi
case $mode in on | off | both) ;; *) usage ;; esac
filter=${1:-}
[ "$(id -u)" = 0 ] || { echo "two-hosts.sh needs root (network namespaces)" >&2; exit 2; }
export XRCE_ROS_VENV=${XRCE_ROS_VENV:-$PWD/target/ros2-venv}
[ -x "$XRCE_ROS_VENV/bin/python" ] || { echo "no venv at $XRCE_ROS_VENV (run .ci/ros2-venv.sh $XRCE_ROS_VENV)" >&2; exit 2; }
XRCE_ROS_VENV=$(cd "$XRCE_ROS_VENV" && pwd)

# Build outside the namespaces (no DDS participant starts while building); only run inside them.
if [ "${AGENT:-}" = release ]; then
  cargo build -q --release -p xrce-agent
  export XRCE_ROS_AGENT=${CARGO_TARGET_DIR:-$PWD/target}/release/xrce-agent
fi
exe=$(cargo test -q -p xrce-agent --all-features --test ros2_two_hosts --no-run --message-format=json \
  | grep '"name":"ros2_two_hosts","src_path"' | grep -o '"executable":"[^"]*"' | tail -1 | cut -d'"' -f4)
[ -x "$exe" ] || { echo "could not build the ros2_two_hosts test" >&2; exit 2; }

suffix=${NETNS_SUFFIX:-$$}
robot=xrce-robot-$suffix
ground=xrce-ground-$suffix
robot_addr=198.18.0.1
ground_addr=198.18.0.2
remove_namespaces() {
  ip netns del "$robot" 2>/dev/null || true
  ip netns del "$ground" 2>/dev/null || true
}
trap remove_namespaces EXIT

# Classic BPF for a tc filter in direct-action mode: IPv4 to 224.0.0.0/4 is dropped (TC_ACT_SHOT), the rest
# passes (TC_ACT_OK). `ldh [12]; jne #0x800, pass; ld [30]; and #0xf0000000; jne #0xe0000000, pass; ret #2;
# pass: ret #0`. The kernel's classifiers here are u32 and bpf, without the drop action, hence this.
drop_multicast='7,40 0 0 12,21 0 4 2048,32 0 0 30,84 0 0 4026531840,21 0 1 3758096384,6 0 0 2,6 0 0 0'

# link_end NS DEV on|off: one end of the link, up.
link_end() {
  local ns=$1 dev=$2
  if [ "$3" = on ]; then
    ip -n "$ns" link set "$dev" multicast on
    ip -n "$ns" link set "$dev" up
    ip -n "$ns" route add 224.0.0.0/4 dev "$dev"
  else
    ip -n "$ns" link set "$dev" multicast off
    # The flag and the missing route alone do not stop a socket that names its interface (IP_MULTICAST_IF): it
    # still sends multicast through it, and the other end delivers it (checked with a plain UDP socket; Fast DDS
    # 2.9 and 2.14 happen not to send then). Dropped on the way out, the link carries none, whoever sends.
    tc -n "$ns" qdisc add dev "$dev" clsact
    tc -n "$ns" filter add dev "$dev" egress bpf da bytecode "$drop_multicast"
    ip -n "$ns" link set "$dev" up
  fi
}

# make_link on|off: fresh namespaces joined by the veth pair.
make_link() {
  remove_namespaces
  ip netns add "$robot"
  ip netns add "$ground"
  for ns in "$robot" "$ground"; do
    # IPv4 only: not even a link-local IPv6 address on the link.
    ip netns exec "$ns" sh -c 'echo 1 >/proc/sys/net/ipv6/conf/all/disable_ipv6 &&
      echo 1 >/proc/sys/net/ipv6/conf/default/disable_ipv6' 2>/dev/null || true
    ip -n "$ns" link set lo up
  done
  ip link add robot0 netns "$robot" type veth peer name ground0 netns "$ground"
  ip -n "$robot" addr add "$robot_addr/24" dev robot0
  ip -n "$ground" addr add "$ground_addr/24" dev ground0
  link_end "$robot" robot0 "$1"
  link_end "$ground" ground0 "$1"
}

out=target/two-hosts
mkdir -p "$out"
status=0
case $mode in both) settings="on off" ;; *) settings=$mode ;; esac
logs=()
for m in $settings; do
  logs+=("$out/multicast-$m.log")
  make_link "$m"
  echo "=== two hosts, multicast $m: $robot ($robot_addr, agent and XRCE clients) <-> $ground ($ground_addr, rclpy)"
  # The test binary runs in "robot" (its own /dev/shm); it starts the ROS nodes in "ground" itself.
  if ! XRCE_GROUND_NETNS=$ground ip netns exec "$robot" sh -c \
      'mount -t tmpfs -o size=512m,mode=1777 robot-shm /dev/shm || echo "two-hosts.sh: no private /dev/shm" >&2; exec "$@"' \
      robot-sh "$exe" --ignored --test-threads 1 --nocapture "multicast_$m::$filter" 2>&1 | tee "$out/multicast-$m.log"; then
    status=1
  fi
  remove_namespaces
done
echo
echo "=== two hosts: summary"
grep -h '^ROS2-SUMMARY' "${logs[@]}" || true
exit $status
