#include "runtime/target_check.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace dualv::runtime {
namespace {

const char* kCan0Up =
    "3: can0: <NOARP,UP,LOWER_UP,ECHO> mtu 16 qdisc pfifo_fast state UP mode DEFAULT group "
    "default qlen 10\n"
    "    link/can  promiscuity 0 minmtu 0 maxmtu 0 \n"
    "    can state ERROR-ACTIVE (berr-counter tx 0 rx 0) restart-ms 100 \n"
    "\t  bitrate 1000000 sample-point 0.750 \n"
    "\t  tq 125 prop-seg 2 phase-seg1 3 phase-seg2 2 sjw 1\n";

class TargetCheck : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/dualv-sys-test.XXXXXX";
    ASSERT_NE(mkdtemp(tmpl), nullptr);
    root_ = tmpl;
    in_.sysfs_root = root_.string();
    in_.uname_version = "#1 SMP PREEMPT_DYNAMIC Debian 6.1.0";
    in_.rtprio = Limit{0, false};
    in_.memlock = Limit{8 * 1024 * 1024, false};
    in_.cap_sys_nice = false;
    in_.cap_ipc_lock = false;
    in_.ip_details = "";
  }
  void TearDown() override { std::filesystem::remove_all(root_); }
  void put(const std::string& rel, const std::string& content) {
    const auto p = root_ / rel;
    std::filesystem::create_directories(p.parent_path());
    std::ofstream(p) << content;
  }
  void make_can0(const std::string& flags) {
    put("class/net/can0/type", "280\n");
    put("class/net/can0/flags", flags + "\n");
  }
  const CheckItem& item(const TargetReport& r, const std::string& name) {
    for (const auto& i : r.items)
      if (i.name == name) return i;
    static CheckItem none{"<missing>", CheckStatus::kFail, "", ""};
    ADD_FAILURE() << "no item " << name << " in\n" << r.format();
    return none;
  }
  std::filesystem::path root_;
  TargetCheckInput in_;
};

TEST_F(TargetCheck, BareDevelopmentMachineFailsWithFixes) {
  const TargetReport r = check_target(in_);
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(item(r, "PREEMPT_RT kernel").status, CheckStatus::kFail);
  EXPECT_NE(item(r, "PREEMPT_RT kernel").fix.find("linux-image-rt"), std::string::npos);
  EXPECT_EQ(item(r, "isolated CPUs").status, CheckStatus::kWarn);
  EXPECT_EQ(item(r, "rtprio limit").status, CheckStatus::kFail);
  EXPECT_NE(item(r, "rtprio limit").fix.find("LimitRTPRIO"), std::string::npos);
  EXPECT_EQ(item(r, "memlock limit").status, CheckStatus::kFail);
  EXPECT_EQ(item(r, "CAN interface can0").status, CheckStatus::kFail);
  EXPECT_EQ(item(r, "CAN interface can0").detail, "not present");
  for (const auto& i : r.items) {
    if (i.status != CheckStatus::kOk) {
      EXPECT_FALSE(i.fix.empty()) << i.name;
    }
  }
  const std::string text = r.format();
  EXPECT_NE(text.find("[FAIL] PREEMPT_RT kernel"), std::string::npos) << text;
  EXPECT_NE(text.find("fix: "), std::string::npos) << text;
}

TEST_F(TargetCheck, ReadyTargetPasses) {
  put("kernel/realtime", "1\n");
  put("devices/system/cpu/isolated", "3\n");
  in_.uname_version = "#1 SMP PREEMPT_RT Debian 6.1.0-rt";
  in_.rtprio = Limit{99, false};
  in_.memlock = Limit{0, true};
  make_can0("0x40081");
  in_.ip_details = kCan0Up;
  const TargetReport r = check_target(in_);
  EXPECT_TRUE(r.ok(true)) << r.format();
  EXPECT_EQ(item(r, "CAN bitrate").detail, "1000000 bit/s");
  EXPECT_EQ(item(r, "CAN controller state").detail, "ERROR-ACTIVE");
  EXPECT_NE(item(r, "isolated CPUs").detail.find("3"), std::string::npos);
}

TEST_F(TargetCheck, CapabilitiesReplaceTheLimits) {
  in_.cap_sys_nice = true;
  in_.cap_ipc_lock = true;
  const TargetReport r = check_target(in_);
  EXPECT_EQ(item(r, "rtprio limit").status, CheckStatus::kOk);
  EXPECT_EQ(item(r, "memlock limit").status, CheckStatus::kOk);
}

TEST_F(TargetCheck, RtprioBelowTheLoopPriorityFails) {
  in_.rtprio = Limit{50, false};
  in_.priority = 80;
  EXPECT_EQ(item(check_target(in_), "rtprio limit").status, CheckStatus::kFail);
  in_.priority = 50;
  EXPECT_EQ(item(check_target(in_), "rtprio limit").status, CheckStatus::kOk);
}

TEST_F(TargetCheck, CanDownOrAtTheWrongBitrateSaysHowToFixIt) {
  make_can0("0x80");  // IFF_UP clear
  in_.ip_details = std::string(kCan0Up);
  in_.can_bitrate = 500'000;
  const TargetReport r = check_target(in_);
  EXPECT_EQ(item(r, "CAN interface can0").status, CheckStatus::kFail);
  EXPECT_NE(item(r, "CAN interface can0").fix.find("80-can0.network"), std::string::npos);
  EXPECT_EQ(item(r, "CAN bitrate").status, CheckStatus::kFail);
  EXPECT_NE(item(r, "CAN bitrate").detail.find("1000000 bit/s, configuration says 500000"),
            std::string::npos);
}

TEST_F(TargetCheck, NotACanInterface) {
  put("class/net/can0/type", "1\n");  // Ethernet
  const TargetReport r = check_target(in_);
  EXPECT_NE(item(r, "CAN interface can0").detail.find("not a CAN interface"), std::string::npos);
}

TEST_F(TargetCheck, BusOffFails) {
  make_can0("0x1");
  std::string d = kCan0Up;
  d.replace(d.find("ERROR-ACTIVE"), 12, "BUS-OFF");
  in_.ip_details = d;
  EXPECT_EQ(item(check_target(in_), "CAN controller state").status, CheckStatus::kFail);
}

TEST_F(TargetCheck, HostileInterfaceNameIsNeverPassedToAShell) {
  in_.can_interface = "can0; rm -rf /";
  in_.ip_details.reset();  // would run `ip` if the name were accepted
  EXPECT_EQ(item(check_target(in_), "CAN interface can0; rm -rf /").detail, "not present");
}

TEST(IpDetails, ParsesVcanAndRealControllers) {
  const IpCanDetails real = parse_ip_details(kCan0Up);
  EXPECT_EQ(real.bitrate.value_or(0), 1'000'000);
  EXPECT_EQ(real.state.value_or(""), "ERROR-ACTIVE");
  EXPECT_EQ(real.restart_ms.value_or(-1), 100);
  EXPECT_FALSE(real.vcan);
  const IpCanDetails v = parse_ip_details(
      "4: vcan0: <NOARP,UP,LOWER_UP> mtu 72 qdisc noqueue state UNKNOWN\n"
      "    link/can  promiscuity 0 minmtu 0 maxmtu 0 \n    vcan numtxqueues 1\n");
  EXPECT_TRUE(v.vcan);
  EXPECT_FALSE(v.bitrate.has_value());
}

}  // namespace
}  // namespace dualv::runtime
