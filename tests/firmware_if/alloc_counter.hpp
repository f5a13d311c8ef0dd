#pragma once
// Counts calls of the global operator new in this test binary (alloc_counter.cpp replaces it).
namespace dualv::fw::test {
long allocation_count() noexcept;
}
