// The configuration loader on any file: the input is the file (config/dualv.yaml and broken
// variants of it are the seeds), read by load_robot_config (apps/experiment/robot_config.hpp,
// every `dualv run`) and, as `dualv sim` and `dualv eds-check` do, by load_can_config_file
// (drivers/canopen_config.hpp). A refusal is an exception (set-up code); everything else must
// not crash, leak, hang or hit undefined behaviour, and a configuration that loads must hold
// what the loaders promise: a positive control period, the safety limits at least as wide as
// the trajectory's, and no drive allowed more torque than the safety limit.
#include <sys/mman.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <string>

#include "apps/experiment/robot_config.hpp"
#include "drivers/canopen_config.hpp"

#include "fuzz/check.hpp"

namespace {

// The input as a file: an in-memory file (memfd), rewritten for each input; the loaders open
// it by its /proc path like any other file.
const std::string& input_file(const std::uint8_t* data, std::size_t size) {
  static const int fd = memfd_create("dualv-config-fuzz.yaml", 0);
  static const std::string path = "/proc/self/fd/" + std::to_string(fd);
  FUZZ_CHECK(fd >= 0 && ftruncate(fd, 0) == 0);
  std::size_t done = 0;
  while (done < size) {
    const ssize_t n = pwrite(fd, data + done, size - done, static_cast<off_t>(done));
    FUZZ_CHECK(n > 0);
    done += static_cast<std::size_t>(n);
  }
  return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = input_file(data, size);
  try {
    const dualv::apps::RobotConfig cfg = dualv::apps::load_robot_config(path);
    FUZZ_CHECK(cfg.loop.period_ns > 0 && std::isfinite(cfg.rate_hz()));
    for (const auto& d : cfg.can.drives) FUZZ_CHECK(d.max_torque <= cfg.safety.torque.max);
    FUZZ_CHECK(cfg.safety.torque.max >= cfg.trajectory.limits.max_joint_torque);
    FUZZ_CHECK(cfg.safety.max_joint_velocity >= cfg.trajectory.limits.max_joint_speed);
  } catch (const std::exception&) {
    // refused: the message is the user's (issue 14 defect 2 checks its wording)
  }
  try {
    const dualv::drivers::CanConfig can = dualv::drivers::load_can_config_file(path);
    FUZZ_CHECK(can.size() >= 1);
    (void)dualv::drivers::bus_load_report(can);
  } catch (const std::exception&) {
  }
  return 0;
}
