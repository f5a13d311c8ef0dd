#!/usr/bin/env bash
# Installs every Debian package dualv needs to build, test and package.
# Idempotent: returns in about a second when everything is already there.
set -euo pipefail

PKGS=(
  build-essential cmake pkg-config clang-format
  ccache   # scripts/test.sh: the package build reuses the release build's objects
  clang libclang-rt-dev   # the libFuzzer targets (fuzz/, scripts/fuzz.sh): clang + libFuzzer runtime
  libeigen3-dev
  liblcm-dev liblcm-bin libglib2.0-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libyaml-cpp-dev libcli11-dev libfmt-dev libspdlog-dev
  libsodium-dev libsystemd-dev
  user-mode-linux kmod iproute2 can-utils
  linux-source-6.1 bc flex bison   # the time-travel UML kernel (tests/hil/uml_kernel/build.sh)
  python3-matplotlib python3-numpy python3-yaml
  dpkg-dev file
)

missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
