// Sampling a program at run time allocates nothing: global operator new is replaced in this
// test binary and counts calls while a window is open.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "control/trajectory/sequencer.hpp"
#include "test_util.hpp"

namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};

void* counted_alloc(std::size_t n) {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1);
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void* counted_aligned_alloc(std::size_t n, std::align_val_t a) {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1);
  const std::size_t al = static_cast<std::size_t>(a);
  if (void* p = std::aligned_alloc(al, (n + al - 1) / al * al)) return p;
  throw std::bad_alloc();
}
}  // namespace

void* operator new(std::size_t n) { return counted_alloc(n); }
void* operator new[](std::size_t n) { return counted_alloc(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted_alloc(n);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted_alloc(n);
  } catch (...) {
    return nullptr;
  }
}
void* operator new(std::size_t n, std::align_val_t a) { return counted_aligned_alloc(n, a); }
void* operator new[](std::size_t n, std::align_val_t a) { return counted_aligned_alloc(n, a); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

namespace dualv::trajectory {
namespace {

struct CountingWindow {
  CountingWindow() {
    g_allocations = 0;
    g_counting = true;
  }
  ~CountingWindow() { g_counting = false; }
  long count() const { return g_allocations.load(); }
};

TEST(NoAlloc, TheCounterSeesAllocations) {  // the test itself can fail
  CountingWindow w;
  auto* v = new std::vector<int>(100);
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
