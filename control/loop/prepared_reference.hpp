#pragma once
// What the real-time loop follows, made ready off the real-time thread (docs/architecture.md,
// "Two-phase switching"): a program loaded, pre-flighted and rebased on the pose the loop
// reported, or a stream's reference at that pose; with the controller switches of the run.
//
// Set-up code builds one (prepare_program / prepare_stream: they allocate and may throw) and
// hands its pointer to the loop (Executor::start); the loop takes it at a cycle boundary, follows
// it, and hands it back to be freed off the real-time thread. The loop only reads the members
// marked RT; `name` is for messages.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "control/model/model.hpp"
#include "control/trajectory/limits.hpp"
#include "control/trajectory/program.hpp"
#include "control/trajectory/sequencer.hpp"
#include "control/trajectory/streaming_reference.hpp"

namespace dualv::control {

enum class ReferenceKind : std::uint8_t { kProgram = 0, kStream, kHold };
const char* to_string(ReferenceKind k) noexcept;

struct PreparedReference {
  ReferenceKind kind = ReferenceKind::kProgram;          // RT
  std::optional<trajectory::Sequencer> sequencer;        // RT: kProgram
  std::optional<trajectory::StreamingReference> stream;  // RT: kStream, kHold
  model::Pose start = model::Pose::Zero();               // RT: the pose it begins at
  bool projection = true;                                // RT: controller switches (eq. 20)
  bool feedforward = true;                               //     and the computed feedforward
  double settle_time = 0.2;  // RT: [s] held at the end before the loop reports it finished
  // RT: e-stops counted (Executor::estop_epoch) when the start was asked for. The loop refuses
  // the reference when any came since: an e-stop during preparation is never lost.
  std::uint64_t estop_epoch = 0;
  std::uint64_t id = 0;  // RT: names it in events and telemetry (> 0)
  std::string name;      // set-up only
};

// A program (already pre-flighted by the caller) rebased on `from`, the pose the loop reports:
// a point-to-point move within `rebase` joins `from` to its first pose (program.hpp rebase()).
// Throws std::runtime_error / ConfigError as rebase and the sequencer do.
std::unique_ptr<PreparedReference> prepare_program(const model::Model& model,
                                                   const trajectory::Program& program,
                                                   const model::Pose& from,
                                                   const trajectory::RebaseOptions& rebase);

// A stream's reference at rest at `from`; setpoints must lie in `workspace`.
std::unique_ptr<PreparedReference> prepare_stream(const model::Model& model,
                                                  const trajectory::StreamingLimits& limits,
                                                  const trajectory::Workspace& workspace,
                                                  double period, const model::Pose& from);

}  // namespace dualv::control
