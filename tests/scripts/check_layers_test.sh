#!/usr/bin/env bash
# scripts/check-layers.sh must fail (exit 1, naming file:line) on an include that goes up a
# layer and pass a tree whose includes all go down (docs/architecture.md "Layers"). It runs
# on small trees made here, with a copy of the script, and then on the repository itself.
set -u
src=$(cd "$(dirname "$0")/../.." && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0

# tree NAME: a fresh tree with the script and one header per layer, includes going down only.
tree() {
  local t=$tmp/$1
  mkdir -p "$t/scripts" "$t/common" "$t/firmware_if" "$t/drivers/can" "$t/drivers/canopen" "$t/sim"
  cp "$src/scripts/check-layers.sh" "$t/scripts/"
  echo '#pragma once' >"$t/common/a.hpp"
  echo '#pragma once' >"$t/firmware_if/b.hpp"
  printf '#pragma once\n#include "firmware_if/b.hpp"\n' >"$t/drivers/can/bus.hpp"
  printf '#pragma once\n#include "drivers/can/bus.hpp"\n#include "common/a.hpp"\n' \
    >"$t/drivers/canopen/master.hpp"
  printf '#pragma once\n#include "drivers/can/bus.hpp"\n' >"$t/sim/emu.hpp"
  echo "$t"
}

# expect NAME RC PATTERN: the script in tree NAME exits RC and prints PATTERN.
expect() {
  local out rc
  out=$(bash "$tmp/$1/scripts/check-layers.sh" -q 2>&1)
  rc=$?
  if [[ $rc -ne $2 ]] || ! grep -qF -- "$3" <<<"$out"; then
    echo "FAIL $1: exit $rc (expected $2), output lacks '$3':"
    echo "$out"
    fail=1
  else
    echo "ok   $1: exit $rc, '$3'"
  fi
}

tree clean >/dev/null
expect clean 0 "layers: no upward include"

t=$(tree firmware_up)  # firmware_if (bottom) including drivers: up
printf '#pragma once\n\n#include "drivers/canopen/master.hpp"\n' >"$t/firmware_if/b.hpp"
expect firmware_up 1 "firmware_if/b.hpp:3: firmware_if includes drivers/canopen/master.hpp (drivers)"

t=$(tree sim_master)  # sim may use the bus interface only, not the CANopen master
printf '#pragma once\n#include "drivers/canopen/master.hpp"\n' >"$t/sim/emu.hpp"
expect sim_master 1 "sim/emu.hpp:2: sim includes drivers/canopen/master.hpp (drivers)"

t=$(tree slave_parts_up)  # the CANopen slave parts use firmware_if only, not the rest of sim
mkdir -p "$t/sim/canopen"
printf '#pragma once\n#include "sim/emu.hpp"\n' >"$t/sim/canopen/pdo.hpp"
expect slave_parts_up 1 "sim/canopen/pdo.hpp:2: sim/canopen includes sim/emu.hpp (sim)"

t=$(tree common_up)  # an indented include in a .cpp counts too
printf '#include <vector>\n  #  include "firmware_if/b.hpp"\n' >"$t/common/c.cpp"
expect common_up 1 "common/c.cpp:2: common includes firmware_if/b.hpp (firmware_if)"

# The repository itself.
if out=$(bash "$src/scripts/check-layers.sh" -q 2>&1); then
  echo "ok   repository: $out"
else
  echo "FAIL repository:"
  echo "$out"
  fail=1
fi
exit $fail
