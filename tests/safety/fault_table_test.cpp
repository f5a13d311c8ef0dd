// The fault -> reaction table is complete, and docs/safety.md shows the same table.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>

#include "safety/fault.hpp"

namespace dualv::safety {
namespace {

TEST(FaultTable, EveryFaultHasARuleAndAName) {
  for (int i = 0; i < kFaultCount; ++i) {
    const auto f = static_cast<Fault>(i);
    EXPECT_EQ(rule(f).fault, f);
    EXPECT_STRNE(to_string(f), "none");
  }
}

TEST(FaultTable, StandardsMapping) {
  // Drive faults, communication loss and internal errors: STO; e-stop requests and limits: SS1.
  for (Fault f : {Fault::kDriveFault, Fault::kDriveLost, Fault::kBusError, Fault::kStaleFeedback,
                  Fault::kSafetyCheckMissed, Fault::kDeadlineMisses, Fault::kInvalidState})
    EXPECT_EQ(reaction_of(f), Reaction::kSto) << to_string(f);
  for (Fault f : {Fault::kEstopLcm, Fault::kEstopSignal, Fault::kEstopCli, Fault::kTorqueLimit,
                  Fault::kJointVelocity, Fault::kPlateVelocity, Fault::kWorkspace,
                  Fault::kSingularity, Fault::kTrackingError})
    EXPECT_EQ(reaction_of(f), Reaction::kSs1) << to_string(f);
  EXPECT_EQ(strongest(bit(Fault::kTorqueLimit) | bit(Fault::kDriveLost)), Reaction::kSto);
  EXPECT_EQ(strongest(0), Reaction::kWarn);
}

// docs/safety.md has a markdown table row per fault: | `kName` | name | reaction | clearing |
TEST(FaultTable, DocsTableMatchesTheCode) {
  std::ifstream in(std::string(DUALV_SOURCE_DIR) + "/docs/safety.md");
  ASSERT_TRUE(in) << "docs/safety.md missing";
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string doc = ss.str();
  const std::regex row(
      R"(\|\s*`(k\w+)`\s*\|[^|]*\|\s*(SS1|STO|warning)\s*\|\s*(reset|condition)\s*\|)");
  std::map<std::string, std::pair<std::string, std::string>> rows;
  for (auto it = std::sregex_iterator(doc.begin(), doc.end(), row); it != std::sregex_iterator();
       ++it)
    rows[(*it)[1]] = {(*it)[2], (*it)[3]};
  const char* names[] = {
      "kEstopLcm",          "kEstopSignal",        "kEstopCli",     "kEstopInput",
      "kDriveLost",         "kDriveFault",         "kBusError",     "kStaleFeedback",
      "kEncoderJump",       "kInvalidState",       "kDeadlineMiss", "kDeadlineMisses",
      "kSafetyCheckMissed", "kNonFiniteCommand",   "kTorqueLimit",  "kTorqueRate",
      "kJointVelocity",     "kPlateVelocity",      "kWorkspace",    "kSingularity",
      "kTrackingError",     "kCommandStreamStale", "kStopTimeout"};
  static_assert(std::size(names) == kFaultCount);
  EXPECT_EQ(rows.size(), static_cast<std::size_t>(kFaultCount));
  for (int i = 0; i < kFaultCount; ++i) {
    const FaultRule& r = kFaultTable[static_cast<std::size_t>(i)];
    auto it = rows.find(names[i]);
    ASSERT_NE(it, rows.end()) << names[i] << " not in docs/safety.md";
    EXPECT_EQ(it->second.first, to_string(r.reaction)) << names[i];
    EXPECT_EQ(it->second.second, r.clearing == Clearing::kCondition ? "condition" : "reset")
        << names[i];
  }
}

}  // namespace
}  // namespace dualv::safety
