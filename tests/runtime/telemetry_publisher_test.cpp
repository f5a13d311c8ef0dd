#include "runtime/telemetry_publisher.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <vector>

#include "dualv_lcm/fault_event_t.hpp"
#include "dualv_lcm/loop_stats_t.hpp"
#include "dualv_lcm/robot_state_t.hpp"
#include "runtime/channels.hpp"

namespace dualv::runtime {
namespace {

StateSample make_state(std::int64_t cycle) {
  StateSample s;
  s.utime = 1'700'000'000'000'000 + cycle * 1000;
  s.cycle = cycle;
  s.t = static_cast<double>(cycle) * 1e-3;
  s.n = 4;
  for (int i = 0; i < 4; ++i) {
    s.q[i] = 0.1 * i + static_cast<double>(cycle);
    s.q_dot[i] = -0.5 * i;
    s.tau_cmd[i] = 1.5 * i;
    s.tau_internal[i] = 0.01 * i;
  }
  s.X = {0.01, 0.25, 0.0};
  s.X_d = {0.011, 0.25, 0.001};
  s.tracking_error = {0.001, 0.0, 0.001};
  s.lambda = 0.5;
  s.segment = 2;
  s.safety_state = dualv_lcm::robot_state_t::SAFETY_OPERATIONAL;
  copy_text(s.safety_text, "operational");
  s.status_flags = dualv_lcm::robot_state_t::FLAG_SIMULATED;
  s.stream_target = {0.012, 0.251, -0.002};
  s.stream_age = 0.004;
  s.stream_accepted = 123;
  s.stream_refused = 2;
  return s;
}

// Collects decoded messages published on a memq:// LCM instance. Subscribes
// through LCM's C API, as the runtime does (command_channel.hpp explains why).
struct Collector {
  std::vector<dualv_lcm::robot_state_t> states;
  std::vector<dualv_lcm::fault_event_t> faults;
  std::vector<dualv_lcm::loop_stats_t> stats;
  std::vector<std::string> order;
  int undecodable = 0;

  void add(const dualv_lcm::robot_state_t& m) { states.push_back(m); }
  void add(const dualv_lcm::fault_event_t& m) { faults.push_back(m); }
  void add(const dualv_lcm::loop_stats_t& m) { stats.push_back(m); }

  template <typename Msg>
  static void on_raw(const lcm_recv_buf_t* rb, const char* channel, void* user) {
    auto* self = static_cast<Collector*>(user);
    Msg m;
    if (m.decode(rb->data, 0, static_cast<int>(rb->data_size)) != static_cast<int>(rb->data_size)) {
      ++self->undecodable;
      return;
    }
    self->add(m);
    self->order.push_back(channel);
  }
  void subscribe(lcm::LCM& l) {
    lcm_t* c = l.getUnderlyingLCM();
    lcm_subscribe(c, kStateChannel, &Collector::on_raw<dualv_lcm::robot_state_t>, this);
    lcm_subscribe(c, kFaultChannel, &Collector::on_raw<dualv_lcm::fault_event_t>, this);
    lcm_subscribe(c, kLoopStatsChannel, &Collector::on_raw<dualv_lcm::loop_stats_t>, this);
  }
};

void handle_all(lcm::LCM& l) {
  while (l.handleTimeout(0) > 0) {
  }
}

TEST(TelemetryPublisher, PublishesStateFaultAndStatsOnMemq) {
  lcm::LCM l("memq://");
  ASSERT_TRUE(l.good());
  Collector c;
  c.subscribe(l);
  TelemetryPublisher pub(l);

  ASSERT_TRUE(pub.push_state(make_state(7)));
  FaultSample f;
  f.cycle = 8;
  copy_text(f.cause, "heartbeat lost node 3");
  copy_text(f.reaction, "STO");
  f.node = 3;
  f.detection_latency_cycles = 100;
  f.n = 4;
  f.tau_at_detection = {1, 2, 3, 4};
  copy_text(f.text, "no heartbeat for 100 ms");
  ASSERT_TRUE(pub.push_fault(f));
  LoopStatsSample ls;
  ls.stats.period_ns = 1'000'000;
  ls.stats.cycles = 1000;
  ls.stats.cycle.p999_ns = 123'000;
  ls.stats.deadline_misses = 2;
  ls.realtime = true;
  ASSERT_TRUE(pub.push_loop_stats(ls));

  EXPECT_EQ(pub.drain(), 3u);
  handle_all(l);

  ASSERT_EQ(c.states.size(), 1u);
  const auto& s = c.states[0];
  EXPECT_EQ(s.cycle, 7);
  EXPECT_EQ(s.n, 4);
  ASSERT_EQ(s.q.size(), 4u);
  EXPECT_DOUBLE_EQ(s.q[3], 7.3);
  EXPECT_DOUBLE_EQ(s.tau_cmd[2], 3.0);
  EXPECT_DOUBLE_EQ(s.X_d[2], 0.001);
  EXPECT_EQ(s.segment, 2);
  EXPECT_EQ(s.safety_text, "operational");
  EXPECT_EQ(s.status_flags, dualv_lcm::robot_state_t::FLAG_SIMULATED);
  EXPECT_DOUBLE_EQ(s.stream_target[1], 0.251);
  EXPECT_DOUBLE_EQ(s.stream_age, 0.004);
  EXPECT_EQ(s.stream_accepted, 123);
  EXPECT_EQ(s.stream_refused, 2);
  EXPECT_EQ(s.utime, 1'700'000'000'007'000);

  ASSERT_EQ(c.faults.size(), 1u);
  EXPECT_EQ(c.faults[0].cause, "heartbeat lost node 3");
  EXPECT_EQ(c.faults[0].reaction, "STO");
  EXPECT_EQ(c.faults[0].node, 3);
  EXPECT_EQ(c.faults[0].detection_latency_cycles, 100);
  EXPECT_EQ(c.faults[0].tau_at_detection, (std::vector<double>{1, 2, 3, 4}));
  EXPECT_GT(c.faults[0].utime, 0);  // stamped by the publisher

  ASSERT_EQ(c.stats.size(), 1u);
  EXPECT_EQ(c.stats[0].cycle_p999_ns, 123'000);
  EXPECT_EQ(c.stats[0].deadline_misses, 2);
  EXPECT_TRUE(c.stats[0].realtime);
  // Events are published before the states queued around them.
  EXPECT_EQ(c.order.front(), kFaultChannel);

  const auto n = pub.counters();
  EXPECT_EQ(n.states, 1u);
  EXPECT_EQ(n.faults, 1u);
  EXPECT_EQ(n.loop_stats, 1u);
  EXPECT_EQ(n.publish_errors, 0u);
}

TEST(TelemetryPublisher, FullQueueDropsAndFlagsTheLoss) {
  lcm::LCM l("memq://");
  Collector c;
  c.subscribe(l);
  TelemetryPublisher pub(l);
  std::size_t accepted = 0;
  for (std::size_t i = 0; i < TelemetryPublisher::kStateQueue + 10; ++i)
    accepted += pub.push_state(make_state(static_cast<std::int64_t>(i))) ? 1 : 0;
  EXPECT_EQ(accepted, TelemetryPublisher::kStateQueue);
  EXPECT_EQ(pub.dropped(), 10u);
  EXPECT_EQ(pub.counters().states_dropped, 10u);
  pub.drain();
  handle_all(l);
  ASSERT_EQ(c.states.size(), TelemetryPublisher::kStateQueue);
  EXPECT_EQ(c.states.back().cycle, static_cast<std::int64_t>(TelemetryPublisher::kStateQueue) - 1);
  EXPECT_NE(c.states.back().status_flags & dualv_lcm::robot_state_t::FLAG_TELEMETRY_DROPPED, 0);
}

TEST(TelemetryPublisher, DecimationPublishesEveryKthState) {
  lcm::LCM l("memq://");
  Collector c;
  c.subscribe(l);
  TelemetryPublisher pub(l, 10);
  for (int i = 0; i < 35; ++i) pub.push_state(make_state(i));
  pub.drain();
  handle_all(l);
  ASSERT_EQ(c.states.size(), 4u);
  EXPECT_EQ(c.states[3].cycle, 30);
  EXPECT_THROW(TelemetryPublisher(l, 0), std::invalid_argument);
}

TEST(TelemetryPublisher, ClampsJointCountToTheSampleCapacity) {
  lcm::LCM l("memq://");
  Collector c;
  c.subscribe(l);
  TelemetryPublisher pub(l);
  StateSample s = make_state(1);
  s.n = 100;  // corrupt count must not read past the arrays
  pub.push_state(s);
  pub.drain();
  handle_all(l);
  ASSERT_EQ(c.states.size(), 1u);
  EXPECT_EQ(c.states[0].n, kMaxJoints);
}

class TempDir : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/dualv-runtime-test.XXXXXX";
    ASSERT_NE(mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::filesystem::path dir_;
};

using TelemetryLog = TempDir;

// The log is LCM's own event-log format (written by LCM's file provider), read
// back here with lcm::LogFile exactly as lcm-logplayer reads it.
TEST_F(TelemetryLog, ThreadWritesAnLcmLogThatLogFileReadsBack) {
  const std::string path = (dir_ / "run.lcmlog").string();
  {
    TelemetryPublisher pub(log_url(path));
    pub.start(1);
    for (int i = 0; i < 200; ++i) pub.push_state(make_state(i));
    FaultSample f;
    copy_text(f.cause, "tracking error");
    pub.push_fault(f);
    LoopStatsSample ls;
    ls.stats.cycles = 200;
    pub.push_loop_stats(ls);
    pub.stop();  // drains what is left
    EXPECT_EQ(pub.counters().states, 200u);
  }
  lcm::LogFile log(path, "r");
  ASSERT_TRUE(log.good());
  int states = 0, faults = 0, stats = 0;
  std::int64_t last_cycle = -1;
  bool in_order = true;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    if (ev->channel == kStateChannel) {
      dualv_lcm::robot_state_t m;
      ASSERT_EQ(m.decode(ev->data, 0, ev->datalen), ev->datalen);
      if (m.cycle != last_cycle + 1) in_order = false;
      last_cycle = m.cycle;
      ++states;
    } else if (ev->channel == kFaultChannel) {
      dualv_lcm::fault_event_t m;
      ASSERT_EQ(m.decode(ev->data, 0, ev->datalen), ev->datalen);
      EXPECT_EQ(m.cause, "tracking error");
      ++faults;
    } else if (ev->channel == kLoopStatsChannel) {
      dualv_lcm::loop_stats_t m;
      ASSERT_EQ(m.decode(ev->data, 0, ev->datalen), ev->datalen);
      EXPECT_EQ(m.cycles, 200);
      ++stats;
    }
    EXPECT_GT(ev->timestamp, 0);
  }
  EXPECT_EQ(states, 200);
  EXPECT_EQ(faults, 1);
  EXPECT_EQ(stats, 1);
  EXPECT_TRUE(in_order);
}

TEST_F(TelemetryLog, UnwritableLogPathIsAClearError) {
  try {
    TelemetryPublisher pub(log_url((dir_ / "no-such-dir" / "run.lcmlog").string()));
    FAIL() << "opening a log in a missing directory must throw";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot open LCM URL"), std::string::npos) << e.what();
  }
}

TEST(TelemetryLogNames, DefaultNamesAndUrls) {
  EXPECT_EQ(log_url("/var/log/dualv/a.lcmlog"), "file:///var/log/dualv/a.lcmlog?mode=w");
  const std::string p = default_log_path("/tmp");
  EXPECT_EQ(p.rfind("/tmp/dualv-", 0), 0u) << p;
  EXPECT_EQ(p.substr(p.size() - 7), ".lcmlog");
}

}  // namespace
}  // namespace dualv::runtime
