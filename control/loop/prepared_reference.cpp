#include "control/loop/prepared_reference.hpp"

namespace dualv::control {

const char* to_string(ReferenceKind k) noexcept {
  switch (k) {
    case ReferenceKind::kProgram:
      return "program";
    case ReferenceKind::kStream:
      return "stream";
    case ReferenceKind::kHold:
      return "hold";
  }
  return "unknown";
}

std::unique_ptr<PreparedReference> prepare_program(const model::Model& model,
                                                   const trajectory::Program& program,
                                                   const model::Pose& from,
                                                   const trajectory::RebaseOptions& rebase) {
  auto ref = std::make_unique<PreparedReference>();
  ref->kind = ReferenceKind::kProgram;
  ref->start = from;
  ref->sequencer.emplace(model, trajectory::rebase(program, from, rebase));
  return ref;
}

std::unique_ptr<PreparedReference> prepare_stream(const model::Model& model,
                                                  const trajectory::StreamingLimits& limits,
                                                  const trajectory::Workspace& workspace,
                                                  double period, const model::Pose& from) {
  auto ref = std::make_unique<PreparedReference>();
  ref->kind = ReferenceKind::kStream;
  ref->start = from;
  ref->stream.emplace(model, limits, workspace, period);
  ref->stream->reset(from);  // at rest at the actual pose: starting a stream never moves
  return ref;
}

}  // namespace dualv::control
