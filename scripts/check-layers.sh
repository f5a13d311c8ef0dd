#!/usr/bin/env bash
# Lists the #include edges between the layers of docs/architecture.md "Layers" and fails (exit 1) on
# one that goes up (a lower layer including a higher one, or sim including more of drivers
# than the bus interface). Run from anywhere: scripts/check-layers.sh [-q]
#   -q  only the violations (no edge table)
# The build enforces the same rules (each layer library compiles with its own include root,
# cmake/DualvHelpers.cmake dualv_add_library; ctest layer_includes); this script also sees a
# header that no library source includes, and prints the edges.
#
# Layers, bottom to top, and what each may include (besides itself and the C++/system
# headers):
#   common        -
#   firmware_if   -                               pure data and codecs
#   control/model -                               pure math (Eigen only, reads no YAML);
#                                                 used by safety and sim
#   drivers       common firmware_if
#   safety        common firmware_if control/model drivers
#   control       common firmware_if control/model drivers safety   (control/* but model)
#   sim/canopen   firmware_if                     the CANopen slave parts (dualv_canopen_slave),
#                                                 which the drivers' tests link too
#   sim           common firmware_if control/model sim/canopen, of drivers only the interfaces:
#                 drivers/can/ (the bus) and drivers/actuator_set.hpp (what SimActuatorSet is)
#   lcm runtime   every layer above but apps      (dualv_lcm/ = generated LCM types)
#   apps          everything
# tests/ and bench/ are not checked.
set -u
root=$(cd "$(dirname "$0")/.." && pwd)
quiet=0
[[ "${1:-}" == -q ]] && quiet=1

layer_of() {  # layer_of PATH (repository-relative) -> layer name, or "" when not a layer
  case $1 in
    common/*) echo common ;;
    firmware_if/*) echo firmware_if ;;
    control/model/*) echo control/model ;;
    control/*) echo control ;;
    drivers/can/*) echo drivers/can ;;
    drivers/actuator_set.*) echo drivers/actuator_set ;;
    drivers/*) echo drivers ;;
    safety/*) echo safety ;;
    sim/canopen/*) echo sim/canopen ;;
    sim/*) echo sim ;;
    lcm/* | dualv_lcm/*) echo lcm ;;
    runtime/*) echo runtime ;;
    apps/*) echo apps ;;
    *) echo "" ;;
  esac
}

allowed() {  # allowed FROM TO -> 0 when FROM may include TO
  local from=$1 to=$2
  [[ $from == "$to" ]] && return 0
  case $from in
    common | firmware_if) return 1 ;;
    control/model) return 1 ;;
    drivers/can) [[ $to == common || $to == firmware_if ]] ;;
    drivers/actuator_set) [[ $to == common || $to == firmware_if ]] ;;
    drivers) [[ $to =~ ^(common|firmware_if|drivers/can|drivers/actuator_set)$ ]] ;;
    safety) [[ $to =~ ^(common|firmware_if|control/model|drivers|drivers/can|drivers/actuator_set)$ ]] ;;
    control) [[ $to =~ ^(common|firmware_if|control/model|drivers|drivers/can|drivers/actuator_set|safety)$ ]] ;;
    sim/canopen) [[ $to == firmware_if ]] ;;
    sim) [[ $to =~ ^(common|firmware_if|control/model|sim/canopen|drivers/can|drivers/actuator_set)$ ]] ;;
    lcm | runtime) [[ $to != apps ]] ;;
    apps) return 0 ;;
    *) return 1 ;;
  esac
}

declare -A edges=()
violations=()
cd "$root" || exit 2
while IFS= read -r file; do
  from=$(layer_of "$file")
  [[ -z $from ]] && continue
  while IFS=: read -r line inc; do
    to=$(layer_of "$inc")
    [[ -z $to ]] && continue
    [[ $from == "$to" ]] && continue
    key="$from -> $to"
    edges[$key]=$((${edges[$key]:-0} + 1))
    allowed "$from" "$to" || violations+=("$file:$line: $from includes $inc ($to)")
  done < <(grep -noE '^[[:space:]]*#[[:space:]]*include[[:space:]]+"[^"]+"' "$file" |
    sed -E 's/^([0-9]+):.*"([^"]+)"$/\1:\2/')
done < <(find common firmware_if control drivers safety sim lcm runtime apps \
  -type f \( -name '*.hpp' -o -name '*.cpp' -o -name '*.h' \) 2>/dev/null | sort)

if [[ $quiet -eq 0 ]]; then
  echo "include edges between layers (count):"
  for k in "${!edges[@]}"; do
    from=${k%% -> *} to=${k##* -> }
    mark=ok
    allowed "$from" "$to" || mark=UP
    printf '  %-30s %4d  %s\n' "$k" "${edges[$k]}" "$mark"
  done | sort
fi
if [[ ${#violations[@]} -gt 0 ]]; then
  echo "upward or forbidden includes (${#violations[@]}):"
  printf '  %s\n' "${violations[@]}"
  exit 1
fi
echo "layers: no upward include"
exit 0
