#pragma once
// The safety filter: sits between the control law and ActuatorSet::write() and owns the
// final torque and DriveRequest (docs/architecture.md: drives -> ... -> controller -> SAFETY ->
// drives).
//
// Every cycle, update() (noexcept, no allocation, no syscalls):
//   1. takes external stop/reset requests (EstopLatch, any thread);
//   2. evaluates every monitor on this cycle's data: drive states and inputs, bus status,
//      fresh feedback, its own joint velocity (a backward difference of the positions,
//      independent of the controller's estimator), encoder jumps, plate velocity, workspace,
//      singularity distance, tracking error, the controller's command (NaN/Inf, torque,
//      torque rate), deadline misses, the LCM command stream, the write-path watchdog;
//   3. latches every fault whose reaction is SS1 or STO (fault.hpp: kFaultTable), logs
//      each new one (FaultLog: cycle, time, cause, reaction, latency, torque sent);
//   4. steps the stop state machine:
//        kDisabled --arm()--> kOperational --SS1 fault--> kSs1 --standstill | max_time--> kSto
//        kOperational / kSs1 --STO fault--> kSto ;  kSto --reset (causes cleared)--> kDisabled
//      (IEC 61800-5-2: SS1 = controlled stop then STO; STO = torque off, stop category 0)
//   5. writes the command: kOperational passes the controller's command, clamped to
//      torque.max and rate-limited to torque.max_rate; kSs1 brakes with
//      tau = -ss1.damping * q_dot (clamped to ss1.max_torque, rate-limited) and kHold;
//      kSto and kDisabled send 0 N m and kDisable (CiA 402 disable voltage).
// Detection is in the cycle the data shows the fault (0 cycles latency) for every limit,
// and at exactly the configured count for the cycle-counted watchdogs.
//
// A reset never restarts motion: it leads to kDisabled, and only arm() (a new program
// start) leads to kOperational. Not a certified safety function (docs/safety.md).
#include <array>
#include <atomic>
#include <cstdint>

#include "control/model/kinematics.hpp"
#include "control/model/model.hpp"
#include "drivers/actuator_set.hpp"
#include "safety/estop_latch.hpp"
#include "safety/fault.hpp"
#include "safety/fault_log.hpp"
#include "safety/safety_config.hpp"

namespace dualv::safety {

enum class SafetyState : std::uint8_t {
  kDisabled = 0,  // no program armed: torque 0, drives disabled
  kOperational,   // the controller's (limited) command passes
  kSs1,           // controlled stop in progress
  kSto,           // torque off, latched until reset
};
const char* to_string(SafetyState s) noexcept;

// What the layers above hand the filter each cycle besides the drives' feedback.
struct SafetyInput {
  std::int64_t cycle = -1;   // loop cycle number (-1: the filter's count)
  std::int64_t time_ns = 0;  // loop clock [ns]
  drivers::IoStatus io_status = drivers::IoStatus::kOk;
  drivers::ActuatorCommand command;     // the controller's wish (torque, request)
  bool pose_valid = true;               // the estimator found the pose
  model::Pose X = model::Pose::Zero();  // estimated plate pose
  bool tracking = false;                // a reference is followed: check X_d - X
  model::Pose X_d = model::Pose::Zero();
  bool deadline_missed = false;         // the previous cycle missed its deadline
  int consecutive_deadline_misses = 0;  // PeriodicExecutive CycleInfo
  bool streaming = false;               // a streaming command mode is active
  bool stream_fresh = false;            // a streamed command arrived this cycle
};

// Plain per-cycle summary (telemetry: CycleRecord::safety).
struct SafetyReport {
  SafetyState state = SafetyState::kDisabled;
  FaultSet latched = 0;         // every latched cause
  FaultSet active = 0;          // monitors that see a violation this cycle
  FaultSet detected = 0;        // newly latched this cycle
  bool torque_limited = false;  // the command was clamped or rate-limited this cycle
  bool reset_pending = false;
  std::int32_t stop_cycles = 0;  // cycles since the current SS1 began
  std::uint64_t checks = 0;      // update() count (the write-path watchdog's token)
};

// The state code of dualv_lcm::robot_state_t (SAFETY_DISABLED 0, OPERATIONAL 1, SS1 2,
// STO 3, ESTOP 4, FAULT 5) for a report: a stop latched by an e-stop source reads ESTOP, one
// latched by a drive or the bus reads FAULT, any other completed stop STO. noexcept.
std::int8_t telemetry_state(const SafetyReport& report) noexcept;

enum class ArmStatus : std::uint8_t { kOk = 0, kLatched, kInvalidFeedback };
const char* to_string(ArmStatus s) noexcept;

// Cycle counts derived from the configuration's times and the control period.
struct CycleLimits {
  std::int32_t ss1_max = 0;
  std::int32_t standstill = 0;
  std::int32_t stream_timeout = 0;
  double torque_step = 0.0;  // [N m] per cycle = max_rate * period
};
CycleLimits cycle_limits(const SafetyConfig& config, double period_s) noexcept;

// Clamps `in` to +-max, then to +-max_step around `prev`; a non-finite entry holds `prev`
// (clamped). Returns true when any entry was changed. noexcept, no allocation.
bool limit_torque(const double* in, const double* prev, int n, double max, double max_step,
                  double* out) noexcept;

class SafetyFilter {
 public:
  // Set-up (allocates the fault log's ring). `model` must outlive the filter. Throws
  // std::invalid_argument when validate(config) finds a problem or period <= 0.
  SafetyFilter(const model::Model& model, const SafetyConfig& config, double period_s);

  // A program start: kDisabled (or kOperational) -> kOperational, seeding the monitors with
  // this feedback. Refused (kLatched) while any cause is latched: reset first. Not RT.
  ArmStatus arm(const drivers::ActuatorFeedback& feedback, std::int64_t time_ns = 0) noexcept;
  // A normal end of operation: -> kDisabled (torque 0, drives disabled), nothing latched.
  void disarm() noexcept;
  // Commissioning limit tests only (`dualv selftest`): new limits from the next update() on,
  // e.g. a joint velocity limit below the motion in progress, to prove that the monitor trips
  // and the stop follows on the real machine. Never in a production run. Set-up, not RT:
  // throws std::invalid_argument as the constructor does.
  void set_limits_for_test(const SafetyConfig& config);

  // One cycle (see the header comment). `out` is the command to write.
  SafetyState update(const drivers::ActuatorFeedback& feedback, const SafetyInput& in,
                     drivers::ActuatorCommand& out) noexcept;

  // Any thread: external stop / reset requests (EstopLatch).
  EstopLatch& latch() noexcept { return latch_; }
  void request_stop(StopSource s) noexcept { latch_.request_stop(s); }
  void request_reset() noexcept { latch_.request_reset(); }
  // The write path found the check skipped or bypassed (WriteGuard): latched next update().
  void report_check_missed() noexcept { check_missed_.store(true, std::memory_order_release); }

  SafetyState state() const noexcept { return report_.state; }
  const SafetyReport& report() const noexcept { return report_; }
  FaultLog& log() noexcept { return log_; }
  const SafetyConfig& config() const noexcept { return config_; }
  const CycleLimits& limits() const noexcept { return limits_; }
  // The last command update() produced and how many checks ran (the WriteGuard's view).
  const drivers::ActuatorCommand& last_output() const noexcept { return last_out_; }
  std::uint64_t checks() const noexcept { return checks_.load(std::memory_order_acquire); }
  // Streaming mode: cycles since the last fresh command, the stream watchdog's clock (0 when
  // no stream is watched).
  std::int32_t stream_age_cycles() const noexcept { return stream_age_; }
  // The filter's own joint velocity estimate [rad/s] (backward difference).
  double joint_velocity(int i) const noexcept { return q_dot_[static_cast<std::size_t>(i)]; }

 private:
  struct Detection {
    FaultSet set = 0;
    std::array<std::int16_t, kFaultCount> drive{};
    std::array<std::int32_t, kFaultCount> latency{};
    std::array<double, kFaultCount> value{};
    std::array<double, kFaultCount> limit{};
    void add(Fault f, int drive_index = -1, double v = 0.0, double lim = 0.0,
             int latency_cycles = 0) noexcept;
  };
  void monitor(const drivers::ActuatorFeedback& fb, const SafetyInput& in, Detection& d) noexcept;
  void log_event(EventKind kind, Fault fault, Reaction reaction, const Detection* d,
                 FaultSet blocking, std::int64_t time_ns) noexcept;
  void enter_sto(std::int64_t time_ns) noexcept;
  bool at_standstill() const noexcept;

  const model::Model* model_;
  SafetyConfig config_;
  double period_;
  CycleLimits limits_;
  int n_;
  model::Data data_;
  EstopLatch latch_;
  FaultLog log_;
  std::atomic<bool> check_missed_{false};
  std::atomic<std::uint64_t> checks_{0};
  SafetyReport report_;
  drivers::ActuatorCommand last_out_;
  std::int64_t cycle_ = 0;       // cycle number of the events logged now
  std::int64_t own_cycles_ = 0;  // update() calls
  // Monitors' memory.
  std::array<double, drivers::kMaxDrives> q_prev_{};
  std::array<bool, drivers::kMaxDrives> q_prev_valid_{};
  std::array<std::int32_t, drivers::kMaxDrives> since_fresh_{};  // cycles without fresh data
  std::array<double, drivers::kMaxDrives> q_dot_{};
  std::array<double, drivers::kMaxDrives> tau_prev_{};  // last torque written [N m]
  std::int32_t stream_age_ = 0;
  std::int32_t standstill_count_ = 0;
  std::int32_t reset_cycles_left_ = 0;
  bool all_enabled_seen_ = false;  // every drive was in Operation enabled since arm()
};

// The independent end of the watchdog: the write path checks that the safety filter ran
// since the last write (its check counter advanced) and that the command about to be
// written is the filter's output; if not, it writes torque 0 + kDisable (STO) instead and
// reports it to the filter (latched as kSafetyCheckMissed). Catches a cycle that skips or
// bypasses the safety check. The last line of defence when the whole process dies is on the
// drives: heartbeat consumer 1016h and RPDO deadline (docs/architecture.md), not this class.
class WriteGuard {
 public:
  explicit WriteGuard(SafetyFilter& filter) noexcept : filter_(&filter) {}
  drivers::IoStatus write(drivers::ActuatorSet& io,
                          const drivers::ActuatorCommand& command) noexcept;
  std::uint64_t trips() const noexcept { return trips_; }
  void rebind() noexcept { last_checks_ = filter_->checks(); }

 private:
  SafetyFilter* filter_;
  std::uint64_t last_checks_ = 0;
  std::uint64_t trips_ = 0;
};

}  // namespace dualv::safety
