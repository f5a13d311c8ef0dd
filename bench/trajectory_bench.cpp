// Sampling the paper's program (config/paper.yaml): ns per sample. Target < 1 us for the
// Cartesian + joint references (the paper's controller ran at 10 kHz).
#include <benchmark/benchmark.h>

#include "control/config/model_config.hpp"
#include "control/trajectory/sequencer.hpp"

namespace {

using namespace dualv;
using namespace dualv::trajectory;

const model::Model& bench_model() {
  static const model::Model m =
      model::load_model_file(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
  return m;
}

Program bench_program(TimingKind kind) {
  ProgramContext ctx;
  ctx.start = ctx.home = bench_model().home;
  return with_timing(load_program_file(std::string(DUALV_SOURCE_DIR) + "/config/paper.yaml", ctx),
                     kind);
}

// Walks the program at 10 kHz, wrapping around at its end.
template <bool kJoint>
void run(benchmark::State& state, TimingKind kind) {
  Sequencer seq(bench_model(), bench_program(kind));
  Reference r;
  double t = 0.0;
  const double dt = 1e-4, T = seq.duration();
  for (auto _ : state) {
    const SampleStatus st = kJoint ? seq.sample(t, r) : seq.sample_cartesian(t, r);
    benchmark::DoNotOptimize(st);
    benchmark::DoNotOptimize(r);
    t += dt;
    if (t > T) t = 0.0;
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_PaperProgram_CartesianAndJoint(benchmark::State& s) { run<true>(s, TimingKind::kRetimed); }
void BM_PaperProgram_CartesianOnly(benchmark::State& s) { run<false>(s, TimingKind::kRetimed); }
void BM_PaperProgram_Smooth_CartesianAndJoint(benchmark::State& s) {
  run<true>(s, TimingKind::kSmooth);
}

}  // namespace

BENCHMARK(BM_PaperProgram_CartesianAndJoint);
BENCHMARK(BM_PaperProgram_CartesianOnly);
BENCHMARK(BM_PaperProgram_Smooth_CartesianAndJoint);
