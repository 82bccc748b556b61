#include "swarmloc/estimators/uwb/relative_pose.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

namespace swarmloc::estimators::uwb {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

double wrap_angle(double angle) { return std::remainder(angle, kTwoPi); }

/// d/dψ of Rz(ψ)·w at v = Rz(ψ)·w.
Vec3 yaw_derivative(const Vec3& v) { return {-v.y(), v.x(), 0.0}; }

double huber_weight(double standardized, double threshold) {
  const double magnitude = std::abs(standardized);
  return magnitude <= threshold ? 1.0 : threshold / magnitude;
}

double huber_cost(double standardized, double threshold) {
  const double magnitude = std::abs(standardized);
  return magnitude <= threshold ? 0.5 * magnitude * magnitude : threshold * (magnitude - 0.5 * threshold);
}

/// The robust normal equations of the ranges (and altitude) at `pose`, and their robust cost.
struct NormalEquations {
  Mat4 information = Mat4::Zero();
  Vec4 gradient = Vec4::Zero();  ///< Hᵀ W R⁻¹ e
  double cost = 0.0;
};

NormalEquations range_equations(const RelativePose& pose, const RangeWindow& window,
                                const RelativePoseParams& params) {
  NormalEquations out;
  const auto prediction = predict_ranges(pose, window, params);
  for (Eigen::Index k = 0; k < prediction.measured_m.size(); ++k) {
    const double error = prediction.measured_m(k) - prediction.predicted_m(k);
    const double standardized = error / prediction.std_m(k);
    const double weight =
        huber_weight(standardized, params.huber_threshold) / (prediction.std_m(k) * prediction.std_m(k));
    const Vec4 row = prediction.jacobian.row(k).transpose();
    out.information += weight * row * row.transpose();
    out.gradient += weight * error * row;
    out.cost += huber_cost(standardized, params.huber_threshold);
  }
  if (window.altitude_difference_m) {
    const double error = *window.altitude_difference_m - pose.position_m.z();
    const double alt_inv_var = 1.0 / (params.altitude_std_m * params.altitude_std_m);
    out.information(2, 2) += alt_inv_var;
    out.gradient(2) += alt_inv_var * error;
    out.cost += 0.5 * error * error * alt_inv_var;
  }
  return out;
}

Vec4 pose_difference(const Vec4& a, const Vec4& b) {
  Vec4 d = a - b;
  d(3) = wrap_angle(d(3));
  return d;
}

double median_valid_range(const MatX& ranges) {
  std::vector<double> valid;
  for (Eigen::Index k = 0; k < ranges.size(); ++k) {
    if (std::isfinite(ranges(k))) valid.push_back(ranges(k));
  }
  std::nth_element(valid.begin(), valid.begin() + static_cast<std::ptrdiff_t>(valid.size() / 2), valid.end());
  return valid[valid.size() / 2];
}

int valid_count(const MatX& ranges) {
  int count = 0;
  for (Eigen::Index k = 0; k < ranges.size(); ++k) count += std::isfinite(ranges(k)) ? 1 : 0;
  return count;
}

}  // namespace

Mat3 level_rotation(const Tilt& tilt) {
  return (Eigen::AngleAxisd(tilt.pitch_rad, Vec3::UnitY()) * Eigen::AngleAxisd(tilt.roll_rad, Vec3::UnitX()))
      .toRotationMatrix();
}

Mat3 yaw_rotation(double yaw_rad) { return Eigen::AngleAxisd(yaw_rad, Vec3::UnitZ()).toRotationMatrix(); }

std::vector<Vec3> ring_lever_arms(int count, double radius_m, double first_angle_rad) {
  std::vector<Vec3> arms;
  for (int i = 0; i < count; ++i) {
    const double angle = first_angle_rad + kTwoPi * i / count;
    arms.emplace_back(radius_m * std::cos(angle), radius_m * std::sin(angle), 0.0);
  }
  return arms;
}

RangeBias::Features geometry_features(double sin_elevation, double facing_mine, double facing_peer) {
  RangeBias::Features features;
  features << std::abs(sin_elevation), sin_elevation * sin_elevation, sin_elevation,
      facing_mine + facing_peer, facing_mine * facing_mine + facing_peer * facing_peer;
  return features;
}

double RangeBias::at(int my_antenna, int peer_antenna, const Features& features) const {
  double bias = coefficients_m.dot(features);
  if (my_antenna < my_antenna_offsets_m.size()) bias += my_antenna_offsets_m(my_antenna);
  if (peer_antenna < peer_antenna_offsets_m.size()) bias += peer_antenna_offsets_m(peer_antenna);
  return bias;
}

namespace {

/// One antenna pair's geometry at a pose, with the derivatives of its bias features in (t, ψ).
struct PairGeometry {
  double range = 0.0;
  Vec4 d_range = Vec4::Zero();
  RangeBias::Features features;
  Eigen::Matrix<double, RangeBias::kFeatures, 4> d_features;
};

PairGeometry pair_geometry(const Vec3& position, const Vec3& my_arm, const Vec3& peer_arm, const Mat3& mine,
                           const Mat3& peer) {
  const Vec3 my_antenna = mine * my_arm;
  const Vec3 peer_antenna = peer * peer_arm;
  const Vec3 d = position + peer_antenna - my_antenna;
  PairGeometry g;
  g.range = d.norm();
  const Vec3 u = d / g.range;
  const Vec3 d_yaw = yaw_derivative(peer_antenna);
  g.d_range << u, u.dot(d_yaw);
  // du/dt = (I − u·uᵀ)/r; du/dψ = that · d(d)/dψ.
  const Mat3 projector = (Mat3::Identity() - u * u.transpose()) / g.range;
  const Vec3 du_yaw = projector * d_yaw;
  const auto radial = [](const Vec3& arm) {
    return arm.norm() > 0.0 ? Vec3(arm / arm.norm()) : Vec3::Zero();
  };
  const Vec3 m = mine * radial(my_arm);
  const Vec3 p = peer * radial(peer_arm);
  const double s = u.z();
  const double facing_mine = m.dot(u);
  const double facing_peer = -p.dot(u);
  Vec4 d_s;
  d_s << projector.row(2).transpose(), du_yaw.z();
  Vec4 d_mine;
  d_mine << projector * m, m.dot(du_yaw);
  Vec4 d_peer;
  d_peer << -(projector * p), -(p.dot(du_yaw) + u.dot(yaw_derivative(p)));
  g.features = geometry_features(s, facing_mine, facing_peer);
  g.d_features.row(0) = (s >= 0.0 ? 1.0 : -1.0) * d_s.transpose();
  g.d_features.row(1) = 2.0 * s * d_s.transpose();
  g.d_features.row(2) = d_s.transpose();
  g.d_features.row(3) = (d_mine + d_peer).transpose();
  g.d_features.row(4) = (2.0 * facing_mine * d_mine + 2.0 * facing_peer * d_peer).transpose();
  return g;
}

}  // namespace

RangePrediction predict_ranges(const RelativePose& pose, const RangeWindow& window,
                               const RelativePoseParams& params) {
  const Mat3 mine = level_rotation(window.mine);
  const Mat3 peer = yaw_rotation(pose.heading_rad) * level_rotation(window.peer);
  const auto rows = static_cast<Eigen::Index>(valid_count(window.ranges_m));
  RangePrediction out{VecX(rows), VecX(rows), Eigen::Matrix<double, Eigen::Dynamic, 4>(rows, 4), VecX(rows)};
  const bool spread_known = window.range_spread_m.size() == window.ranges_m.size();
  Eigen::Index row = 0;
  for (Eigen::Index j = 0; j < window.ranges_m.cols(); ++j) {
    for (Eigen::Index i = 0; i < window.ranges_m.rows(); ++i) {
      if (!std::isfinite(window.ranges_m(i, j))) continue;
      const auto g = pair_geometry(pose.position_m, params.my_lever_arms_m.at(static_cast<std::size_t>(i)),
                                   params.peer_lever_arms_m.at(static_cast<std::size_t>(j)), mine, peer);
      out.predicted_m(row) = g.range + params.bias.at(static_cast<int>(i), static_cast<int>(j), g.features);
      out.jacobian.row(row) = (g.d_range + g.d_features.transpose() * params.bias.coefficients_m).transpose();
      out.measured_m(row) = window.ranges_m(i, j);
      const double spread =
          spread_known && std::isfinite(window.range_spread_m(i, j)) ? window.range_spread_m(i, j) : 0.0;
      out.std_m(row) = std::hypot(params.range_std_m, params.spread_noise_gain * spread * spread);
      ++row;
    }
  }
  return out;
}

RelativePoseFilter::RelativePoseFilter(RelativePoseParams params) : params_(std::move(params)) {}

void RelativePoseFilter::predict(double dt_s, double my_turn_rad, double peer_turn_rad) {
  if (!initialized_ || !(dt_s > 0.0)) return;
  Mat4 turn = Mat4::Identity();
  turn.topLeftCorner<3, 3>() = yaw_rotation(-my_turn_rad);
  mean_ = turn * mean_;
  mean_(3) = wrap_angle(mean_(3) + peer_turn_rad - my_turn_rad);
  covariance_ = turn * covariance_ * turn.transpose();
  const double q_position = params_.position_walk_mps * params_.position_walk_mps * dt_s;
  covariance_.diagonal() += Vec4(q_position, q_position, q_position,
                                 params_.heading_walk_radps * params_.heading_walk_radps * dt_s);
}

bool RelativePoseFilter::update(const RangeWindow& window) {
  if (valid_count(window.ranges_m) < 4) return false;
  if (!initialized_) {
    initialize(window);
    return true;
  }
  const Vec4 prior = mean_;
  solve(window, prior, covariance_.inverse());
  relock_if_lost(window);
  return true;
}

void RelativePoseFilter::relock_if_lost(const RangeWindow& window) {
  // A filter that has followed a wrong solution explains its ranges badly: solve the window afresh from the
  // grid and keep that if it explains them better.
  const auto ranges = static_cast<double>(valid_count(window.ranges_m));
  const double cost = range_equations(RelativePose::from(mean_), window, params_).cost;
  if (cost / ranges <= params_.relock_cost_per_range) return;
  const Vec4 kept_mean = mean_;
  const Mat4 kept_covariance = covariance_;
  initialize(window);
  if (range_equations(RelativePose::from(mean_), window, params_).cost < cost) {
    ++relocks_;
    return;
  }
  mean_ = kept_mean;
  covariance_ = kept_covariance;
}

void RelativePoseFilter::solve(const RangeWindow& window, const Vec4& prior_mean,
                               const Mat4& prior_information) {
  Vec4 x = mean_;
  Mat4 information = prior_information;
  for (int iteration = 0; iteration < params_.iterations; ++iteration) {
    const auto equations = range_equations(RelativePose::from(x), window, params_);
    information = prior_information + equations.information;
    const Vec4 step =
        information.ldlt().solve(prior_information * pose_difference(prior_mean, x) + equations.gradient);
    x += step;
    x(3) = wrap_angle(x(3));
    if (step.norm() < 1e-6) break;
  }
  mean_ = x;
  covariance_ = information.inverse();
  covariance_ = 0.5 * (covariance_ + covariance_.transpose());
}

void RelativePoseFilter::initialize(const RangeWindow& window) {
  // The ranges alone leave the bearing, the heading and (without an altitude) the sign of the height
  // ambiguous: start Gauss–Newton from a grid of them and keep the lowest robust cost.
  const double range = median_valid_range(window.ranges_m);
  std::vector<double> heights;
  if (window.altitude_difference_m) {
    heights.push_back(std::clamp(*window.altitude_difference_m, -0.9 * range, 0.9 * range));
  } else {
    heights = {-0.5 * range, 0.0, 0.5 * range};
  }
  constexpr int kBearings = 24;
  constexpr int kHeadings = 12;
  std::vector<std::pair<double, Vec4>> starts;
  for (const double height : heights) {
    const double horizontal = std::sqrt(std::max(range * range - height * height, 0.0));
    for (int a = 0; a < kBearings; ++a) {
      const double bearing = kTwoPi * a / kBearings;
      for (int h = 0; h < kHeadings; ++h) {
        const Vec4 x(horizontal * std::cos(bearing), horizontal * std::sin(bearing), height,
                     wrap_angle(kTwoPi * h / kHeadings));
        starts.emplace_back(range_equations(RelativePose::from(x), window, params_).cost, x);
      }
    }
  }
  constexpr std::size_t kRefined = 6;
  std::partial_sort(starts.begin(), starts.begin() + static_cast<std::ptrdiff_t>(kRefined), starts.end(),
                    [](const auto& a, const auto& b) { return a.first < b.first; });
  // A weak prior keeps a start with too few ranges well posed; it does not move the solution.
  const Mat4 weak = Mat4::Identity() * 1e-6;
  double best_cost = std::numeric_limits<double>::infinity();
  Vec4 best_mean = Vec4::Zero();
  Mat4 best_covariance = Mat4::Identity();
  for (std::size_t k = 0; k < kRefined; ++k) {
    mean_ = starts[k].second;
    solve(window, starts[k].second, weak);
    const double cost = range_equations(RelativePose::from(mean_), window, params_).cost;
    if (cost < best_cost) {
      best_cost = cost;
      best_mean = mean_;
      best_covariance = covariance_;
    }
  }
  mean_ = best_mean;
  covariance_ = best_covariance;
  initialized_ = true;
}

RelativePose compose_relative(const RelativePose& b, const RelativePose& c) {
  return {yaw_rotation(-b.heading_rad) * (c.position_m - b.position_m),
          wrap_angle(c.heading_rad - b.heading_rad)};
}

std::map<AgentId, PoseEstimate> fuse_team(const std::map<AgentId, PoseEstimate>& mine,
                                          const std::vector<PeerRelation>& relations) {
  std::map<AgentId, Eigen::Index> block;
  for (const auto& [peer, estimate] : mine) block.emplace(peer, static_cast<Eigen::Index>(4 * block.size()));
  std::vector<const PeerRelation*> used;
  for (const auto& relation : relations) {
    if (relation.from != relation.to && block.contains(relation.from) && block.contains(relation.to)) {
      used.push_back(&relation);
    }
  }
  const auto both_ways = [&](const PeerRelation& r) {
    return std::any_of(used.begin(), used.end(),
                       [&](const PeerRelation* o) { return o->from == r.to && o->to == r.from; });
  };
  const auto size = static_cast<Eigen::Index>(4 * block.size());
  VecX y(size);
  for (const auto& [peer, estimate] : mine) y.segment<4>(block[peer]) = estimate.pose.vector();
  MatX information(size, size);
  for (int iteration = 0; iteration < 10; ++iteration) {
    information.setZero();
    VecX gradient = VecX::Zero(size);
    for (const auto& [peer, estimate] : mine) {
      const Eigen::Index at = block[peer];
      const Mat4 weight = estimate.covariance.inverse();
      information.block<4, 4>(at, at) += weight;
      gradient.segment<4>(at) += weight * pose_difference(estimate.pose.vector(), y.segment<4>(at));
    }
    for (const PeerRelation* relation : used) {
      const Eigen::Index from = block[relation->from];
      const Eigen::Index to = block[relation->to];
      const RelativePose a = RelativePose::from(y.segment<4>(from));
      const RelativePose predicted = compose_relative(a, RelativePose::from(y.segment<4>(to)));
      // Jacobian of compose_relative in (from, to): t = Rz(−ψ_a)(t_b − t_a), ψ = ψ_b − ψ_a.
      const Mat3 rotation = yaw_rotation(-a.heading_rad);
      Eigen::Matrix<double, 4, 8> jacobian = Eigen::Matrix<double, 4, 8>::Zero();
      jacobian.block<3, 3>(0, 0) = -rotation;
      jacobian.block<3, 1>(0, 3) = Vec3(predicted.position_m.y(), -predicted.position_m.x(), 0.0);
      jacobian(3, 3) = -1.0;
      jacobian.block<3, 3>(0, 4) = rotation;
      jacobian(3, 7) = 1.0;
      const double share = both_ways(*relation) ? 2.0 : 1.0;
      const Mat4 weight = (share * relation->estimate.covariance).inverse();
      const Vec4 error = pose_difference(relation->estimate.pose.vector(), predicted.vector());
      const std::array<Eigen::Index, 2> at{from, to};
      for (std::size_t r = 0; r < 2; ++r) {
        const auto rows = jacobian.middleCols<4>(4 * static_cast<Eigen::Index>(r));
        gradient.segment<4>(at[r]) += rows.transpose() * weight * error;
        for (std::size_t c = 0; c < 2; ++c) {
          information.block<4, 4>(at[r], at[c]) +=
              rows.transpose() * weight * jacobian.middleCols<4>(4 * static_cast<Eigen::Index>(c));
        }
      }
    }
    const VecX step = information.ldlt().solve(gradient);
    y += step;
    for (Eigen::Index at = 3; at < size; at += 4) y(at) = wrap_angle(y(at));
    if (step.norm() < 1e-9) break;
  }
  const MatX covariance = information.inverse();
  std::map<AgentId, PoseEstimate> fused;
  for (const auto& [peer, at] : block) {
    fused[peer] = {RelativePose::from(y.segment<4>(at)), covariance.block<4, 4>(at, at)};
  }
  return fused;
}

}  // namespace swarmloc::estimators::uwb
