#include "swarmloc/estimators/centralized/centralized_filter.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "centralized/filter_kernels.hpp"
#include "swarmloc/estimators/centralized/relabeling.hpp"

namespace swarmloc::estimators::centralized {
namespace {
// The disk-graph test (docs/algorithms.md §1.6): it waits for every pair in range to have been ranged, and a
// pair must be placed this far inside the radius, and this many of its distance's σ, to count.
constexpr int kGraphPatienceSteps = 10;
constexpr double kGraphMarginFraction = 0.05;
constexpr double kGraphFalseAlarm = 1e-4;

void check_centralized_setup(int dimension, const VecX& mean, std::size_t n, const std::vector<int>& labels) {
  if (static_cast<std::size_t>(mean.size()) != static_cast<std::size_t>(dimension) * n) {
    throw std::invalid_argument("centralized filter: initial_mean has " + std::to_string(mean.size()) +
                                " entries, expected " + std::to_string(dimension) + " × " +
                                std::to_string(n));
  }
  if (!labels.empty() && labels.size() != n) {
    throw std::invalid_argument("centralized filter: labels has " + std::to_string(labels.size()) +
                                " entries, expected " + std::to_string(n));
  }
  if (n == 0) throw std::invalid_argument("centralized filter: no agents");
}

template <int D>
MeasurementInformation assemble_dense_information(const CentralizedMeasurements& measurements,
                                                  const VecX& linearization_point,
                                                  const std::vector<int>& labels) {
  const int n = static_cast<int>(linearization_point.size());
  const std::vector<int> l = labels.empty() ? identity_labels(n / D) : labels;
  VecX x_internal(n);
  for (std::size_t a = 0; a < l.size(); ++a) {
    x_internal.segment<D>(D * l[a]) = linearization_point.segment<D>(D * static_cast<Eigen::Index>(a));
  }
  MeasurementInformation out{MatX::Zero(n, n), VecX()};
  // The measurements name original agents; map them through `l` inside assemble.
  out.vector = filter_kernels::assemble<D>(
      measurements, x_internal, l,
      [&](int bi, int bj, const filter_kernels::Mat<D>& block) {
        out.information.block<D, D>(D * bi, D * bj) += block;
        if (bi != bj) out.information.block<D, D>(D * bj, D * bi) += block.transpose();
      },
      filter_kernels::kKeepAllEdges);
  return out;
}

}  // namespace

MeasurementInformation assemble_measurement_information(const CentralizedMeasurements& measurements,
                                                        const VecX& linearization_point,
                                                        const std::vector<int>& labels) {
  return assemble_dense_information<2>(measurements, linearization_point, labels);
}

MeasurementInformation assemble_measurement_information_3d(const CentralizedMeasurements& measurements,
                                                           const VecX& linearization_point,
                                                           const std::vector<int>& labels) {
  return assemble_dense_information<3>(measurements, linearization_point, labels);
}

CentralizedFilter::CentralizedFilter(int dimension, const VecX& initial_mean, std::size_t agents,
                                     const CentralizedFilterParams& params)
    : labels_(params.labels), dimension_(dimension) {
  check_centralized_setup(dimension, initial_mean, agents, params.labels);
  if (labels_.empty()) labels_ = identity_labels(static_cast<int>(agents));
  (void)inverse_labels(labels_);  // validates the permutation
  x_.resize(initial_mean.size());
  for (int a = 0; a < num_agents(); ++a)
    x_.segment(index(a), dimension_) = initial_mean.segment(dimension_ * a, dimension_);
  self_checks_.resize(agents);
  off_graph_.assign(agents, 0);
}

bool CentralizedFilter::inconsistent(int agent) const {
  if (agent < 0 || agent >= num_agents()) return false;
  const auto a = static_cast<std::size_t>(agent);
  return self_checks_[a].inconsistent() || off_graph_[a] != 0;
}

VecX CentralizedFilter::mean() const {
  VecX out(x_.size());
  for (int a = 0; a < num_agents(); ++a)
    out.segment(dimension_ * a, dimension_) = x_.segment(index(a), dimension_);
  return out;
}

Vec2 CentralizedFilter::agent_mean(int agent) const { return x_.segment<2>(index(agent)); }

VecX CentralizedFilter::agent_mean_full(int agent) const { return x_.segment(index(agent), dimension_); }

template <int D>
CentralizedFilterOf<D>::CentralizedFilterOf(const VecX& initial_mean, const std::vector<Mat>& initial_cov,
                                            const CentralizedFilterParams& params)
    : CentralizedFilter(D, initial_mean, initial_cov.size(), params),
      initial_cov_(initial_cov),
      process_var_(params.process_var) {
  pending_velocity_ = VecX::Zero(initial_mean.size());
  if (!(params.disk_radius_m >= 0.0))
    throw std::invalid_argument("centralized filter: disk_radius_m must be >= 0");
  disk_radius_m_ = params.disk_radius_m;
  const std::size_t n = initial_cov.size();
  anchor_.assign(n, 0);
  if (disk_radius_m_ > 0.0) ranged_.assign(n * n, 0);
}

template <int D>
void CentralizedFilterOf<D>::check_innovations(const CentralizedMeasurements& measurements,
                                               const ProjectedVariance& projected_variance) {
  const int n = num_agents();
  for (const auto& edge : measurements.ranges) {
    if (edge.i < 0 || edge.i >= n || edge.j < 0 || edge.j >= n || edge.i == edge.j) continue;
    const int li = labels_[static_cast<std::size_t>(edge.i)];
    const int lj = labels_[static_cast<std::size_t>(edge.j)];
    const Vec delta = x_.template segment<D>(D * li) - x_.template segment<D>(D * lj);
    const double rho = delta.norm();
    if (rho < filter_kernels::kMinRange) continue;  // no direction (docs/algorithms.md §1.1)
    const double variance = measurements.range_var + projected_variance(li, lj, Vec(delta / rho));
    self_checks_[static_cast<std::size_t>(edge.i)].add(edge.range_m - rho, variance);
    self_checks_[static_cast<std::size_t>(edge.j)].add(edge.range_m - rho, variance);
    if (!ranged_.empty()) ranged_[pair_index(edge.i, edge.j)] = ranged_[pair_index(edge.j, edge.i)] = 1;
  }
  for (auto& check : self_checks_) check.end_step();
  for (const auto& [agent, fix] : measurements.beacon_fixes) {
    if (agent >= 0 && agent < n) anchor_[static_cast<std::size_t>(agent)] = 1;
  }
  if (!measurements.ranges.empty()) ++ranged_steps_;
  check_graph(projected_variance);
}

template <int D>
void CentralizedFilterOf<D>::check_graph(const ProjectedVariance& projected_variance) {
  std::fill(off_graph_.begin(), off_graph_.end(), 0);
  if (ranged_.empty() || ranged_steps_ < kGraphPatienceSteps) return;
  const double floor_m = kGraphMarginFraction * disk_radius_m_;
  const double sigmas = standard_normal_upper_quantile(kGraphFalseAlarm);
  const int n = num_agents();
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      const auto ai = static_cast<std::size_t>(i);
      const auto aj = static_cast<std::size_t>(j);
      if (ranged_[pair_index(i, j)] != 0 || (anchor_[ai] != 0 && anchor_[aj] != 0)) continue;
      const int li = labels_[ai];
      const int lj = labels_[aj];
      const Vec delta = x_.template segment<D>(D * li) - x_.template segment<D>(D * lj);
      const double inside_m = disk_radius_m_ - delta.norm();
      if (inside_m <= floor_m) continue;
      const Vec u = delta.norm() > filter_kernels::kMinRange ? Vec(delta.normalized()) : Vec(Vec::UnitX());
      const double spread_m = std::sqrt(std::max(0.0, projected_variance(li, lj, u)));
      if (!(inside_m > sigmas * spread_m)) continue;
      // Never ranged, yet placed well within range: one of the two is wrong (a flip or fold that fits
      // every range it has). Both are flagged, as the residual test flags both ends of a bad edge.
      if (anchor_[ai] == 0) off_graph_[ai] = 1;
      if (anchor_[aj] == 0) off_graph_[aj] = 1;
    }
  }
}

template <int D>
bool CentralizedFilterOf<D>::predict_mean() {
  if (steps_done_ == 0) return false;
  x_ += pending_velocity_;  // (12): x̂_{k}⁻ = x̂_{k−1}⁺ + v(k−1)
  return true;
}

template <int D>
void CentralizedFilterOf<D>::store_velocity(const CentralizedMeasurements& measurements) {
  pending_velocity_.setZero();
  if (!measurements.velocity_inputs.empty()) {
    if (static_cast<int>(measurements.velocity_inputs.size()) != num_agents()) {
      throw std::invalid_argument("centralized measurements: velocity_inputs has " +
                                  std::to_string(measurements.velocity_inputs.size()) +
                                  " entries, expected " + std::to_string(num_agents()));
    }
    // The input is planar: in 3-D it moves x and y, and z stays (docs/algorithms.md §2.1 in D).
    for (int a = 0; a < num_agents(); ++a) {
      pending_velocity_.segment<2>(index(a)) = measurements.velocity_inputs[static_cast<std::size_t>(a)];
    }
  }
  ++steps_done_;
}

template class CentralizedFilterOf<2>;
template class CentralizedFilterOf<3>;

namespace {

/// The filter of `kind` in D dimensions (both factories below).
template <int D>
std::unique_ptr<CentralizedFilter> make_filter_of(CentralizedKind kind, const VecX& initial_mean,
                                                  const std::vector<filter_kernels::Mat<D>>& initial_cov,
                                                  const CentralizedFilterParams& params) {
  switch (kind) {
    case CentralizedKind::kEkf:
      return filter_kernels::make_ekf<D>(initial_mean, initial_cov, params);
    case CentralizedKind::kLbEkf:
      return filter_kernels::make_lb_ekf<D>(initial_mean, initial_cov, params);
    case CentralizedKind::kLbEkfI:
      return filter_kernels::make_lb_ekf_i<D>(initial_mean, initial_cov, params);
  }
  throw std::invalid_argument("make_centralized_filter: unknown kind");
}

}  // namespace

std::unique_ptr<CentralizedFilter> make_centralized_filter(CentralizedKind kind, const VecX& initial_mean,
                                                           const std::vector<Mat2>& initial_cov,
                                                           const CentralizedFilterParams& params) {
  return make_filter_of<2>(kind, initial_mean, initial_cov, params);
}

std::unique_ptr<CentralizedFilter> make_centralized_filter_3d(CentralizedKind kind, const VecX& initial_mean,
                                                              const std::vector<Mat3>& initial_cov,
                                                              const CentralizedFilterParams& params) {
  return make_filter_of<3>(kind, initial_mean, initial_cov, params);
}

std::string_view to_string(CentralizedKind kind) {
  switch (kind) {
    case CentralizedKind::kEkf:
      return "ekf";
    case CentralizedKind::kLbEkf:
      return "lb-ekf";
    case CentralizedKind::kLbEkfI:
      return "lb-ekf-i";
  }
  return "unknown";
}

}  // namespace swarmloc::estimators::centralized
