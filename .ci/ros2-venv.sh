#!/usr/bin/env bash
# Creates a ROS 2 venv of the ROS 2 suite (crates/xrce-agent/tests/ros2.rs): rclpy over the distribution's
# Fast DDS from PyPI wheels (cp311), headers and libraries included (the agent builds against them with
# AMENT_PREFIX_PATH=OUT_DIR), nothing else. Jazzy: Fast DDS 2.14 (ros-fastrtps); Kilted: Fast DDS 3.2
# (ros-fastdds). Idempotent and quiet: a second run only checks. Run as root on a fresh Debian machine
# (python3-venv comes from apt when missing).
#
#   usage: .ci/ros2-venv.sh OUT_DIR [jazzy|kilted]     e.g. .ci/ros2-venv.sh target/ros2-venv
#
# Use it with LD_LIBRARY_PATH=OUT_DIR/lib AMENT_PREFIX_PATH=OUT_DIR RMW_IMPLEMENTATION=rmw_fastrtps_cpp
# OUT_DIR/bin/python (the suite sets these itself from XRCE_ROS_VENV=OUT_DIR, and FASTDDS_BUILTIN_TRANSPORTS=UDPv4 unless XRCE_ROS_SHM=1),
# and only inside a loopback-only network namespace (../shared/dds-peers/netns.sh).
set -euo pipefail
out_arg=${1:?usage: ros2-venv.sh OUT_DIR [jazzy|kilted]}
distro=${2:-jazzy}
case "$distro" in
  jazzy) packages=(ros-rclpy==7.1.6 ros-rmw-fastrtps-cpp==8.4.3 ros-std-msgs==5.3.6 ros-std-srvs==5.3.6 ros-diagnostic-msgs==5.3.6 ros-fastrtps==2.14.5) ;;
  kilted) packages=(ros-rclpy==9.1.2 ros-rmw-fastrtps-cpp==9.3.3 ros-std-msgs==5.5.1 ros-std-srvs==5.5.1 ros-diagnostic-msgs==5.5.1 ros-fastdds==3.2.3) ;;
  *) echo "ros2-venv.sh: unknown distribution $distro (jazzy or kilted)" >&2; exit 2 ;;
esac
mkdir -p "$out_arg"
out=$(cd "$out_arg" && pwd)
log=$(mktemp)
trap 'rm -f "$log"' EXIT

# The wheels are built for CPython 3.11.
py=$(command -v python3.11 || command -v python3 || true)
if [ -z "$py" ] || ! "$py" -m venv --help >/dev/null 2>&1; then
  if ! { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      python3 python3-venv; } >"$log" 2>&1; then
    cat "$log" >&2
    exit 1
  fi
  py=$(command -v python3.11 || command -v python3)
fi

check() {
  [ -x "$out/bin/python" ] && "$out/bin/python" - "${packages[@]}" <<'PY' >/dev/null 2>&1
import importlib.metadata as m, sys
for pinned in sys.argv[1:]:
    name, version = pinned.split("==")
    if m.version(name) != version:
        sys.exit(1)
PY
}

if ! check; then
  if ! { "$py" -m venv "$out" && "$out/bin/python" -m pip install -q --disable-pip-version-check "${packages[@]}"; } \
      >"$log" 2>&1; then
    cat "$log" >&2
    exit 1
  fi
  check || { echo "ros2-venv.sh: $out lacks ${packages[*]} after installing" >&2; exit 1; }
fi
# rclpy must import with the venv's libraries (no DDS participant is created here).
if ! LD_LIBRARY_PATH="$out/lib" AMENT_PREFIX_PATH="$out" RMW_IMPLEMENTATION=rmw_fastrtps_cpp \
    "$out/bin/python" -c 'import rclpy, std_msgs.msg, std_srvs.srv, diagnostic_msgs.msg' >"$log" 2>&1; then
  cat "$log" >&2
  exit 1
fi
echo "$out"
