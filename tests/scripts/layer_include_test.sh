#!/usr/bin/env bash
# The compiler, not only scripts/check-layers.sh, refuses an include that goes up a layer
# (docs/architecture.md "Layers"): a probe file is compiled with the include path a layer
# library compiles with (its own include root and those of the libraries it links,
# cmake/DualvHelpers.cmake dualv_add_library; tests/scripts/CMakeLists.txt writes them, one
# directory a line, to DIR/<target>.txt). An include of a higher layer must fail with "No
# such file" for that header; the headers the layer may include must compile with the same
# path, so a refusal is not an artefact of a broken path. Also: dualv_model (control/model)
# links no YAML library.
#   tests/scripts/layer_include_test.sh CXX DIR
set -u
cxx=$1
dir=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0
n=0

# compile TARGET HEADER...: compiles a file including HEADER... with TARGET's include path;
# prints the compiler's output, returns its status.
compile() {
  local target=$1
  shift
  local flags=() d
  while IFS= read -r d; do
    [[ -n $d && $d != /usr/include ]] && flags+=("-I$d")
  done <"$dir/$target.txt"
  n=$((n + 1))
  local probe=$tmp/probe_$n.cpp
  printf '#include "%s"\n' "$@" >"$probe"
  "$cxx" -std=c++20 -fsyntax-only "${flags[@]}" "$probe" 2>&1
}

# refused TARGET HEADER: the layer TARGET cannot include HEADER (a higher layer's, or a part of
# drivers it does not link).
refused() {
  local out
  if out=$(compile "$1" "$2"); then
    echo "FAIL $1 compiled #include \"$2\": the include path lets it go up"
    fail=1
  elif grep -qE "$2.*(No such file|file not found)|(No such file|file not found).*$2" <<<"$out"; then
    echo "ok   $1 refuses \"$2\" (No such file)"
  else
    echo "FAIL $1 #include \"$2\" failed for another reason:"
    echo "$out" | head -20
    fail=1
  fi
}

# allowed TARGET HEADER...: the layer TARGET compiles with these includes.
allowed() {
  local out target=$1
  shift
  if out=$(compile "$target" "$@"); then
    echo "ok   $target includes $*"
  else
    echo "FAIL $target cannot include $*:"
    echo "$out" | head -20
    fail=1
  fi
}

for t in dualv_common dualv_firmware_if dualv_model dualv_can_bus dualv_actuator_set \
  dualv_drivers dualv_safety dualv_control dualv_canopen_slave dualv_sim dualv_runtime; do
  if [[ ! -s $dir/$t.txt ]]; then
    echo "FAIL no include path for $t in $dir (tests/scripts/CMakeLists.txt)"
    exit 1
  fi
  if grep -qxF "$(cd "$(dirname "$0")/../.." && pwd)" "$dir/$t.txt"; then
    echo "FAIL $t has the repository root on its include path"
    fail=1
  fi
done

# Bottom layers: nothing above them.
refused dualv_common firmware_if/cob_id.hpp
refused dualv_firmware_if drivers/canopen/master.hpp
refused dualv_firmware_if common/yaml_reader.hpp
allowed dualv_firmware_if firmware_if/cob_id.hpp firmware_if/eds.hpp
# control/model: pure math, reads no YAML (its loader is control/config).
refused dualv_model common/yaml_reader.hpp
refused dualv_model control/config/model_config.hpp
refused dualv_model safety/safety_filter.hpp
allowed dualv_model control/model/kinematics.hpp
# drivers: the bus below the CANopen master; nothing of safety, control, sim.
refused dualv_can_bus drivers/canopen/master.hpp
refused dualv_actuator_set drivers/can/can_bus.hpp
refused dualv_drivers safety/safety_filter.hpp
refused dualv_drivers sim/drive_emulator.hpp
allowed dualv_drivers drivers/canopen/master.hpp drivers/can/socketcan_bus.hpp drivers/actuator_set.hpp
# safety below control.
refused dualv_safety control/controller/controller.hpp
refused dualv_safety control/loop/executor.hpp
# control below sim, runtime and apps.
refused dualv_control sim/plant.hpp
refused dualv_control runtime/telemetry.hpp
refused dualv_control apps/experiment/machine.hpp
allowed dualv_control control/loop/control_cycle.hpp control/trajectory/program.hpp
# sim: of drivers the bus interface and the actuator set only, never the master.
# The CANopen slave parts: firmware_if only (the drivers' tests link them without sim).
refused dualv_canopen_slave sim/plant.hpp
refused dualv_canopen_slave drivers/can/can_bus.hpp
allowed dualv_canopen_slave sim/canopen/pdo_engine.hpp sim/canopen/cia402_slave.hpp firmware_if/pdo.hpp
refused dualv_sim drivers/canopen/master.hpp
refused dualv_sim drivers/canopen_config.hpp
refused dualv_sim safety/safety_filter.hpp
refused dualv_sim control/trajectory/program.hpp
allowed dualv_sim drivers/can/in_process_bus.hpp drivers/actuator_set.hpp sim/drive_emulator.hpp
# runtime below apps.
refused dualv_runtime apps/commands.hpp
refused dualv_runtime sim/plant.hpp

# control/model links no YAML (its direct link libraries).
if grep -qiE 'yaml|dualv_common' "$dir/dualv_model.links.txt"; then
  echo "FAIL dualv_model links $(tr '\n' ' ' <"$dir/dualv_model.links.txt"): control/model reads no YAML"
  fail=1
else
  echo "ok   dualv_model links $(tr '\n' ' ' <"$dir/dualv_model.links.txt")(no YAML)"
fi
exit $fail
