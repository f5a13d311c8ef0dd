#include "firmware_if/cia402.hpp"

#include <gtest/gtest.h>

#include <random>
#include <set>
#include <string>

namespace dualv::fw {
namespace {

using S = Cia402State;

// CiA 402-2 table 30, as printed (bit 15 left, x = don't care), kept apart from the header.
struct Row {
  S state;
  const char* pattern;
};
constexpr Row kTable30[] = {
    {S::kNotReadyToSwitchOn, "xxxxxxxxx0xx0000"},  {S::kSwitchOnDisabled, "xxxxxxxxx1xx0000"},
    {S::kReadyToSwitchOn, "xxxxxxxxx01x0001"},     {S::kSwitchedOn, "xxxxxxxxx01x0011"},
    {S::kOperationEnabled, "xxxxxxxxx01x0111"},    {S::kQuickStopActive, "xxxxxxxxx00x0111"},
    {S::kFaultReactionActive, "xxxxxxxxx0xx1111"}, {S::kFault, "xxxxxxxxx0xx1000"},
};
struct MaskValue {
  std::uint16_t mask = 0, value = 0;
};
MaskValue parse(const char* p) {
  MaskValue mv;
  for (int i = 0; i < 16; ++i) {
    const std::uint16_t bit = static_cast<std::uint16_t>(1u << (15 - i));
    if (p[i] == '0' || p[i] == '1') mv.mask |= bit;
    if (p[i] == '1') mv.value |= bit;
  }
  return mv;
}

TEST(Cia402, StatuswordEveryStateWithRandomDontCares) {
  std::mt19937 rng(402);
  for (const Row& r : kTable30) {
    const MaskValue mv = parse(r.pattern);
    for (int i = 0; i < 500; ++i) {
      const auto sw = static_cast<std::uint16_t>((rng() & ~mv.mask) | mv.value);
      const Result<Statusword> d = decode_statusword(sw);
      ASSERT_TRUE(d.ok()) << std::hex << sw;
      EXPECT_EQ(d->state, r.state) << std::hex << sw;
      EXPECT_EQ(d->voltage_enabled, (sw & 0x0010) != 0);
      EXPECT_EQ(d->warning, (sw & 0x0080) != 0);
      EXPECT_EQ(d->remote, (sw & 0x0200) != 0);
      EXPECT_EQ(d->target_reached, (sw & 0x0400) != 0);
      EXPECT_EQ(d->internal_limit_active, (sw & 0x0800) != 0);
    }
  }
}

TEST(Cia402, StatuswordExhaustive) {
  // Every 16-bit value: decoded state iff exactly one row of table 30 matches.
  for (std::uint32_t v = 0; v <= 0xFFFF; ++v) {
    const auto sw = static_cast<std::uint16_t>(v);
    int matches = 0;
    S match = S::kFault;
    for (const Row& r : kTable30) {
      const MaskValue mv = parse(r.pattern);
      if ((sw & mv.mask) == mv.value) {
        ++matches;
        match = r.state;
      }
    }
    ASSERT_LE(matches, 1) << std::hex << sw;
    const Result<Statusword> d = decode_statusword(sw);
    if (matches == 0) {
      EXPECT_EQ(d.error(), Error::kBadValue) << std::hex << sw;
    } else {
      ASSERT_TRUE(d.ok()) << std::hex << sw;
      EXPECT_EQ(d->state, match);
    }
  }
}

TEST(Cia402, StatuswordGoldenAndInvalid) {
  EXPECT_EQ(decode_statusword(0x0250)->state, S::kSwitchOnDisabled);  // 0x0250: remote + SOD
  EXPECT_EQ(decode_statusword(0x0231)->state, S::kReadyToSwitchOn);
  EXPECT_EQ(decode_statusword(0x0233)->state, S::kSwitchedOn);
  EXPECT_EQ(decode_statusword(0x1637)->state, S::kOperationEnabled);
  EXPECT_TRUE(decode_statusword(0x1637)->drive_follows_command);
  EXPECT_EQ(decode_statusword(0x0217)->state, S::kQuickStopActive);
  EXPECT_EQ(decode_statusword(0x021F)->state, S::kFaultReactionActive);
  EXPECT_EQ(decode_statusword(0x0218)->state, S::kFault);
  // No row: bit 5 clear with 0001 / 0011; bit 6 with a fault pattern; 0010 etc.
  for (const std::uint16_t bad : std::initializer_list<std::uint16_t>{
           0x0001, 0x0003, 0x0048, 0x0002, 0x0004, 0x0006, 0x0041, 0x0067}) {
    EXPECT_EQ(decode_statusword(bad).error(), Error::kBadValue) << std::hex << bad;
  }
  // The emulator's statusword for each state decodes back to that state.
  for (const Row& r : kTable30)
    EXPECT_EQ(decode_statusword(statusword_bits(r.state))->state, r.state);
}

TEST(Cia402, ControlwordCommandsGolden) {
  // CiA 402-2 table 29, with all don't-care bits 0.
  EXPECT_EQ(apply(Command::kShutdown), 0x0006);
  EXPECT_EQ(apply(Command::kSwitchOn), 0x0007);
  EXPECT_EQ(apply(Command::kEnableOperation), 0x000F);
  EXPECT_EQ(apply(Command::kDisableVoltage), 0x0000);
  EXPECT_EQ(apply(Command::kQuickStop), 0x0002);
  EXPECT_EQ(apply(Command::kDisableOperation), 0x0007);
  EXPECT_EQ(apply(Command::kFaultReset), 0x0080);
  // Halt (bit 8), manufacturer bits and the command's own don't-care bits survive; a stale
  // fault-reset bit is cleared.
  EXPECT_EQ(apply(Command::kEnableOperation, 0x0180), 0x010F);
  EXPECT_EQ(apply(Command::kShutdown, 0x800F), 0x800E);   // 0xxx x110: bit 3 kept
  EXPECT_EQ(apply(Command::kQuickStop, 0x000F), 0x000B);  // 0xxx x01x: bits 0, 3 kept
  EXPECT_EQ(apply(Command::kDisableVoltage, 0x000F), 0x000D);
}

TEST(Cia402, DecodeCommand) {
  EXPECT_EQ(decode_command(0x0006), Command::kShutdown);
  EXPECT_EQ(decode_command(0x0007), Command::kSwitchOn);
  EXPECT_EQ(decode_command(0x000F), Command::kEnableOperation);
  EXPECT_EQ(decode_command(0x0000), Command::kDisableVoltage);
  EXPECT_EQ(decode_command(0x000D), Command::kDisableVoltage);  // xx0x
  EXPECT_EQ(decode_command(0x0002), Command::kQuickStop);
  EXPECT_EQ(decode_command(0x000B), Command::kQuickStop);  // x01x
  EXPECT_EQ(decode_command(0x000E), Command::kShutdown);   // x110
}

// The drive side of figure 22, written from the standard for this test: the state a
// CiA 402 drive enters when it receives controlword `cw` in `s`.
S drive_reacts(S s, std::uint16_t cw, bool fault_reset_edge) {
  const bool ev = cw & 0x2, qs_off = cw & 0x4, so = cw & 0x1, eo = cw & 0x8;
  const bool disable_voltage = !ev;
  const bool quick_stop = ev && !qs_off;
  const bool shutdown = ev && qs_off && !so;
  const bool switch_on = ev && qs_off && so && !eo;
  const bool enable_op = ev && qs_off && so && eo;
  switch (s) {
    case S::kSwitchOnDisabled:
      return shutdown ? S::kReadyToSwitchOn : s;  // 2
    case S::kReadyToSwitchOn:
      if (switch_on || enable_op) return S::kSwitchedOn;               // 3
      if (disable_voltage || quick_stop) return S::kSwitchOnDisabled;  // 7
      return s;
    case S::kSwitchedOn:
      if (enable_op) return S::kOperationEnabled;                      // 4
      if (shutdown) return S::kReadyToSwitchOn;                        // 6
      if (disable_voltage || quick_stop) return S::kSwitchOnDisabled;  // 10
      return s;
    case S::kOperationEnabled:
      if (switch_on) return S::kSwitchedOn;              // 5
      if (shutdown) return S::kReadyToSwitchOn;          // 8
      if (disable_voltage) return S::kSwitchOnDisabled;  // 9
      if (quick_stop) return S::kQuickStopActive;        // 11
      return s;
    case S::kQuickStopActive:
      if (disable_voltage) return S::kSwitchOnDisabled;  // 12
      if (enable_op) return S::kOperationEnabled;        // 16
      return s;
    case S::kFault:
      return fault_reset_edge ? S::kSwitchOnDisabled : s;  // 15
    case S::kNotReadyToSwitchOn:
      return S::kSwitchOnDisabled;  // 1, automatic
    case S::kFaultReactionActive:
      return S::kFault;  // 14, automatic
  }
  return s;
}

constexpr S kAllStates[] = {
    S::kNotReadyToSwitchOn, S::kSwitchOnDisabled, S::kReadyToSwitchOn,     S::kSwitchedOn,
    S::kOperationEnabled,   S::kQuickStopActive,  S::kFaultReactionActive, S::kFault};

// Drives a simulated drive from `start` to `target` with next_transition(); returns the
// transition numbers taken (automatic ones as 100 + number).
std::vector<int> walk(S start, S target) {
  std::vector<int> taken;
  S s = start;
  std::uint16_t cw = 0;
  for (int step = 0; step < 10 && s != target; ++step) {
    const std::optional<Transition> t = next_transition(s, target);
    if (!t) {
      // Only the drive can move on: NRTSO -> SOD (1), FRA -> Fault (14).
      if (s == S::kNotReadyToSwitchOn)
        taken.push_back(101);
      else if (s == S::kFaultReactionActive)
        taken.push_back(114);
      else
        break;
      s = drive_reacts(s, cw, false);
      continue;
    }
    EXPECT_EQ(t->from, s);
    EXPECT_TRUE(t->command.has_value());
    const std::uint16_t next_cw = apply(*t->command, cw);
    const bool edge = !(cw & 0x80) && (next_cw & 0x80);
    s = drive_reacts(s, next_cw, edge);
    EXPECT_EQ(s, t->to) << "transition " << int(t->number);
    cw = static_cast<std::uint16_t>(next_cw & ~0x80);  // fault reset released afterwards
    taken.push_back(t->number);
  }
  EXPECT_EQ(s, target) << to_string(start) << " -> " << to_string(target);
  return taken;
}

TEST(Cia402, WalkEveryStateToOperationEnabled) {
  const std::vector<int> expected[] = {
      {101, 2, 3, 4},      // Not ready to switch on
      {2, 3, 4},           // Switch on disabled
      {3, 4},              // Ready to switch on
      {4},                 // Switched on
      {},                  // Operation enabled
      {12, 2, 3, 4},       // Quick stop active: never 16
      {114, 15, 2, 3, 4},  // Fault reaction active
      {15, 2, 3, 4},       // Fault
  };
  for (std::size_t i = 0; i < std::size(kAllStates); ++i) {
    EXPECT_EQ(walk(kAllStates[i], S::kOperationEnabled), expected[i]) << to_string(kAllStates[i]);
  }
}

TEST(Cia402, WalkEveryStateToEveryStopState) {
  for (S from : kAllStates) {
    walk(from, S::kSwitchOnDisabled);
    walk(from, S::kReadyToSwitchOn);
    walk(from, S::kSwitchedOn);
  }
  EXPECT_EQ(walk(S::kOperationEnabled, S::kSwitchOnDisabled), std::vector<int>{9});
  EXPECT_EQ(walk(S::kOperationEnabled, S::kReadyToSwitchOn), std::vector<int>{8});
  EXPECT_EQ(walk(S::kOperationEnabled, S::kSwitchedOn), std::vector<int>{5});
  EXPECT_EQ(walk(S::kOperationEnabled, S::kQuickStopActive), std::vector<int>{11});
  EXPECT_EQ(walk(S::kSwitchedOn, S::kSwitchOnDisabled), std::vector<int>{10});
  EXPECT_EQ(walk(S::kReadyToSwitchOn, S::kSwitchOnDisabled), std::vector<int>{7});
  EXPECT_EQ(walk(S::kSwitchedOn, S::kReadyToSwitchOn), std::vector<int>{6});
}

TEST(Cia402, NoTransitionWhereTheHostCannotAct) {
  for (S from : kAllStates) {
    EXPECT_FALSE(next_transition(from, from).has_value());
    EXPECT_FALSE(next_transition(from, S::kFault).has_value());
    EXPECT_FALSE(next_transition(from, S::kFaultReactionActive).has_value());
    EXPECT_FALSE(next_transition(from, S::kNotReadyToSwitchOn).has_value());
    if (from != S::kOperationEnabled) {
      EXPECT_FALSE(next_transition(from, S::kQuickStopActive).has_value()) << to_string(from);
    }
  }
}

TEST(Cia402, TransitionTableMatchesStandard) {
  // Transition number -> (command bits set, bits reset) per table 29.
  struct T {
    int n;
    std::uint16_t set, reset;
  };
  const T table[] = {{2, 0x06, 0x81},  {3, 0x07, 0x88},  {4, 0x0F, 0x80},  {5, 0x07, 0x88},
                     {6, 0x06, 0x81},  {7, 0x00, 0x82},  {8, 0x06, 0x81},  {9, 0x00, 0x82},
                     {10, 0x00, 0x82}, {11, 0x02, 0x84}, {12, 0x00, 0x82}, {15, 0x80, 0x00},
                     {16, 0x0F, 0x80}};
  for (const T& x : table) {
    const std::optional<Transition> t = find_transition(static_cast<std::uint8_t>(x.n));
    ASSERT_TRUE(t.has_value()) << x.n;
    ASSERT_TRUE(t->command.has_value()) << x.n;
    EXPECT_EQ(command_bits(*t->command).set, x.set) << x.n;
    EXPECT_EQ(command_bits(*t->command).reset, x.reset) << x.n;
  }
  EXPECT_FALSE(find_transition(1)->command.has_value());
  EXPECT_FALSE(find_transition(14)->command.has_value());
  EXPECT_FALSE(find_transition(13).has_value());
}

TEST(Cia402, ModesAndOptions) {
  EXPECT_EQ(static_cast<int>(ModeOfOperation::kCyclicSyncTorque), 10);
  EXPECT_EQ(static_cast<int>(ModeOfOperation::kCyclicSyncPosition), 8);
  EXPECT_EQ(supported_mode_bit(ModeOfOperation::kCyclicSyncTorque), 0x200u);
  EXPECT_EQ(supported_mode_bit(ModeOfOperation::kProfilePosition), 0x001u);
  EXPECT_EQ(supported_mode_bit(ModeOfOperation::kNoMode), 0u);
  EXPECT_EQ(static_cast<int>(AbortConnectionOption::kQuickStop), 3);
  EXPECT_EQ(static_cast<int>(QuickStopOption::kQuickStopRamp), 2);
  EXPECT_EQ(static_cast<int>(QuickStopOption::kCurrentLimitStay), 7);
  EXPECT_EQ(static_cast<int>(FaultReactionOption::kDisableDrive), 0);
}

TEST(Cia402, Names) {
  EXPECT_EQ(std::string(to_string(S::kOperationEnabled)), "Operation enabled");
  EXPECT_EQ(std::string(to_string(Command::kFaultReset)), "fault reset");
}

// ---- one owner: host and drive sides derived from kTransitions -------------------------

// The drive side agrees with the bit-level reading of table 29 (drive_reacts, written from
// the standard independently of kTransitions) for every state and all 16 patterns of
// controlword bits 0..3, 605Ah 5..8 (16 allowed) or not.
TEST(Cia402OneOwner, SlaveTransitionMatchesTable29ForEveryControlword) {
  for (S from : kAllStates) {
    if (from == S::kNotReadyToSwitchOn || from == S::kFaultReactionActive || from == S::kFault)
      continue;  // the drive moves on its own / only bit 7's edge acts
    for (std::uint16_t bits = 0; bits < 16; ++bits) {
      const std::optional<Transition> t = slave_transition(from, decode_command(bits), true);
      const S expected = drive_reacts(from, bits, false);
      EXPECT_EQ(t ? t->to : from, expected) << to_string(from) << " cw " << bits;
      if (t) {
        EXPECT_EQ(t->from, from);
      }
      // Without 605Ah 5..8, 16 is never taken.
      const std::optional<Transition> no16 = slave_transition(from, decode_command(bits), false);
      if (no16) {
        EXPECT_NE(no16->number, 16);
      }
    }
  }
}

// Every step the host commands (next_transition, for every state and target) is the
// transition the drive side makes on the controlword the host sends for it.
TEST(Cia402OneOwner, HostAndDriveAgreeOnEveryTransition) {
  int checked = 0;
  for (S from : kAllStates) {
    for (S target : kAllStates) {
      const std::optional<Transition> host = next_transition(from, target);
      if (!host) continue;
      ASSERT_TRUE(host->command.has_value());
      if (host->number == 15) continue;  // the rising edge of bit 7, not a command pattern
      const std::uint16_t cw = apply(*host->command, 0);
      const std::optional<Transition> drive = slave_transition(from, decode_command(cw));
      ASSERT_TRUE(drive.has_value()) << to_string(from) << " -> " << to_string(target);
      EXPECT_EQ(drive->number, host->number) << to_string(from) << " -> " << to_string(target);
      EXPECT_EQ(drive->to, host->to);
      ++checked;
    }
  }
  // Every commanded transition of the table except 15 and 16 is used by some walk.
  std::set<int> used;
  for (S from : kAllStates)
    for (S target : kAllStates)
      if (const auto t = next_transition(from, target)) used.insert(t->number);
  EXPECT_EQ(used, (std::set<int>{2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 15}));
  EXPECT_GE(checked, 16);  // at least the 4 commandable states x 4 targets
}

}  // namespace
}  // namespace dualv::fw
