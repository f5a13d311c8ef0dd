// Streaming mode in closed loop against the simulated Dual-V, in-process: signed setpoints go
// through LCM (memq://), the command channel's verification and queue, the RT loop, the
// streaming reference, the controller and the safety filter, exactly as in `dualv run --serve`.
// The test publishes in simulated time (RunOptions::before_cycle), so every cycle number is
// known: the watchdog must fire exactly `command_stream_timeout` after the last setpoint.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "apps/experiment/closed_loop.hpp"
#include "dualv_lcm/robot_state_t.hpp"
#include "runtime/channels.hpp"
#include "runtime/command_auth.hpp"
#include "runtime/command_channel.hpp"
#include "runtime/telemetry_publisher.hpp"

namespace dualv::apps {
namespace {

const std::string kConfig = std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml";
constexpr double kRadius = 0.02;     // [m]
constexpr double kCirclePeriod = 4;  // [s]: 31 mm/s, well inside the streaming limits
constexpr int kEvery = 10;           // a setpoint every 10 cycles: 100 Hz at 1 kHz

runtime::CommandKey lab_key() {
  runtime::CommandKey k;
  k.id = "lab";
  for (std::size_t i = 0; i < runtime::kKeyBytes; ++i)
    k.bytes[i] = static_cast<unsigned char>(7 * i + 3);
  return k;
}

model::Pose circle(const model::Pose& centre, double t) {
  const double a = 2 * M_PI * t / kCirclePeriod;
  return centre + model::Pose(kRadius * std::cos(a), kRadius * std::sin(a), 0.0);
}

struct FaultLine {
  std::int64_t cycle = -1;
  std::string event, cause, reaction;
};

std::vector<FaultLine> read_faults(const std::string& path) {
  std::vector<FaultLine> out;
  std::ifstream in(path);
  std::string line;
  auto field = [&](const std::string& name) {
    const std::string key = "\"" + name + "\":";
    const auto p = line.find(key);
    if (p == std::string::npos) return std::string();
    auto b = p + key.size();
    if (line[b] == '"') {
      ++b;
      return line.substr(b, line.find('"', b) - b);
    }
    return line.substr(b, line.find_first_of(",}", b) - b);
  };
  while (std::getline(in, line)) {
    FaultLine f;
    f.cycle = std::stoll(field("cycle"));
    f.event = field("event");
    f.cause = field("cause");
    f.reaction = field("reaction");
    out.push_back(f);
  }
  return out;
}

// One streaming run: publishes what `plan` says before each cycle, through memq:// LCM.
class StreamRun {
 public:
  // plan(cycle, rig) publishes whatever that cycle should see.
  using Plan = std::function<void(std::int64_t cycle, StreamRun& rig)>;

  explicit StreamRun(const std::string& name) {
    cfg_ = load_robot_config(kConfig);
    dir_ = std::filesystem::path(::testing::TempDir()) / ("dualv-stream-" + name);
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    channel_ = std::make_unique<runtime::CommandChannel>(lcm_, runtime::CommandVerifier({key_}),
                                                         [this] { return now_; });
    // Telemetry into an LCM log, drained on the loop's thread in simulated time (no sample
    // can be dropped by a publisher thread falling behind a faster-than-real-time run).
    telemetry_ =
        std::make_unique<runtime::TelemetryPublisher>("file://" + telemetry_path() + "?mode=w");
  }

  RunResult run(const Plan& plan, double settle_time = 1.0) {
    RunOptions o;
    o.commands = channel_.get();
    o.fault_log_path = faults_path();
    o.settle_time = settle_time;
    o.max_stream_time = 30.0;
    o.telemetry = telemetry_.get();
    o.before_cycle = [&](std::int64_t cycle) {
      now_ = kEpoch + cycle * 1000;  // the verifier's clock follows simulated time
      plan(cycle, *this);
      while (channel_->poll(0) > 0) {
      }
      telemetry_->drain();
    };
    RunResult r = run_stream_in_process(cfg_, o);
    telemetry_->drain();
    telemetry_.reset();  // closes (flushes) the log
    return r;
  }

  // The robot states the run published, read back from its LCM log.
  std::vector<dualv_lcm::robot_state_t> telemetry_states() const {
    std::vector<dualv_lcm::robot_state_t> out;
    lcm::LogFile log(telemetry_path(), "r");
    if (!log.good()) return out;
    for (const lcm::LogEvent* e = log.readNextEvent(); e != nullptr; e = log.readNextEvent()) {
      dualv_lcm::robot_state_t s;
      if (e->channel == runtime::kStateChannel && s.decode(e->data, 0, e->datalen) == e->datalen)
        out.push_back(s);
    }
    return out;
  }

  // A signed setpoint with the next sequence number.
  dualv_lcm::setpoint_t signed_setpoint(const model::Pose& p) {
    return runtime::make_setpoint(p[0], p[1], p[2], now_, ++sequence_, &key_);
  }
  void publish(const dualv_lcm::setpoint_t& sp) {
    ASSERT_EQ(lcm_.publish(runtime::kSetpointChannel, &sp), 0);
  }
  void publish_stop() {
    const auto c =
        runtime::make_command(runtime::CommandKind::kStop, "", now_, ++command_seq_, &key_);
    ASSERT_EQ(lcm_.publish(runtime::kCommandChannel, &c), 0);
  }

  std::string faults_path() const { return (dir_ / "faults.jsonl").string(); }
  std::string telemetry_path() const { return (dir_ / "telemetry.lcmlog").string(); }
  const RobotConfig& cfg() const { return cfg_; }
  const runtime::CommandChannel& channel() const { return *channel_; }
  std::int64_t now() const { return now_; }
  std::int64_t sequence() const { return sequence_; }
  const runtime::CommandKey& key() const { return key_; }

  static constexpr std::int64_t kEpoch = 1'750'000'000'000'000;
  dualv_lcm::setpoint_t last_good;  // the last good setpoint sent
  bool have_good = false;

 private:
  RobotConfig cfg_;
  std::filesystem::path dir_;
  lcm::LCM lcm_{"memq://"};
  runtime::CommandKey key_ = lab_key();
  std::int64_t now_ = kEpoch;
  std::int64_t sequence_ = 0;
  std::int64_t command_seq_ = 0;
  std::unique_ptr<runtime::CommandChannel> channel_;
  std::unique_ptr<runtime::TelemetryPublisher> telemetry_;
};

TEST(StreamClosedLoop, TracksAStreamedCircleThenTheWatchdogStopsItWhenTheStreamStops) {
  StreamRun rig("watchdog");
  const model::Pose centre = rig.cfg().model.home;
  const std::int64_t last_publish = 6000;  // 6 s of stream, then silence
  std::int64_t last_setpoint_cycle = -1;
  const RunResult r = rig.run([&](std::int64_t cycle, StreamRun& s) {
    if (cycle > last_publish || cycle % kEvery != 0) return;
    s.publish(s.signed_setpoint(circle(centre, static_cast<double>(cycle) * 1e-3)));
    last_setpoint_cycle = cycle;
  });
  ASSERT_TRUE(r.stream.streamed);
  EXPECT_EQ(r.stream.accepted, static_cast<std::uint64_t>(last_publish / kEvery + 1));
  EXPECT_EQ(r.stream.refused, 0u);

  // Stopped by the watchdog, exactly command_stream_timeout after the last setpoint.
  ASSERT_FALSE(r.ok);
  EXPECT_NE(r.failure.find("command stream stale"), std::string::npos) << r.failure;
  const double timeout = rig.cfg().safety.watchdogs.command_stream_timeout;
  const auto timeout_cycles = static_cast<std::int64_t>(std::llround(timeout / 1e-3));
  ASSERT_EQ(timeout_cycles, 100);  // config/dualv.yaml: 0.1 s at 1 kHz
  const std::vector<FaultLine> faults = read_faults(rig.faults_path());
  const auto first = std::find_if(faults.begin(), faults.end(),
                                  [](const FaultLine& f) { return f.event == "fault"; });
  ASSERT_NE(first, faults.end()) << "no fault in " << rig.faults_path();
  EXPECT_EQ(first->cause, "command stream stale");
  EXPECT_EQ(first->reaction, "SS1");
  // Fault-log cycles count from the loop's start; the plan's from the cycle that took the stream.
  ASSERT_GE(r.first_cycle, 0);
  EXPECT_EQ(first->cycle, r.first_cycle + last_setpoint_cycle + timeout_cycles);
  // Nothing else went wrong before it (no other fault events).
  for (const auto& f : faults)
    if (f.event == "fault") {
      EXPECT_EQ(f.cause, "command stream stale");
    }

  // Tracking while the stream ran: the plate follows X_d within 1 mm, X_d follows the
  // streamed circle within the reference's lag (about 3 / w * speed: 5 mm), and the whole
  // circle is covered.
  const double speed = 2 * M_PI * kRadius / kCirclePeriod;
  double worst_track = 0, worst_lag = 0, xmin = 1, xmax = -1, ymin = 1, ymax = -1;
  double worst_step = 0;
  for (std::size_t k = 0; k < r.rows.size(); ++k) {
    const Row& row = r.rows[k];
    if (k > 0)
      for (int i = 0; i < r.n; ++i)
        worst_step = std::max(worst_step, std::abs(row.tau[i] - r.rows[k - 1].tau[i]));
    if (row.t > last_publish * 1e-3) break;
    worst_track = std::max(worst_track, (row.X_d - row.X).head<2>().norm());
    if (row.t < 1.5) continue;  // the first setpoint is 20 mm from home: the move there
    worst_lag = std::max(worst_lag, (row.X_d - circle(centre, row.t)).head<2>().norm());
    xmin = std::min(xmin, row.X[0]);
    xmax = std::max(xmax, row.X[0]);
    ymin = std::min(ymin, row.X[1]);
    ymax = std::max(ymax, row.X[1]);
  }
  EXPECT_LT(worst_track, 1e-3);
  EXPECT_LT(worst_lag, 0.25 * speed + 1e-3);
  EXPECT_GT(xmax - xmin, 1.8 * kRadius);
  EXPECT_GT(ymax - ymin, 1.8 * kRadius);
  // The 20 mm jump of the first setpoint never became a torque step (the paper program's
  // retimed run: 0.6 N m; a reference step of 20 mm would ask kp * Jm * 20 mm, over 100 N m).
  EXPECT_LT(worst_step, 1.0);

  // Telemetry shows the stream: flagged while it runs, its watchdog clock back to zero with
  // every setpoint (so never above kEvery - 1 cycles) and, after the last one, counting up
  // by one cycle per cycle to the timeout; the last target is the last setpoint sent.
  using M = dualv_lcm::robot_state_t;
  const auto states = rig.telemetry_states();
  ASSERT_GT(states.size(), 6000u);
  std::vector<const M*> streaming;
  for (const M& s : states)
    if ((s.status_flags & M::FLAG_STREAMING) != 0) streaming.push_back(&s);
  ASSERT_GT(streaming.size(), 6000u);
  const std::size_t silent = timeout_cycles - 1;  // the samples after the last setpoint
  for (std::size_t k = 0; k + silent < streaming.size(); ++k)
    EXPECT_LE(streaming[k]->stream_age, (kEvery - 1) * 1e-3 + 1e-12)
        << "cycle " << streaming[k]->cycle;
  for (std::size_t k = streaming.size() - silent; k < streaming.size(); ++k)
    EXPECT_NEAR(streaming[k]->stream_age - streaming[k - 1]->stream_age, 1e-3, 1e-12)
        << "cycle " << streaming[k]->cycle;
  const M& last = *streaming.back();
  EXPECT_NEAR(last.stream_age, timeout - 1e-3, 1e-12);  // the next cycle's 0.1 s trips SS1
  const model::Pose sent = circle(centre, static_cast<double>(last_setpoint_cycle) * 1e-3);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(last.stream_target[k], sent[k], 1e-12);
  EXPECT_EQ(static_cast<std::uint64_t>(last.stream_accepted), r.stream.accepted);
  EXPECT_EQ(last.stream_refused, 0);
  // Then the stop itself is on telemetry too: SS1 right after the last streaming sample, no
  // longer flagged as streaming, until the torque is off.
  const auto after = std::find_if(states.begin(), states.end(),
                                  [&](const M& s) { return s.cycle == last.cycle + 1; });
  ASSERT_NE(after, states.end());
  EXPECT_EQ(after->safety_state, M::SAFETY_SS1);
  EXPECT_EQ(after->status_flags & M::FLAG_STREAMING, 0);
  EXPECT_EQ(states.back().safety_state, M::SAFETY_STO);
}

TEST(StreamClosedLoop, RefusedSetpointsNeverChangeXdAndASignedStopEndsTheStreamWithoutAFault) {
  const RobotConfig cfg = load_robot_config(kConfig);
  const model::Pose centre = cfg.model.home;
  const std::int64_t stop_at = 3000;
  // The same good stream twice; the second run also gets, around every good setpoint:
  // an unsigned one, a replay of the previous signed one, a signed one with an old sequence,
  // a signed one outside the workspace, a signed NaN, one signed with an unknown key.
  auto good = [&](std::int64_t cycle, StreamRun& s) {
    if (cycle >= stop_at) {
      if (cycle == stop_at) s.publish_stop();
      return;
    }
    if (cycle % kEvery == 0) {
      const auto sp = s.signed_setpoint(circle(centre, static_cast<double>(cycle) * 1e-3));
      s.publish(sp);
      s.last_good = sp;
      s.have_good = true;
    }
  };
  StreamRun clean("clean");
  const RunResult a = clean.run(good);

  StreamRun dirty("dirty");
  runtime::CommandKey intruder = lab_key();
  intruder.bytes[0] ^= 0xff;  // same id, another key: a bad signature
  runtime::CommandKey stranger = lab_key();
  stranger.id = "stranger";
  const model::Pose far = centre + model::Pose(0.05, -0.05, 0.2);  // inside: would move it
  const RunResult b = dirty.run([&](std::int64_t cycle, StreamRun& s) {
    if (cycle < stop_at && cycle % kEvery == 5) {
      s.publish(runtime::make_setpoint(far[0], far[1], far[2], s.now(), s.sequence() + 1, nullptr));
      if (s.have_good) s.publish(s.last_good);  // a replay, bytes unchanged
      s.publish(runtime::make_setpoint(far[0], far[1], far[2], s.now(), s.sequence() - 1,
                                       &s.key()));  // signed, old sequence
      s.publish(
          runtime::make_setpoint(far[0], far[1], far[2], s.now(), s.sequence() + 1, &intruder));
      s.publish(
          runtime::make_setpoint(far[0], far[1], far[2], s.now(), s.sequence() + 1, &stranger));
      s.publish(s.signed_setpoint(model::Pose(std::nan(""), centre[1], 0.0)));
      // Signed, fresh sequence, outside trajectory.limits.workspace: only the RT reference
      // can refuse it (the test sets no channel-side check).
      s.publish(s.signed_setpoint(centre + model::Pose(0.5, 0.0, 0.0)));
    }
    good(cycle, s);
  });

  for (const RunResult* r : {&a, &b}) {
    EXPECT_TRUE(r->ok) << r->failure;
    EXPECT_TRUE(r->stream.ended_by_stop);
  }
  // A normal end: no fault at all in either run.
  for (StreamRun* rig : {&clean, &dirty})
    for (const auto& f : read_faults(rig->faults_path()))
      EXPECT_NE(f.event, "fault") << f.cause << " at cycle " << f.cycle;
  // Refused setpoints never reached X_d: the two runs are identical bit for bit.
  ASSERT_EQ(a.rows.size(), b.rows.size());
  for (std::size_t k = 0; k < a.rows.size(); ++k)
    ASSERT_EQ(a.rows[k].X_d, b.rows[k].X_d) << "cycle " << k << " t " << a.rows[k].t;
  EXPECT_GT(b.stream.refused, 0u);  // the outside ones, refused in the loop
  const auto& v = dirty.channel().verifier();
  EXPECT_GT(v.setpoint_count(runtime::CommandVerdict::kUnsigned), 0u);
  EXPECT_GT(v.setpoint_count(runtime::CommandVerdict::kReplayed), 0u);
  EXPECT_GT(v.setpoint_count(runtime::CommandVerdict::kBadSignature), 0u);
  EXPECT_GT(v.setpoint_count(runtime::CommandVerdict::kUnknownKey), 0u);
  EXPECT_GT(v.setpoint_count(runtime::CommandVerdict::kMalformed), 0u);  // the NaN
  // The stop: X_d comes to rest and is held (settle_time 1 s after the stop).
  ASSERT_GT(a.rows.size(), 100u);
  const Row& last = a.rows.back();
  const Row& before = a.rows[a.rows.size() - 2];
  EXPECT_LT((last.X_d - before.X_d).norm(), 1e-3 * 1e-3);  // < 1 mm/s
  EXPECT_GT(last.t, stop_at * 1e-3);
}

}  // namespace
}  // namespace dualv::apps
