#!/usr/bin/env bash
# Builds the user-mode-linux kernel of the virtual-clock HIL guest (run_in_vcan.sh --clock
# virtual): Linux 6.1 from Debian's linux-source-6.1 (the version of Debian's own linux.uml),
# UML's x86_64_defconfig plus config.fragment beside this script: time travel
# (CONFIG_UML_TIME_TRAVEL_SUPPORT, which Debian's linux.uml lacks), SocketCAN and vcan built in.
#
#   tests/hil/uml_kernel/build.sh [OUT_DIR]     (default: build/uml-kernel in this checkout)
#
# Writes OUT_DIR/linux. Idempotent: returns at once when OUT_DIR/linux was built from the same
# source package, fragment and script (OUT_DIR/stamp). Needs linux-source-6.1, bc, flex, bison
# (scripts/install-deps.sh); about 10 min on 2 cores, ~1.5 GB of disk while it builds.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
out=${1:-$(cd "$here/../../.." && pwd)/build/uml-kernel}
tarball=/usr/src/linux-source-6.1.tar.xz
fragment=$here/config.fragment
[[ -f $tarball ]] || {
  echo "uml_kernel: $tarball missing: apt-get install linux-source-6.1 (scripts/install-deps.sh)" >&2
  exit 1
}
version=$(dpkg-query -W -f='${Version}' linux-source-6.1 2>/dev/null || echo unknown)
stamp="linux-source-6.1 $version $(cat "$fragment" "${BASH_SOURCE[0]}" | sha256sum | cut -c1-16)"
if [[ -x $out/linux && -f $out/stamp && "$(cat "$out/stamp")" == "$stamp" ]]; then
  echo "uml_kernel: $out/linux is up to date ($stamp)"
  exit 0
fi

mkdir -p "$out"
out=$(cd "$out" && pwd)  # absolute: the build below runs in the source folder
work=$(mktemp -d "$out/src.XXXXXX")
trap 'rm -rf "$work"' EXIT
echo "uml_kernel: building $out/linux from $tarball ($version)"
tar -xJf "$tarball" -C "$work" --strip-components=1
cd "$work"
make -s ARCH=um x86_64_defconfig
scripts/kconfig/merge_config.sh -m .config "$fragment" >/dev/null
make -s ARCH=um olddefconfig
# Every option of the fragment must have survived olddefconfig (a dependency it lacks drops
# it silently).
missing=$(grep -E '^CONFIG_[A-Z0-9_]+=' "$fragment" | while IFS= read -r opt; do
  grep -qx -- "$opt" .config || echo "$opt"
done)
if [[ -n $missing ]]; then
  echo "uml_kernel: options dropped by the kernel's configuration: $missing" >&2
  exit 1
fi
make -s ARCH=um -j"$(nproc)" linux
strip -o "$out/linux.new" linux
mv -f "$out/linux.new" "$out/linux"
echo "$stamp" >"$out/stamp"
echo "uml_kernel: built $out/linux"
