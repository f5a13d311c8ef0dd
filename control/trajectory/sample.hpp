#pragma once
// Value structs the trajectory generator hands out (Ruckig style: plain data in and out).
#include "control/trajectory/shape.hpp"

namespace dualv::trajectory {

// Desired plate motion at one instant, world frame, SI units.
struct CartesianSample {
  Pose X = Pose::Zero();        // X_d
  Twist X_dot = Twist::Zero();  // X_d_dot [m/s, rad/s]
  Twist X_dd = Twist::Zero();   // X_d_dd [m/s^2, rad/s^2]
  Twist X_ddd = Twist::Zero();  // jerk [m/s^3, rad/s^3]
};

}  // namespace dualv::trajectory
