#!/usr/bin/env bash
# The zenoh middleware's suite (docs/zenoh.md): crates/xrce-agent/tests/zenoh.rs, a Python peer that follows
# rmw_zenoh 0.2.x's formats (eclipse-zenoh from PyPI) against XRCE clients through `xrce-agent -m zenoh` and a
# Zenoh router, inside a loopback-only network namespace (every Zenoh session runs there); then the fleet test
# (scripts/zenoh-fleet.sh: two robots' agents behind veth links to a router in a ground namespace, one link cut
# and restored; namespaces joined to nothing else). Type hashes come
# from the Jazzy venv of .ci/ros2-venv.sh (AMENT_PREFIX_PATH). Built with --all-features like .ci/run's main
# build, so its artifacts are reused. Prints its duration. Run as root from the repository root:
#
#   .ci/zenoh.sh
set -euo pipefail
start=$(date +%s)
packages=(eclipse-zenoh==1.9.0 xxhash==4.1.0)
zenoh_venv=target/zenoh-venv
ros_venv=$(.ci/ros2-venv.sh target/ros2-venv)

venv_ok() {
  [ -x "$zenoh_venv/bin/python" ] && "$zenoh_venv/bin/python" - "${packages[@]}" <<'PY' >/dev/null 2>&1
import importlib.metadata as m, sys
sys.exit(any(m.version(n) != v for n, v in (p.split("==") for p in sys.argv[1:])))
PY
}
if ! venv_ok; then
  log=$(mktemp)
  if ! { python3 -m venv "$zenoh_venv" && "$zenoh_venv/bin/pip" install -q --disable-pip-version-check "${packages[@]}"; } \
      >"$log" 2>&1; then
    cat "$log" >&2
    exit 1
  fi
  rm -f "$log"
fi

netns=target/dds-peers/netns.sh
[ -x "$netns" ] || netns=../shared/dds-peers/netns.sh
ns=xrce-ci-zenoh-$$
trap 'ip netns del "$ns" 2>/dev/null || true' EXIT
# Built outside the namespace; only the run is inside it.
cargo test -q -p xrce-agent --all-features --test zenoh --no-run
XRCE_ZENOH_VENV=$PWD/$zenoh_venv XRCE_ROS_VENV=$ros_venv "$netns" "$ns" \
  cargo test -p xrce-agent --all-features --test zenoh -- --ignored
# The test build made target/debug/xrce-agent with every feature: the fleet runs that one.
XRCE_ZENOH_VENV=$zenoh_venv XRCE_ROS_VENV=$ros_venv AGENT=${CARGO_TARGET_DIR:-$PWD/target}/debug/xrce-agent \
  scripts/zenoh-fleet.sh 2
echo "Zenoh step: $(( $(date +%s) - start )) s"
