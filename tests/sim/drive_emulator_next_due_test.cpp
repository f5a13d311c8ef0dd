// DriveEmulator::next_due_ns (what lets `dualv sim` sleep until a frame or its next timer,
// apps/cmd_sim.cpp) checked against the truth of polling on a fine grid: the same scenario run
// twice, once polled every 100 us and once polled only when a frame is sent to it or when
// next_due_ns says, must put the same frames on the bus at the same times. The scenario makes
// every timer fire: heartbeat producer, consumer heartbeat loss, RPDO deadline, the statusword
// event TPDO and the plant's free run after the master went silent.
#include <gtest/gtest.h>

#include <utility>
#include <vector>

#include "tests/sim/emulator_fixture.hpp"

namespace dualv::sim {
namespace {

using test::kMs;
namespace od = fw::od;

struct Trace {
  std::vector<std::pair<std::uint64_t, fw::CanFrame>> frames;  // (bus time, frame)
  std::uint64_t polls = 0;
  std::uint64_t virtual_syncs = 0;
};

class NextDueTest : public test::EmulatorTest {
 protected:
  // Set-up and a few cycles (identical in both runs), then 300 ms of silence from the
  // master, polled on the 100 us grid or only at next_due_ns.
  Trace run(bool only_when_due) {
    build(default_config());
    to_operation_enabled();
    write(1, od::pdo_event_timer(od::PdoDirection::kRpdo, 1), 10);  // RPDO deadline 10 ms
    write(2, od::kProducerHeartbeat, 20);                           // 20 ms heartbeats
    write(3, od::consumer_heartbeat(1), fw::consumer_heartbeat_value(127, 50));
    send(fw::encode_heartbeat(127, fw::NmtState::kOperational));
    now();
    for (int k = 0; k < 20; ++k) cycle(0x0F, static_cast<std::int16_t>(10 * k));
    Trace t;
    auto record = [&] {
      for (const fw::CanFrame& f : drain()) t.frames.emplace_back(f.timestamp_ns, f);
    };
    record();
    const std::uint64_t start = hub->now_ns();
    const std::uint64_t end = start + 300 * kMs;
    if (!only_when_due) {
      for (std::uint64_t at_ns = start; at_ns <= end; at_ns += kMs / 10) {
        at(at_ns);
        ++t.polls;
        record();
      }
    } else {
      std::uint64_t at_ns = start;
      at(at_ns);
      ++t.polls;
      record();
      for (;;) {
        const std::uint64_t due = emu->next_due_ns(at_ns);
        if (due > end) break;
        if (due == at_ns) {
          ADD_FAILURE() << "next_due_ns(" << at_ns << ") is the time just polled: on_time left "
                        << "something due (the caller would spin)";
          break;
        }
        at_ns = due;
        at(at_ns);
        ++t.polls;
        record();
      }
      at(end);
      record();
    }
    t.virtual_syncs = emu->virtual_syncs();
    return t;
  }
};

std::size_t count_id(const Trace& t, std::uint32_t id, std::uint8_t byte0 = 0, bool any = true) {
  std::size_t n = 0;
  for (const auto& [time, f] : t.frames)
    if (f.id == id && (any || f.data[0] == byte0)) ++n;
  return n;
}

TEST_F(NextDueTest, PollingOnlyWhenDuePutsTheSameFramesOnTheBusAtTheSameTimes) {
  const Trace fine = run(false);
  const Trace due = run(true);
  // The scenario exercises the timers (else the comparison would prove nothing).
  EXPECT_GE(count_id(fine, 0x702), 14u) << "drive 2's 20 ms heartbeats over 300 ms";
  EXPECT_EQ(count_id(fine, 0x081, 0x50, false), 1u) << "drive 1: EMCY 8250h (RPDO deadline)";
  EXPECT_EQ(count_id(fine, 0x083, 0x30, false), 1u) << "drive 3: EMCY 8130h (heartbeat lost)";
  EXPECT_GT(fine.virtual_syncs, 100u) << "the plant free-runs once SYNCs stopped";

  ASSERT_EQ(due.frames.size(), fine.frames.size());
  for (std::size_t k = 0; k < fine.frames.size(); ++k) {
    EXPECT_EQ(due.frames[k].first, fine.frames[k].first) << "frame " << k << " time";
    EXPECT_EQ(due.frames[k].second, fine.frames[k].second) << "frame " << k;
  }
  EXPECT_EQ(due.virtual_syncs, fine.virtual_syncs);
  // And it is what makes the emulator cheap: far fewer wake-ups than the fine grid.
  EXPECT_LT(due.polls * 5, fine.polls) << due.polls << " polls against " << fine.polls;
}

TEST_F(NextDueTest, NothingScheduledBeforePowerOnMeansPollNow) {
  EXPECT_EQ(emu->next_due_ns(123), 123u) << "the drives power on at the first poll";
  at(0);
  EXPECT_GT(emu->next_due_ns(0), 0u) << "after the boot-up nothing is due at once";
}

}  // namespace
}  // namespace dualv::sim
