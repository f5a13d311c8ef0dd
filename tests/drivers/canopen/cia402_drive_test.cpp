// Cia402Drive: the walk to Operation enabled from every state, fault reset on a rising
// edge of bit 7, quick stop, disable, per-transition timeouts at T - 1 / T, stops the drive
// made on its own, no torque unless Operation enabled.
#include "drivers/cia402_drive.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace dualv::drivers {
namespace {

using fw::Cia402State;
using S = Cia402State;
constexpr std::uint64_t kMs = 1'000'000;
constexpr std::uint64_t kTimeout = 500 * kMs;

// The drive side of CiA 402-2 figure 22, as a drive reads a controlword (fw tables only).
S drive_reacts(S s, std::uint16_t cw, std::uint16_t previous_cw) {
  if (s == S::kFault) {
    const bool rising = (cw & fw::cw::kFaultReset) && !(previous_cw & fw::cw::kFaultReset);
    return rising ? S::kSwitchOnDisabled : s;
  }
  if (s == S::kNotReadyToSwitchOn) return S::kSwitchOnDisabled;  // transition 1
  if (s == S::kFaultReactionActive) return S::kFault;            // transition 14
  const fw::Command c = fw::decode_command(cw);
  for (const fw::Transition& t : fw::kTransitions) {
    if (t.from != s || !t.command || t.number == 16) continue;
    if (*t.command == c ||
        (c == fw::Command::kSwitchOn && *t.command == fw::Command::kDisableOperation))
      return t.to;
  }
  return s;
}

struct Loop {
  Cia402Drive drive{kTimeout};
  S state = S::kSwitchOnDisabled;
  std::uint16_t last_cw = 0;
  std::uint64_t now = 0;
  std::vector<std::uint8_t> transitions;
  std::vector<bool> torque;
  // One cycle: statusword in, request, controlword out, the drive reacts.
  Cia402Output cycle(DriveRequest r, bool drive_moves = true) {
    drive.on_statusword(fw::statusword_bits(state), now);
    const Cia402Output out = drive.update(r, now);
    if (drive.last_transition() != 0) transitions.push_back(drive.last_transition());
    torque.push_back(out.torque_allowed);
    if (drive_moves) state = drive_reacts(state, out.controlword, last_cw);
    last_cw = out.controlword;
    now += kMs;
    return out;
  }
};

struct WalkCase {
  S from;
  std::vector<std::uint8_t> transitions;
};

TEST(Cia402Drive, WalksToOperationEnabledFromEveryState) {
  const std::vector<WalkCase> cases = {
      {S::kNotReadyToSwitchOn, {2, 3, 4}},
      {S::kSwitchOnDisabled, {2, 3, 4}},
      {S::kReadyToSwitchOn, {3, 4}},
      {S::kSwitchedOn, {4}},
      {S::kOperationEnabled, {}},
      {S::kQuickStopActive, {12, 2, 3, 4}},  // never 16: a stale target is never applied
  };
  for (const WalkCase& c : cases) {
    Loop l;
    l.state = c.from;
    l.drive.on_statusword(fw::statusword_bits(c.from), 0);
    for (int i = 0; i < 8; ++i) l.cycle(DriveRequest::kEnable);
    EXPECT_EQ(l.state, S::kOperationEnabled) << fw::to_string(c.from);
    EXPECT_EQ(l.transitions, c.transitions) << fw::to_string(c.from);
    EXPECT_EQ(l.drive.own_stops(), 0u) << fw::to_string(c.from);
  }
}

TEST(Cia402Drive, FromFaultOnlyAfterExplicitResetOnARisingEdge) {
  Loop l;
  l.state = S::kFault;
  l.last_cw = fw::cw::kFaultReset;  // a stale bit 7 high from before: no edge yet
  for (int i = 0; i < 5; ++i) l.cycle(DriveRequest::kEnable);
  EXPECT_EQ(l.state, S::kFault);  // kEnable never resets a fault
  EXPECT_EQ(l.drive.goal(), Cia402Goal::kNone);
  l.cycle(DriveRequest::kFaultReset);  // bit 7 low
  EXPECT_EQ(l.last_cw & fw::cw::kFaultReset, 0);
  EXPECT_EQ(l.state, S::kFault);
  l.cycle(DriveRequest::kFaultReset);  // bit 7 high: rising edge, transition 15
  EXPECT_NE(l.last_cw & fw::cw::kFaultReset, 0);
  EXPECT_EQ(l.state, S::kSwitchOnDisabled);
  ASSERT_FALSE(l.transitions.empty());
  EXPECT_EQ(l.transitions.back(), 15);
  EXPECT_EQ(l.drive.fault_resets(), 1u);
  for (int i = 0; i < 5; ++i) l.cycle(DriveRequest::kHold);
  EXPECT_EQ(l.state, S::kSwitchOnDisabled);       // a reset never restarts motion by itself
  EXPECT_EQ(l.last_cw & fw::cw::kFaultReset, 0);  // bit 7 back low
  for (int i = 0; i < 5; ++i) l.cycle(DriveRequest::kEnable);
  EXPECT_EQ(l.state, S::kOperationEnabled);
}

// Issue 12 point 5: the drive refused the first edge (its fault's cause remained); a new
// kFaultReset request, before the transition timeout, must give it a new rising edge.
TEST(Cia402Drive, NewFaultResetRequestGivesANewRisingEdge) {
  Cia402Drive d{kTimeout};
  d.on_statusword(fw::statusword_bits(S::kFault), 0);
  std::vector<std::uint16_t> cw;
  auto step = [&](DriveRequest r, std::uint64_t t) {
    d.on_statusword(fw::statusword_bits(S::kFault), t);  // the drive stays in Fault
    cw.push_back(d.update(r, t).controlword & fw::cw::kFaultReset);
  };
  step(DriveRequest::kFaultReset, 1 * kMs);  // low
  step(DriveRequest::kFaultReset, 2 * kMs);  // high: refused by the drive
  step(DriveRequest::kHold, 3 * kMs);        // still high (reset in progress)
  step(DriveRequest::kFaultReset, 4 * kMs);  // new request: low again ...
  step(DriveRequest::kFaultReset, 5 * kMs);  // ... then high: a new rising edge
  EXPECT_EQ(cw, (std::vector<std::uint16_t>{0, fw::cw::kFaultReset, fw::cw::kFaultReset, 0,
                                            fw::cw::kFaultReset}));
  EXPECT_EQ(d.fault_resets(), 2u);
  EXPECT_FALSE(d.transition_timed_out());
}

TEST(Cia402Drive, FaultResetTimesOutAtExactlyT) {
  Loop l;
  l.state = S::kFault;
  l.drive.on_statusword(fw::statusword_bits(S::kFault), 0);
  // The drive refuses to leave Fault (cause still present).
  l.drive.update(DriveRequest::kFaultReset, 0);        // bit 7 low
  l.drive.update(DriveRequest::kFaultReset, 1 * kMs);  // bit 7 high, timer starts here
  l.drive.update(DriveRequest::kFaultReset, 1 * kMs + kTimeout - 1);
  EXPECT_FALSE(l.drive.transition_timed_out());
  EXPECT_TRUE(l.drive.fault_reset_in_progress());
  const Cia402Output out = l.drive.update(DriveRequest::kFaultReset, 1 * kMs + kTimeout);
  EXPECT_TRUE(l.drive.transition_timed_out());
  EXPECT_EQ(out.controlword & fw::cw::kFaultReset, 0);
  EXPECT_EQ(l.drive.transition_timeouts(), 1u);
}

TEST(Cia402Drive, TransitionTimeoutAtExactlyT) {
  Cia402Drive d(kTimeout);
  d.on_statusword(fw::statusword_bits(S::kSwitchOnDisabled), 0);
  d.update(DriveRequest::kEnable, 10 * kMs);  // walk starts: shutdown (2)
  EXPECT_EQ(d.last_transition(), 2);
  d.on_statusword(fw::statusword_bits(S::kSwitchOnDisabled), 10 * kMs + kTimeout - 1);
  d.update(DriveRequest::kEnable, 10 * kMs + kTimeout - 1);
  EXPECT_FALSE(d.transition_timed_out());
  const Cia402Output out = d.update(DriveRequest::kEnable, 10 * kMs + kTimeout);
  EXPECT_TRUE(d.transition_timed_out());
  EXPECT_EQ(out.controlword, fw::apply(fw::Command::kDisableVoltage, 0));
  EXPECT_FALSE(out.torque_allowed);
  // kEnable held: nothing is retried (edge semantics).
  d.update(DriveRequest::kEnable, 20 * kMs + kTimeout);
  EXPECT_EQ(d.goal(), Cia402Goal::kNone);
  // A new kEnable retries.
  d.update(DriveRequest::kHold, 21 * kMs + kTimeout);
  d.update(DriveRequest::kEnable, 22 * kMs + kTimeout);
  EXPECT_EQ(d.goal(), Cia402Goal::kOperationEnabled);
  EXPECT_FALSE(d.transition_timed_out());
}

TEST(Cia402Drive, TimerRestartsWithEveryStep) {
  // Each transition has its own timeout: a slow but progressing walk never times out.
  Loop l;
  l.drive.on_statusword(fw::statusword_bits(S::kSwitchOnDisabled), 0);
  for (int step = 0; step < 3; ++step) {
    l.drive.update(DriveRequest::kEnable, l.now);
    l.now += kTimeout - 1;
    l.drive.update(DriveRequest::kEnable, l.now);
    EXPECT_FALSE(l.drive.transition_timed_out());
    l.state = drive_reacts(l.state, l.drive.controlword(), l.last_cw);
    l.last_cw = l.drive.controlword();
    l.drive.on_statusword(fw::statusword_bits(l.state), l.now);
  }
  EXPECT_EQ(l.state, S::kOperationEnabled);
}

TEST(Cia402Drive, TorqueOnlyInOperationEnabled) {
  Loop l;
  for (int i = 0; i < 6; ++i) l.cycle(DriveRequest::kEnable);
  // Cycles 0..2 walk (2, 3, 4); the controlword of cycle 2 enables; cycle 3 sees the
  // Operation enabled statusword: torque from there, never before.
  EXPECT_EQ(l.torque, (std::vector<bool>{false, false, false, true, true, true}));
}

TEST(Cia402Drive, QuickStopAndReEnable) {
  Loop l;
  for (int i = 0; i < 5; ++i) l.cycle(DriveRequest::kEnable);
  ASSERT_EQ(l.state, S::kOperationEnabled);
  const Cia402Output out = l.cycle(DriveRequest::kQuickStop);
  EXPECT_EQ(out.controlword & 0x0006, 0x0002);  // quick stop: 0xxx x01x
  EXPECT_FALSE(out.torque_allowed);
  ASSERT_FALSE(l.transitions.empty());
  EXPECT_EQ(l.transitions.back(), 11);
  EXPECT_EQ(l.state, S::kQuickStopActive);
  for (int i = 0; i < 3; ++i) l.cycle(DriveRequest::kQuickStop);
  EXPECT_EQ(l.state, S::kQuickStopActive);
  EXPECT_EQ(l.drive.own_stops(), 0u);  // asked for: not an own stop
  l.transitions.clear();
  for (int i = 0; i < 6; ++i) l.cycle(DriveRequest::kEnable);
  EXPECT_EQ(l.transitions, (std::vector<std::uint8_t>{12, 2, 3, 4}));
  EXPECT_EQ(l.state, S::kOperationEnabled);
}

TEST(Cia402Drive, DisableTakesTorqueOffAtOnce) {
  Loop l;
  for (int i = 0; i < 5; ++i) l.cycle(DriveRequest::kEnable);
  const Cia402Output out = l.cycle(DriveRequest::kDisable);
  EXPECT_EQ(out.controlword & 0x0002, 0);  // disable voltage: 0xxx xx0x
  EXPECT_FALSE(out.torque_allowed);
  ASSERT_FALSE(l.transitions.empty());
  EXPECT_EQ(l.transitions.back(), 9);
  EXPECT_EQ(l.state, S::kSwitchOnDisabled);
  for (int i = 0; i < 3; ++i) l.cycle(DriveRequest::kDisable);
  EXPECT_EQ(l.drive.transition_timeouts(), 0u);
}

TEST(Cia402Drive, OwnQuickStopReportedAndNeverUndoneByItself) {
  Loop l;
  for (int i = 0; i < 5; ++i) l.cycle(DriveRequest::kEnable);
  l.state = S::kQuickStopActive;  // e.g. 6007h: the drive lost the master's heartbeat
  for (int i = 0; i < 5; ++i) l.cycle(DriveRequest::kEnable);  // enable held: no retry
  EXPECT_EQ(l.drive.own_stop(), StopCause::kQuickStop);
  EXPECT_EQ(l.drive.own_stops(), 1u);
  EXPECT_EQ(l.state, S::kSwitchOnDisabled);  // held disabled (12), not re-enabled
  EXPECT_FALSE(l.torque.back());
  l.cycle(DriveRequest::kHold);
  for (int i = 0; i < 6; ++i) l.cycle(DriveRequest::kEnable);  // a new request
  EXPECT_EQ(l.state, S::kOperationEnabled);
  EXPECT_EQ(l.drive.own_stop(), StopCause::kNone);
}

TEST(Cia402Drive, OwnFaultAndOwnDisableReported) {
  Loop l;
  for (int i = 0; i < 5; ++i) l.cycle(DriveRequest::kEnable);
  l.state = S::kFault;
  l.cycle(DriveRequest::kHold);
  EXPECT_EQ(l.drive.own_stop(), StopCause::kFault);
  EXPECT_EQ(l.drive.drive_state(), DriveState::kFault);

  Loop m;
  for (int i = 0; i < 5; ++i) m.cycle(DriveRequest::kEnable);
  m.state = S::kSwitchOnDisabled;  // e.g. STO input
  m.cycle(DriveRequest::kHold);
  EXPECT_EQ(m.drive.own_stop(), StopCause::kDisabled);
  for (int i = 0; i < 5; ++i) m.cycle(DriveRequest::kHold);
  EXPECT_EQ(m.state, S::kSwitchOnDisabled);
}

TEST(Cia402Drive, LostDriveNeedsANewEnable) {
  Loop l;
  for (int i = 0; i < 5; ++i) l.cycle(DriveRequest::kEnable);
  l.drive.on_lost();
  EXPECT_EQ(l.drive.own_stop(), StopCause::kLost);
  EXPECT_EQ(l.drive.drive_state(), DriveState::kOffline);
  const Cia402Output out = l.drive.update(DriveRequest::kHold, l.now);
  EXPECT_FALSE(out.torque_allowed);
  EXPECT_EQ(out.controlword, 0);
  // It comes back still enabled (a short outage): the host disables it, no torque.
  for (int i = 0; i < 3; ++i) l.cycle(DriveRequest::kHold);
  EXPECT_EQ(l.state, S::kSwitchOnDisabled);
  EXPECT_FALSE(l.torque.back());
}

TEST(Cia402Drive, BadStatuswordIgnored) {
  Cia402Drive d;
  d.on_statusword(0x000B, 0);  // bits 0, 1, 3 without 2 and 6: no state of table 30
  EXPECT_EQ(d.bad_statuswords(), 1u);
}

}  // namespace
}  // namespace dualv::drivers
