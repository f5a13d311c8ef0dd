#pragma once
// An ActuatorSet decorator that injects sensor and link faults between real (or simulated)
// drives and the control loop, for `dualv selftest` and the safety tests: an encoder jump,
// feedback that stops arriving (stale TPDOs), a non-finite position. It also records the
// largest torque written to the drives while they were asked to hold or enable (what a
// commissioning test reports as "max torque seen"). noexcept, no allocation.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "drivers/actuator_set.hpp"

namespace dualv::safety {

class FaultInjector final : public drivers::ActuatorSet {
 public:
  explicit FaultInjector(drivers::ActuatorSet& inner) noexcept : inner_(&inner) {}

  int size() const noexcept override { return inner_->size(); }
  drivers::IoStatus read(drivers::ActuatorFeedback& fb) noexcept override {
    drivers::IoStatus s = inner_->read(fb);
    for (int i = 0; i < fb.n && i < drivers::kMaxDrives; ++i) {
      auto& d = fb.drive[static_cast<std::size_t>(i)];
      d.position += offset_[static_cast<std::size_t>(i)];
      if (frozen_[static_cast<std::size_t>(i)]) {
        d.position = held_[static_cast<std::size_t>(i)];
        d.fresh = false;
        if (s == drivers::IoStatus::kOk) s = drivers::IoStatus::kStale;
      } else {
        held_[static_cast<std::size_t>(i)] = d.position;
      }
      if (nan_[static_cast<std::size_t>(i)]) d.position = std::numeric_limits<double>::quiet_NaN();
    }
    return s;
  }
  drivers::IoStatus write(const drivers::ActuatorCommand& c) noexcept override {
    ++writes_;
    for (int i = 0; i < c.n && i < drivers::kMaxDrives; ++i)
      max_torque_ = std::max(max_torque_, std::abs(c.torque[static_cast<std::size_t>(i)]));
    last_ = c;
    return inner_->write(c);
  }

  // Adds `rad` to drive i's position from the next read() on (an encoder jump).
  void jump_encoder(int i, double rad) noexcept { offset_[static_cast<std::size_t>(i)] += rad; }
  // Drive i's position stops updating and is reported not fresh (lost TPDOs).
  void freeze_feedback(int i, bool frozen) noexcept {
    frozen_[static_cast<std::size_t>(i)] = frozen;
  }
  void corrupt_position(int i, bool nan) noexcept { nan_[static_cast<std::size_t>(i)] = nan; }
  // Every injection off (offsets back to zero: the next read() shows the true positions).
  void clear() noexcept {
    offset_.fill(0.0);
    frozen_.fill(false);
    nan_.fill(false);
  }

  double max_torque() const noexcept { return max_torque_; }
  void reset_max_torque() noexcept { max_torque_ = 0.0; }
  const drivers::ActuatorCommand& last_command() const noexcept { return last_; }
  long writes() const noexcept { return writes_; }

 private:
  drivers::ActuatorSet* inner_;
  std::array<double, drivers::kMaxDrives> offset_{};
  std::array<double, drivers::kMaxDrives> held_{};
  std::array<bool, drivers::kMaxDrives> frozen_{};
  std::array<bool, drivers::kMaxDrives> nan_{};
  double max_torque_ = 0.0;
  drivers::ActuatorCommand last_{};
  long writes_ = 0;
};

}  // namespace dualv::safety
