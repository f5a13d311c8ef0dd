#include "firmware_if/result.hpp"

#include <gtest/gtest.h>

#include <string>

namespace dualv::fw {
namespace {

TEST(Result, ValueAndError) {
  const Result<int> good = 42;
  EXPECT_TRUE(good.ok());
  EXPECT_TRUE(static_cast<bool>(good));
  EXPECT_EQ(*good, 42);
  EXPECT_EQ(good.error(), Error::kNone);
  const Result<int> bad = Error::kWrongDlc;
  EXPECT_FALSE(bad.ok());
  EXPECT_EQ(bad.error(), Error::kWrongDlc);
  EXPECT_EQ(bad.value(), 0);  // defined, not UB
}

TEST(Result, EveryErrorHasText) {
  for (int e = 0; e <= static_cast<int>(Error::kSizeMismatch); ++e) {
    const std::string s = to_string(static_cast<Error>(e));
    EXPECT_FALSE(s.empty());
    EXPECT_NE(s, "?") << e;
  }
}

}  // namespace
}  // namespace dualv::fw
