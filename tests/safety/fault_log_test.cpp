// The fault log: RT ring (no allocation, drops counted when full) and the JSON-lines writer.
#include "safety/fault_log.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "tests/support/allocation_counter.hpp"

namespace dualv::safety {
namespace {

TEST(FaultLog, RecordAllocatesNothingAndCountsDrops) {
  FaultLog log;
  FaultEvent e;
  e.fault = Fault::kDriveLost;
  const long before = dualv::test::allocation_count();
  for (std::size_t i = 0; i < FaultLog::kCapacity + 10; ++i) {
    e.cycle = static_cast<std::int64_t>(i);
    log.record(e);
  }
  EXPECT_EQ(dualv::test::allocation_count() - before, 0);
  EXPECT_EQ(log.dropped(), 10u);
  FaultEvent out;
  ASSERT_TRUE(log.try_pop(out));
  EXPECT_EQ(out.cycle, 0);  // the oldest survive: the first fault is the one that matters
}

TEST(FaultLog, WriterProducesOneJsonLinePerEvent) {
  const std::string path =
      (std::filesystem::temp_directory_path() / "dualv_fault_log_test.jsonl").string();
  std::remove(path.c_str());
  FaultLog log;
  FaultEvent e;
  e.cycle = 1234;
  e.time_ns = 1'234'000'000;
  e.fault = Fault::kTrackingError;
  e.reaction = Reaction::kSs1;
  e.value = 0.012;
  e.limit = 0.005;
  e.n = 4;
  e.torque = {1.5, -2.5, 0, 0};
  log.record(e);
  e.kind = EventKind::kResetRefused;
  e.fault = Fault::kCount;
  e.blocking = bit(Fault::kDriveLost);
  log.record(e);
  int published = 0;
  {
    FaultLogWriter w(path);
    EXPECT_EQ(w.drain(log, [&](const FaultEvent&) { ++published; }), 2u);
  }
  EXPECT_EQ(published, 2);
  std::ifstream in(path);
  std::string l1, l2;
  std::getline(in, l1);
  std::getline(in, l2);
  EXPECT_NE(l1.find("\"cycle\":1234"), std::string::npos) << l1;
  EXPECT_NE(l1.find("\"cause\":\"tracking error\""), std::string::npos) << l1;
  EXPECT_NE(l1.find("\"reaction\":\"SS1\""), std::string::npos) << l1;
  EXPECT_NE(l1.find("\"torque\":[1.5,-2.5,0,0]"), std::string::npos) << l1;
  EXPECT_NE(l2.find("reset refused"), std::string::npos) << l2;
  EXPECT_NE(l2.find("drive lost"), std::string::npos) << l2;
  EXPECT_THROW(FaultLogWriter("/nonexistent-dir/x.jsonl"), std::runtime_error);
}

}  // namespace
}  // namespace dualv::safety
