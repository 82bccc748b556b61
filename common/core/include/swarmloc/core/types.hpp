#pragma once
// Plain value types shared by every layer. No transport, clock or I/O types here.
#include <Eigen/Dense>  // Core + LU/Cholesky: determinant() and inverse() of small blocks
#include <cstdint>

namespace swarmloc {

using AgentId = std::int32_t;
inline constexpr AgentId kOrchestratorId = -1;

using Vec2 = Eigen::Vector2d;
using Mat2 = Eigen::Matrix2d;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using VecX = Eigen::VectorXd;
using MatX = Eigen::MatrixXd;

}  // namespace swarmloc
