#pragma once
// Counts calls of the global operator new in the drivers test binaries (alloc_counter.cpp
// replaces it), so tests can assert that the real-time path allocates nothing.
namespace dualv::drivers::test {
long allocation_count() noexcept;
}  // namespace dualv::drivers::test
