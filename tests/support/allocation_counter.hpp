#pragma once
// Counts calls of the global operator new in a test binary that links dualv_test_support
// (allocation_counter.cpp replaces it), so tests can assert that a real-time path allocates
// nothing: take allocation_count() before and after, compare.
namespace dualv::test {
long allocation_count() noexcept;
// Counting from a mark: start_counting(), then stop_counting() returns the allocations made
// in between (one mark per binary at a time).
void start_counting() noexcept;
long stop_counting() noexcept;
}  // namespace dualv::test
