// The real `dualv stream --csv` binary, writing through LCM's file provider
// (file://...?mode=w) instead of the network: the test reads the LCM log back and puts every
// message through the robot's own checks (runtime::CommandVerifier): a signed start, the
// file's poses in its order with increasing sequences, a signed stop. A bad file is refused
// before anything is sent.
#include <gtest/gtest.h>
#include <stdio.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <vector>

#include "dualv_lcm/command_t.hpp"
#include "dualv_lcm/setpoint_t.hpp"
#include "runtime/channels.hpp"
#include "runtime/command_auth.hpp"

namespace {

namespace fs = std::filesystem;
using namespace dualv;

const std::string kDualv = DUALV_BINARY;

struct Exit {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

Exit run(const std::string& args) {
  Exit r;
  FILE* p = popen((kDualv + " " + args + " 2>&1").c_str(), "r");
  if (p == nullptr) return r;
  char buf[4096];
  while (fgets(buf, sizeof buf, p) != nullptr) r.output += buf;
  const int status = pclose(p);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

class StreamCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("dualv_stream_cli_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    key_path_ = (dir_ / "lab1.key").string();
    std::ofstream key(key_path_, std::ios::binary);
    for (int i = 0; i < 32; ++i) key.put(static_cast<char>(17 * i + 3));
    key.close();
    fs::permissions(key_path_, fs::perms::owner_read | fs::perms::owner_write);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write_csv(const std::string& text) {
    const std::string path = (dir_ / "poses.csv").string();
    std::ofstream(path) << text;
    return path;
  }
  std::string log_path() const { return (dir_ / "stream.lcmlog").string(); }
  std::string stream_args(const std::string& csv) const {
    return "stream --key " + key_path_ + " --lcm 'file://" + log_path() + "?mode=w' --csv " + csv +
           " --rate 200";
  }

  fs::path dir_;
  std::string key_path_;
};

TEST_F(StreamCli, SendsTheFilesPosesSignedAndInOrderBetweenAStartAndAStop) {
  struct Row {
    double t, x, y, theta;
  };
  const std::vector<Row> rows = {{0.0, 0.0, 0.25, 0.0},
                                 {0.5, 0.005, 0.25, 0.0},
                                 {1.0, 0.005, 0.255, 0.01},
                                 {1.5, 0.0, 0.255, 0.0}};
  std::string csv = "t,x,y,theta\n";
  for (const Row& r : rows)
    csv += std::to_string(r.t) + "," + std::to_string(r.x) + "," + std::to_string(r.y) + "," +
           std::to_string(r.theta) + "\n";
  const Exit r = run(stream_args(write_csv(csv)));
  ASSERT_EQ(r.exit_code, 0) << r.output;

  // The robot's checks, each message at the time it was logged (published).
  runtime::CommandVerifier verifier({runtime::load_command_key(key_path_)});
  lcm::LogFile log(log_path(), "r");
  ASSERT_TRUE(log.good()) << log_path();
  std::vector<std::string> commands;
  std::vector<Row> poses;  // distinct poses in the order received
  int setpoints = 0;
  std::int64_t first_utime = 0, last_utime = 0;
  for (const lcm::LogEvent* e = log.readNextEvent(); e != nullptr; e = log.readNextEvent()) {
    if (e->channel == runtime::kCommandChannel) {
      if (commands.empty()) {
        EXPECT_EQ(setpoints, 0) << "the start comes before any setpoint";
      }
      const auto v = verifier.verify_encoded(e->data, e->datalen, e->timestamp);
      EXPECT_EQ(v.verdict, runtime::CommandVerdict::kAccepted) << v.reason;
      dualv_lcm::command_t cmd;
      ASSERT_EQ(cmd.decode(e->data, 0, e->datalen), e->datalen);
      commands.push_back(cmd.kind == dualv_lcm::command_t::KIND_START_PROGRAM
                             ? "start " + cmd.program
                         : cmd.kind == dualv_lcm::command_t::KIND_STOP ? "stop"
                                                                       : "other");
    } else if (e->channel == runtime::kSetpointChannel) {
      const auto v = verifier.verify_setpoint_encoded(e->data, e->datalen, e->timestamp);
      EXPECT_EQ(v.verdict, runtime::CommandVerdict::kAccepted) << v.reason;  // signed, in order
      dualv_lcm::setpoint_t sp;
      ASSERT_EQ(sp.decode(e->data, 0, e->datalen), e->datalen);
      if (setpoints++ == 0) first_utime = e->timestamp;
      last_utime = e->timestamp;
      if (poses.empty() || poses.back().x != sp.x || poses.back().y != sp.y ||
          poses.back().theta != sp.theta)
        poses.push_back({0.0, sp.x, sp.y, sp.theta});
    }
  }
  ASSERT_EQ(commands.size(), 2u);
  EXPECT_EQ(commands[0], "start stream");
  EXPECT_EQ(commands[1], "stop");
  // Every row, in the file's order, each held until the next; the last one is sent too.
  ASSERT_EQ(poses.size(), rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_DOUBLE_EQ(poses[i].x, rows[i].x) << "row " << i;
    EXPECT_DOUBLE_EQ(poses[i].y, rows[i].y) << "row " << i;
    EXPECT_DOUBLE_EQ(poses[i].theta, rows[i].theta) << "row " << i;
  }
  // For the file's length (1.5 s; rows 0.5 s apart, so a stalled machine cannot skip one)
  // at 200 setpoints/s: at most 301.
  EXPECT_LE(setpoints, 301);
  EXPECT_GE(last_utime - first_utime, 1450000);
}

// --duration shorter than the file: the stream ends there, its last setpoint the row in force
// at that time (rows 0 and 0.5 s of four; nothing of the rows at 1.0 and 1.5 s).
TEST_F(StreamCli, DurationShorterThanTheFileEndsTheStreamAtTheRowInForce) {
  const std::string csv =
      "t,x,y,theta\n0,0,0.25,0\n0.5,0.004,0.25,0\n1.0,0.008,0.25,0\n1.5,0.012,0.25,0\n";
  const Exit r = run(stream_args(write_csv(csv)) + " --duration 0.6");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  lcm::LogFile log(log_path(), "r");
  ASSERT_TRUE(log.good()) << log_path();
  std::vector<double> xs;  // distinct x in the order sent
  int stops = 0;
  for (const lcm::LogEvent* e = log.readNextEvent(); e != nullptr; e = log.readNextEvent()) {
    if (e->channel == runtime::kSetpointChannel) {
      dualv_lcm::setpoint_t sp;
      ASSERT_EQ(sp.decode(e->data, 0, e->datalen), e->datalen);
      if (xs.empty() || xs.back() != sp.x) xs.push_back(sp.x);
    } else if (e->channel == runtime::kCommandChannel) {
      dualv_lcm::command_t cmd;
      ASSERT_EQ(cmd.decode(e->data, 0, e->datalen), e->datalen);
      stops += cmd.kind == dualv_lcm::command_t::KIND_STOP;
    }
  }
  EXPECT_EQ(xs, (std::vector<double>{0.0, 0.004}));
  EXPECT_EQ(stops, 1);
}

TEST_F(StreamCli, RefusesABadFileBeforeSendingAnything) {
  const struct {
    const char* csv;
    const char* message;
  } cases[] = {
      {"0,0,0.25,0\n0.2,0,0.25,0\n0.1,0,0.25,0\n", "line 3: t must increase"},
      {"t,x,y,theta\n0,0,0.25,0\n0.1,0,abc,0\n", "line 3: expected t,x,y,theta"},
      {"t,x,y,theta\n", "no poses"},
  };
  for (const auto& c : cases) {
    fs::remove(log_path());
    const Exit r = run(stream_args(write_csv(c.csv)));
    EXPECT_NE(r.exit_code, 0) << c.csv;
    EXPECT_NE(r.output.find(c.message), std::string::npos) << r.output;
    // Not even the start: the log was never opened, or holds no message.
    if (fs::exists(log_path())) {
      lcm::LogFile log(log_path(), "r");
      EXPECT_EQ(log.readNextEvent(), nullptr) << c.csv;
    }
  }
  const Exit missing = run(stream_args((dir_ / "nowhere.csv").string()));
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.output.find("cannot open"), std::string::npos) << missing.output;
}

}  // namespace
