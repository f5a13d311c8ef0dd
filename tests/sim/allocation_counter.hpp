#pragma once
// Counts calls of the global operator new between start() and stop(), in this
// test binary only (allocation_counter.cpp replaces operator new). The
// replacement lives in its own file so the compiler cannot pair it with
// inlined library code and warn about mismatched new/delete.
namespace testing_alloc {
void start() noexcept;
long stop() noexcept;  // allocations since start()
}  // namespace testing_alloc
