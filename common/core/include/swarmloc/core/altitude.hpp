#pragma once
// The third coordinate of a 3-D world (world.dimensions: 3, docs/design.md §3.1). A 3-D position travels as
// its planar part (x, y), in the fields every 2-D message already has, plus an Altitude: z and the z row of
// the (x, y, z) covariance. Planar worlds leave it out, so their messages, wire bytes and results stay as
// they were.
#include "swarmloc/core/types.hpp"

namespace swarmloc {

struct Altitude {
  double z_m = 0.0;
  double variance_m2 = 0.0;      ///< var(z); information-form fields use it for the zz entry
  Vec2 cross_m2 = Vec2::Zero();  ///< (cov(x, z), cov(y, z))
};

/// (x, y) and z as one point.
inline Vec3 join(const Vec2& planar, double z_m) { return {planar.x(), planar.y(), z_m}; }

/// The (x, y, z) covariance from its planar block and its z row.
inline Mat3 join(const Mat2& planar, const Altitude& altitude) {
  Mat3 joined;
  joined.topLeftCorner<2, 2>() = planar;
  joined.topRightCorner<2, 1>() = altitude.cross_m2;
  joined.bottomLeftCorner<1, 2>() = altitude.cross_m2.transpose();
  joined(2, 2) = altitude.variance_m2;
  return joined;
}

/// The z row of `covariance` with z = `position.z()`.
inline Altitude altitude_of(const Vec3& position, const Mat3& covariance) {
  return {position.z(), covariance(2, 2), covariance.topRightCorner<2, 1>()};
}

}  // namespace swarmloc
