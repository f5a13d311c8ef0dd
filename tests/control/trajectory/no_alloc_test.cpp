// Sampling a program at run time allocates nothing: global operator new is replaced in this
// test binary (dualv_test_support) and the calls made while a window is open are counted.
#include <gtest/gtest.h>

#include "control/trajectory/sequencer.hpp"
#include "test_util.hpp"
#include "tests/support/allocation_counter.hpp"

namespace dualv::trajectory {
namespace {

struct CountingWindow {
  CountingWindow() : start(dualv::test::allocation_count()) {}
  long count() const { return dualv::test::allocation_count() - start; }
  long start;
};

TEST(NoAlloc, TheCounterSeesAllocations) {  // the test itself can fail
  CountingWindow w;
  std::vector<int>* volatile v = new std::vector<int>(100);  // volatile: no new/delete elision
  delete v;
  EXPECT_GE(w.count(), 2);
}

TEST(NoAlloc, SamplingThePaperProgramAllocatesNothing) {
  for (auto kind : {TimingKind::kRetimed, TimingKind::kOriginal, TimingKind::kSmooth}) {
    Sequencer seq(test::dualv_model(), with_timing(test::paper_program(), kind));
    Reference r;
    const double dt = (seq.duration() + 0.5) / 10000;
    double checksum = 0;
    long allocations = 0;
    {
      CountingWindow w;
      for (int i = 0; i < 10000; ++i) {
        const double t = -0.1 + i * dt;
        seq.sample(t, r);
        checksum += r.q_dd.sum();
        seq.sample_cartesian(t, r);
        checksum += r.cartesian.X_ddd.sum();
      }
      allocations = w.count();
    }
    EXPECT_EQ(allocations, 0) << to_string(kind);
    EXPECT_TRUE(std::isfinite(checksum));
  }
}

TEST(NoAlloc, FailingSamplesAllocateNothingEither) {
  Program p(test::kHome);
  p.add_ptp(Pose(0.0, 1.2, 0.0), 1.0);
  Sequencer seq(test::dualv_model(), p);
  Reference r;
  CountingWindow w;
  for (int i = 0; i < 1000; ++i) seq.sample(i * 1e-3, r);
  seq.sample(NAN, r);
  EXPECT_EQ(w.count(), 0);
}

}  // namespace
}  // namespace dualv::trajectory
