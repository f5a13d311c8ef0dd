#pragma once
// The planar n-RRR parallel mechanism (n >= 3 chains; the Dual-V has n = 4).
//
// Model: geometry and inertia, immutable after loading (control/config/model_config.hpp).
// Data:  every buffer the algorithms need, preallocated from a Model
//        (Pinocchio's model/data split). Algorithms take (const Model&, Data&, ...),
//        are noexcept, allocate nothing and return a status.
//
// Frames and units: world frame x right, y up, SI units, angles in rad.
// Pose X = (x, y, theta) of the travelling plate; q = crank angles measured
// from the world x axis. Chain i: base pivot A_i -> crank (length l1) -> elbow
// B_i -> coupler (length l2) -> plate anchor C_i = p + Rot(theta) c_i.
#include <Eigen/Core>
#include <array>
#include <cstdint>

namespace dualv::model {

inline constexpr int kMaxChains = 8;

using Vec2 = Eigen::Vector2d;
using Pose = Eigen::Vector3d;   // (x [m], y [m], theta [rad])
using Twist = Eigen::Vector3d;  // (x_dot, y_dot, theta_dot) and likewise for accelerations
using Mat3 = Eigen::Matrix3d;
// Sized n at run time, storage fixed at kMaxChains: never touches the heap.
using JointVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxChains, 1>;
using JointJacobian = Eigen::Matrix<double, Eigen::Dynamic, 3, 0, kMaxChains, 3>;  // n x 3
using JointMatrix =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxChains, kMaxChains>;

// A rigid link: mass [kg], rotational inertia about its centre of mass [kg m^2]
// and the centre of mass in the link frame [m] (x along the link from its proximal joint).
struct Body {
  double mass = 0.0;
  double inertia = 0.0;
  Vec2 com = Vec2::Zero();
};

struct Chain {
  Vec2 base = Vec2::Zero();          // A_i, world frame [m]
  Vec2 plate_anchor = Vec2::Zero();  // c_i, plate frame [m]
  double crank_length = 0.0;         // l1 [m]
  double coupler_length = 0.0;       // l2 [m]
  int working_mode = 1;              // s_i = +1 or -1 (elbow side, docs/architecture.md IK)
  Body crank;                        // link frame: origin A_i, x towards B_i
  Body coupler;                      // link frame: origin B_i, x towards C_i
};

struct Model {
  int n = 0;  // number of chains, 3..kMaxChains
  std::array<Chain, kMaxChains> chains{};
  Body plate;                   // link frame = plate frame (origin at p, rotated by theta)
  Vec2 gravity = Vec2::Zero();  // [m/s^2] in the plane of motion (zero: horizontal machine)
  Pose home = Pose::Zero();
  // Scale turning rotations into lengths when translations and rotations are
  // compared (singularity distance, tracking error): a characteristic length [m].
  double characteristic_length = 0.11;
};

enum class Status : std::uint8_t {
  kOk = 0,
  kUnreachable,       // a chain cannot reach its anchor: |C - A| outside [|l1 - l2|, l1 + l2]
  kSerialSingular,    // crank and coupler aligned: Jm not defined
  kParallelSingular,  // Jm^T Jm not invertible: the plate is not controlled
  kInvalidInput,      // NaN/Inf input or a size that does not match the model
  kNotConverged,      // forward kinematics ran out of iterations
  kInconsistent,      // forward kinematics: no pose explains the n joint angles
};

const char* to_string(Status s) noexcept;

// Per-chain intermediate quantities, kept for reuse across algorithms.
struct ChainState {
  Vec2 anchor = Vec2::Zero();   // C_i world [m]
  Vec2 r = Vec2::Zero();        // Rot(theta) c_i [m]
  Vec2 elbow = Vec2::Zero();    // B_i world [m]
  Vec2 crank = Vec2::Zero();    // a_i = B_i - A_i
  Vec2 coupler = Vec2::Zero();  // u_i = C_i - B_i
};

struct Data {
  explicit Data(const Model& model);
  int n = 0;
  std::array<ChainState, kMaxChains> chain{};
  Vec2 rotation = Vec2(1.0, 0.0);  // (cos theta, sin theta) of the plate, with chain[*]
  JointVector q;                   // crank angles [rad]
  JointVector q_dot;               // [rad/s]
  JointJacobian Jm;                // q_dot = Jm X_dot (n x 3)
  JointJacobian Jm_dot;            // d/dt Jm
  JointVector qdd_bias;            // Jm_dot X_dot: joint accelerations at zero plate acceleration
  JointJacobian JmT_pinv;   // Jm^{T*} = Jm (Jm^T Jm)^-1: minimum-norm solution of Jm^T tau = F
  JointMatrix R;            // Jm^{T*} Jm^T: projector onto range(Jm) (paper eq. 19-20)
  JointMatrix N;            // I - R: null space of Jm^T (internal forces)
  Mat3 M = Mat3::Zero();    // task-space mass matrix M(X)
  Twist h = Twist::Zero();  // Coriolis/centrifugal generalized force
  Twist g = Twist::Zero();  // gravity generalized force (F_X = M X_dd + h + g)
};

}  // namespace dualv::model
