#!/usr/bin/env bash
# Installs the C client library as eProsima's client installs itself, so that projects written for it build
# unchanged: headers in PREFIX/include (uxr/client/..., ucdr/...), PREFIX/lib/libmicroxrcedds_client.a and
# libmicrocdr.a, and the CMake packages microxrcedds_client and microcdr in PREFIX/lib/cmake/.
#
#   scripts/c-install.sh PREFIX [cargo build options, e.g. --target thumbv7em-none-eabihf]
#   XRCE_C_MULTITHREAD=1 scripts/c-install.sh PREFIX    # eProsima's multithread profile (POSIX threads)
#
# libmicrocdr.a is a copy of the client archive (the Micro-CDR functions live there, beside one Rust runtime):
# a library linking only -lmicrocdr (micro-ROS' type support) takes the objects it needs from it, and a
# program linking both archives takes each object once.
set -euo pipefail
[ $# -ge 1 ] || { echo "usage: $0 PREFIX [cargo build options]" >&2; exit 2; }
prefix=$1; shift
here=$(cd "$(dirname "$0")/.." && pwd)
cd "$here"
cargo build --release -p xrce-client-c "$@"
target_dir=$(cargo metadata --format-version 1 --no-deps | python3 -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')
# The archive is under <target dir>/[<triple>/]release: the triple of --target, if given.
lib_dir=$target_dir/release prev=
for arg in "$@"; do
  case $arg in --target=*) lib_dir=$target_dir/${arg#--target=}/release ;; esac
  [ "$prev" = --target ] && lib_dir=$target_dir/$arg/release
  prev=$arg
done
mkdir -p "$prefix/include" "$prefix/lib/cmake/microxrcedds_client" "$prefix/lib/cmake/microcdr"
cp -r crates/xrce-client-c/include/uxr crates/xrce-client-c/include/ucdr "$prefix/include/"
if [ "${XRCE_C_MULTITHREAD:-0}" = 1 ]; then
  # The headers must say what the library is: the profile's mutexes are fields of the shared structures.
  sed -i 's|^/\* #define UCLIENT_PROFILE_MULTITHREAD \*/$|#define UCLIENT_PROFILE_MULTITHREAD|' "$prefix/include/uxr/client/config.h"
  grep -q '^#define UCLIENT_PROFILE_MULTITHREAD$' "$prefix/include/uxr/client/config.h"
fi
install -m 644 "$lib_dir/libmicroxrcedds_client.a" "$prefix/lib/libmicroxrcedds_client.a"
install -m 644 "$lib_dir/libmicroxrcedds_client.a" "$prefix/lib/libmicrocdr.a"
install -m 644 crates/xrce-client-c/cmake/microxrcedds_client*.cmake "$prefix/lib/cmake/microxrcedds_client/"
install -m 644 crates/xrce-client-c/cmake/microcdr*.cmake "$prefix/lib/cmake/microcdr/"
echo "installed the C client library in $prefix (find_package(microxrcedds_client) with CMAKE_PREFIX_PATH=$prefix)"
