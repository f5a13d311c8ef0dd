// runtime/lcm_url.hpp: the URL operator commands travel on, written out by hand from LCM's udpm
// URL form (udpm://group:port?options; LCM's defaults 239.255.76.67 and 7667).
#include "runtime/lcm_url.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "runtime/channels.hpp"

namespace dualv::runtime {
namespace {

TEST(CommandUrl, UdpmGoesOnePortUpKeepingGroupAndOptions) {
  EXPECT_EQ(command_url("udpm://239.255.76.67:7667?ttl=0"), "udpm://239.255.76.67:7668?ttl=0");
  EXPECT_EQ(command_url("udpm://239.255.76.67:7667?ttl=1&recv_buf_size=2097152"),
            "udpm://239.255.76.67:7668?ttl=1&recv_buf_size=2097152");
  EXPECT_EQ(command_url("udpm://239.1.2.3:9000"), "udpm://239.1.2.3:9001");
  EXPECT_EQ(command_url("udpm://239.1.2.3:65534"), "udpm://239.1.2.3:65535");
  // The live default of dualv run and the CLI.
  EXPECT_EQ(command_url(kLiveUrl), "udpm://239.255.76.67:7668?ttl=0");
}

TEST(CommandUrl, UdpmWithoutGroupOrPortUsesLcmsDefaults) {
  EXPECT_EQ(command_url("udpm://"), "udpm://239.255.76.67:7668");
  EXPECT_EQ(command_url("udpm://?ttl=0"), "udpm://239.255.76.67:7668?ttl=0");
  EXPECT_EQ(command_url("udpm://239.1.2.3"), "udpm://239.1.2.3:7668");
  EXPECT_EQ(command_url("udpm://239.1.2.3?ttl=0"), "udpm://239.1.2.3:7668?ttl=0");
}

TEST(CommandUrl, OtherProvidersAreTheirOwnUrl) {
  // In-process and log providers: one instance carries everything, as before.
  for (const std::string u : {"memq://", "file:///tmp/run.lcmlog?speed=0", "file:///tmp/x?mode=w"})
    EXPECT_EQ(command_url(u), u);
}

TEST(CommandUrl, EmptyIsTheLiveDefaultAsForOpenLcm) {
  // open_lcm("") publishes on kLiveUrl: an e-stop sent with --lcm "" must reach the port
  // `dualv run --lcm kLiveUrl` listens on, not stay on the telemetry's.
  EXPECT_EQ(command_url(""), "udpm://239.255.76.67:7668?ttl=0");
}

TEST(CommandUrl, APortThatCannotGoUpIsRefusedNamingTheUrl) {
  for (const char* u : {"udpm://239.1.2.3:65535", "udpm://239.1.2.3:0",
                        "udpm://239.1.2.3:", "udpm://239.1.2.3:76x7?ttl=0", "udpm://239.1.2.3:-5",
                        "udpm://239.1.2.3:99999999999"}) {
    try {
      (void)command_url(u);
      ADD_FAILURE() << u << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(u), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("1..65534"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace dualv::runtime
