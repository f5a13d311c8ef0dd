#pragma once
// A fuzz target's invariant: when it does not hold, the condition and its line are printed
// and the process aborts, so libFuzzer reports a finding and keeps the input.
#include <cstdio>
#include <cstdlib>

namespace dualv::fuzz {

[[noreturn]] inline void invariant_failed(const char* condition, const char* file, int line) {
  std::fprintf(stderr, "%s:%d: fuzz invariant failed: %s\n", file, line, condition);
  std::abort();
}

}  // namespace dualv::fuzz

#define FUZZ_CHECK(condition) \
  ((condition) ? void() : ::dualv::fuzz::invariant_failed(#condition, __FILE__, __LINE__))
