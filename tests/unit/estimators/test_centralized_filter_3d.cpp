// The centralized EKF / LB-EKF / LB-EKF-I in 3-D (Khan et al. eqs. (10)–(12), Alg. 2; docs/algorithms.md
// §2.1–§2.4 with D = 3 coordinates per agent): the Jacobian in space, the filter against an independent dense
// information recursion and the truth, the banded filters against the EKF, and the z of a beacon fix.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <random>

#include "eigen_gtest.hpp"
#include "swarmloc/estimators/centralized/centralized_filter.hpp"
#include "swarmloc/estimators/centralized/relabeling.hpp"

namespace swarmloc::estimators::centralized::filter_3d_test {
namespace {

constexpr int kAgents = 10;
constexpr int kAnchors = 4;
constexpr double kRadiusM = 12.0;
constexpr int kMinNeighbours = 4;
constexpr double kRangeStdM = 0.1;
constexpr double kBeaconVar = 1e-6;
constexpr double kInitialStdM = 0.5;

// A static 3-D network: 10 agents in a 20 m × 20 m × 8 m box, the first 4 with beacon fixes (and their z),
// every pair within 12 m ranged, one set of draws per step from a seeded generator.
struct Network3d {
  std::vector<Vec3> truth;
  VecX initial_mean;
  std::vector<Mat3> initial_cov;
  std::vector<std::pair<int, int>> edges;
  std::vector<CentralizedMeasurements> steps;
};

Network3d make_network_3d(int steps, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> planar(0.0, 20.0);
  std::uniform_real_distribution<double> height(0.0, 8.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  Network3d net;
  // Placements are drawn until every agent has kMinNeighbours ranges: in space an agent with two is free to
  // turn on a circle, and the test is about the filter, not about an unobservable network.
  std::vector<int> degree;
  while (degree.empty() || *std::min_element(degree.begin(), degree.end()) < kMinNeighbours) {
    net.truth.clear();
    net.edges.clear();
    degree.assign(kAgents, 0);
    for (int a = 0; a < kAgents; ++a) net.truth.emplace_back(planar(rng), planar(rng), height(rng));
    for (int i = 0; i < kAgents; ++i) {
      for (int j = i + 1; j < kAgents; ++j) {
        if ((net.truth[static_cast<std::size_t>(i)] - net.truth[static_cast<std::size_t>(j)]).norm() >
            kRadiusM)
          continue;
        net.edges.emplace_back(i, j);
        ++degree[static_cast<std::size_t>(i)];
        ++degree[static_cast<std::size_t>(j)];
      }
    }
  }
  net.initial_mean.resize(3 * kAgents);
  for (int a = 0; a < kAgents; ++a) {
    net.initial_mean.segment<3>(3 * a) =
        net.truth[static_cast<std::size_t>(a)] + kInitialStdM * Vec3(gauss(rng), gauss(rng), gauss(rng));
    net.initial_cov.push_back(Mat3::Identity() * (kInitialStdM * kInitialStdM));
  }
  for (int k = 0; k < steps; ++k) {
    CentralizedMeasurements m;
    m.beacon_var = kBeaconVar;
    m.range_var = kRangeStdM * kRangeStdM;
    for (int b = 0; b < kAnchors; ++b) {
      const Vec3 fix = net.truth[static_cast<std::size_t>(b)] +
                       std::sqrt(kBeaconVar) * Vec3(gauss(rng), gauss(rng), gauss(rng));
      m.beacon_fixes.emplace_back(b, fix.head<2>());
      m.beacon_fix_z.push_back(fix.z());
    }
    for (const auto& [i, j] : net.edges) {
      const double rho =
          (net.truth[static_cast<std::size_t>(i)] - net.truth[static_cast<std::size_t>(j)]).norm();
      m.ranges.push_back({i, j, rho + kRangeStdM * gauss(rng)});
    }
    net.steps.push_back(m);
  }
  return net;
}

// S = HᵀR⁻¹H and b = HᵀR⁻¹(y − h(x)) from the range model written out here, in original labels.
MeasurementInformation dense_information_3d(const CentralizedMeasurements& m, const VecX& x) {
  MeasurementInformation out{MatX::Zero(x.size(), x.size()), VecX::Zero(x.size())};
  for (std::size_t f = 0; f < m.beacon_fixes.size(); ++f) {
    const int a = m.beacon_fixes[f].first;
    const Vec3 y(m.beacon_fixes[f].second.x(), m.beacon_fixes[f].second.y(), m.beacon_fix_z[f]);
    out.information.block<3, 3>(3 * a, 3 * a) += Mat3::Identity() / m.beacon_var;
    out.vector.segment<3>(3 * a) += (y - x.segment<3>(3 * a)) / m.beacon_var;
  }
  for (const auto& e : m.ranges) {
    const Vec3 delta = x.segment<3>(3 * e.i) - x.segment<3>(3 * e.j);
    VecX h_row = VecX::Zero(x.size());  // ∂‖x_i − x_j‖/∂x
    h_row.segment<3>(3 * e.i) = delta.normalized();
    h_row.segment<3>(3 * e.j) = -delta.normalized();
    out.information += h_row * h_row.transpose() / m.range_var;
    out.vector += h_row * (e.range_m - delta.norm()) / m.range_var;
  }
  return out;
}

std::vector<int> shuffled_labels_3d(int agents, std::uint32_t seed) {
  std::vector<int> labels = identity_labels(agents);
  std::mt19937 rng(seed);
  std::shuffle(labels.begin(), labels.end(), rng);
  return labels;
}

// Smallest eigenvalue over largest, after checking symmetry to `tolerance` of the largest entry.
double min_eigen_ratio_3d(const MatX& m, double tolerance) {
  const double scale = m.cwiseAbs().maxCoeff();
  EXPECT_LE((m - m.transpose()).cwiseAbs().maxCoeff(), tolerance * scale);
  const Eigen::SelfAdjointEigenSolver<MatX> eigen(0.5 * (m + m.transpose()), Eigen::EigenvaluesOnly);
  return eigen.eigenvalues().minCoeff() / eigen.eigenvalues().maxCoeff();
}

TEST(CentralizedFilter3d, AssemblyMatchesFiniteDifferencesOfTheRangeModel) {
  const Network3d net = make_network_3d(1, 7);
  CentralizedMeasurements m = net.steps[0];
  m.beacon_var = 2.0;  // central differences of the beacons' rows would lose digits against 1/1e−6
  const VecX& x = net.initial_mean;
  // h(x): the beacons' three coordinates, then the ranges ‖x_i − x_j‖ in space.
  const auto h = [&](const VecX& p) {
    VecX out(static_cast<Eigen::Index>(3 * m.beacon_fixes.size() + m.ranges.size()));
    Eigen::Index row = 0;
    for (const auto& [b, fix] : m.beacon_fixes) {
      out.segment<3>(row) = p.segment<3>(3 * b);
      row += 3;
    }
    for (const auto& e : m.ranges) out(row++) = (p.segment<3>(3 * e.i) - p.segment<3>(3 * e.j)).norm();
    return out;
  };
  VecX y(h(x).size());
  Eigen::Index row = 0;
  for (std::size_t f = 0; f < m.beacon_fixes.size(); ++f) {
    y.segment<3>(row) = Vec3(m.beacon_fixes[f].second.x(), m.beacon_fixes[f].second.y(), m.beacon_fix_z[f]);
    row += 3;
  }
  for (const auto& e : m.ranges) y(row++) = e.range_m;
  MatX jacobian(y.size(), x.size());
  for (Eigen::Index c = 0; c < x.size(); ++c) {
    VecX xp = x;
    VecX xm = x;
    xp(c) += 1e-6;
    xm(c) -= 1e-6;
    jacobian.col(c) = (h(xp) - h(xm)) / 2e-6;
  }
  VecX r_inv(y.size());
  r_inv.head(3 * static_cast<Eigen::Index>(m.beacon_fixes.size())).setConstant(1.0 / m.beacon_var);
  r_inv.tail(static_cast<Eigen::Index>(m.ranges.size())).setConstant(1.0 / m.range_var);
  const MatX s = jacobian.transpose() * r_inv.asDiagonal() * jacobian;
  const VecX b = jacobian.transpose() * r_inv.asDiagonal() * (y - h(x));
  const MeasurementInformation info = assemble_measurement_information_3d(m, x, {});
  ASSERT_EQ(info.information.rows(), 3 * kAgents);
  EXPECT_MATRIX_NEAR(info.information, s, 1e-5);
  EXPECT_MATRIX_NEAR(info.vector, b, 1e-5);

  const std::vector<int> labels = shuffled_labels_3d(kAgents, 3);
  const MeasurementInformation relabeled = assemble_measurement_information_3d(m, x, labels);
  for (int a = 0; a < kAgents; ++a) {
    EXPECT_MATRIX_NEAR(relabeled.vector.segment<3>(3 * labels[static_cast<std::size_t>(a)]),
                       info.vector.segment<3>(3 * a), 1e-9);
    for (int c = 0; c < kAgents; ++c) {
      EXPECT_MATRIX_NEAR(relabeled.information.block(3 * labels[static_cast<std::size_t>(a)],
                                                     3 * labels[static_cast<std::size_t>(c)], 3, 3),
                         info.information.block(3 * a, 3 * c, 3, 3), 1e-9);
    }
  }
}

// With σ_p = 0 and a static network the EKF is the information recursion J_k = J_{k−1} + S_k(x̂_{k−1}),
// x̂_k = x̂_{k−1} + J_k⁻¹ b_k(x̂_{k−1}) from J_0 = Σ_0⁻¹: recomputed here densely from the range model.
TEST(CentralizedFilter3d, EkfIsTheDenseInformationRecursionAndFindsTheTruthInSpace) {
  constexpr int kSteps = 100;
  const Network3d net = make_network_3d(kSteps, 11);
  CentralizedFilterParams params;
  params.process_var = 0.0;
  params.labels = shuffled_labels_3d(kAgents, 5);
  const auto ekf =
      make_centralized_filter_3d(CentralizedKind::kEkf, net.initial_mean, net.initial_cov, params);
  ASSERT_EQ(ekf->dimension(), 3);
  MatX information = MatX::Zero(3 * kAgents, 3 * kAgents);
  for (int a = 0; a < kAgents; ++a)
    information.block<3, 3>(3 * a, 3 * a) = net.initial_cov[static_cast<std::size_t>(a)].inverse();
  VecX x = net.initial_mean;
  for (const auto& m : net.steps) {
    const MeasurementInformation step = dense_information_3d(m, x);
    information += step.information;
    x += information.ldlt().solve(step.vector);
    ekf->step(m);
  }
  const MatX covariance = information.inverse();
  ASSERT_EQ(ekf->mean().size(), 3 * kAgents);
  EXPECT_MATRIX_NEAR(ekf->mean(), x, 1e-9);
  EXPECT_MATRIX_NEAR(ekf->covariance_dense(), covariance, 1e-9 * covariance.cwiseAbs().maxCoeff());
  EXPECT_GT(min_eigen_ratio_3d(ekf->covariance_dense(), 1e-12), 0.0);
  double squared_error = 0.0;
  for (int a = 0; a < kAgents; ++a) {
    const Mat3 block = ekf->covariance_block_full(a);
    EXPECT_MATRIX_NEAR(block, covariance.block(3 * a, 3 * a, 3, 3), 1e-9 * covariance.cwiseAbs().maxCoeff());
    EXPECT_MATRIX_NEAR(ekf->covariance_block(a), block.topLeftCorner(2, 2), 0.0);
    const Vec3 mean = ekf->agent_mean_full(a);
    EXPECT_MATRIX_NEAR(ekf->agent_mean(a), mean.head<2>(), 0.0);
    const Vec3 error = mean - net.truth[static_cast<std::size_t>(a)];
    squared_error += error.squaredNorm();
    for (int c = 0; c < 3; ++c) EXPECT_LE(std::abs(error(c)), 4.0 * std::sqrt(block(c, c))) << a << " " << c;
  }
  const double rms_m = std::sqrt(squared_error / kAgents);
  EXPECT_LT(rms_m, 0.05);
  RecordProperty("rms_error_m", std::to_string(rms_m));
}

// docs/algorithms.md §2.4: both banded filters are the EKF when the band holds every block (L = 3N − 1).
TEST(CentralizedFilter3d, BandedFiltersWithFullBandwidthEqualTheEkf) {
  const Network3d net = make_network_3d(20, 13);
  CentralizedFilterParams params;
  params.process_var = 0.01;
  params.labels = shuffled_labels_3d(kAgents, 9);
  params.bandwidth = 3 * kAgents - 1;
  const auto ekf =
      make_centralized_filter_3d(CentralizedKind::kEkf, net.initial_mean, net.initial_cov, params);
  for (const auto& m : net.steps) ekf->step(m);
  const double scale = ekf->covariance_dense().cwiseAbs().maxCoeff();
  for (auto kind : {CentralizedKind::kLbEkf, CentralizedKind::kLbEkfI}) {
    for (auto method : {BandInversionMethod::kWindows, BandInversionMethod::kSlidingCholesky}) {
      params.inversion = method;
      const auto banded = make_centralized_filter_3d(kind, net.initial_mean, net.initial_cov, params);
      for (const auto& m : net.steps) banded->step(m);
      EXPECT_MATRIX_NEAR(banded->mean(), ekf->mean(), 1e-9) << to_string(kind);
      EXPECT_MATRIX_NEAR(banded->covariance_dense(), ekf->covariance_dense(), 1e-9 * scale)
          << to_string(kind);
      for (int a = 0; a < kAgents; ++a) {
        EXPECT_MATRIX_NEAR(banded->covariance_block_full(a), ekf->covariance_block_full(a), 1e-9 * scale);
      }
      EXPECT_EQ(banded->last_truncated_entries(), 0) << to_string(kind);
    }
  }
}

// A band narrower than the measurements' (L = 4 against ~20 here): information is dropped, but the mean
// stays finite and every covariance the filters report stays symmetric PSD.
TEST(CentralizedFilter3d, BandedFiltersWithASmallBandwidthStayFiniteAndPsd) {
  const Network3d net = make_network_3d(20, 17);
  CentralizedFilterParams params;
  params.process_var = 0.01;
  params.bandwidth = 4;
  for (auto kind : {CentralizedKind::kLbEkf, CentralizedKind::kLbEkfI}) {
    const auto filter = make_centralized_filter_3d(kind, net.initial_mean, net.initial_cov, params);
    for (const auto& m : net.steps) {
      filter->step(m);
      EXPECT_GT(filter->last_truncated_entries(), 0) << to_string(kind);
    }
    EXPECT_TRUE(filter->mean().allFinite()) << to_string(kind);
    for (int a = 0; a < kAgents; ++a) {
      const MatX block = filter->covariance_block_full(a);
      ASSERT_EQ(block.rows(), 3);
      EXPECT_TRUE(block.allFinite());
      EXPECT_GT(min_eigen_ratio_3d(block, 1e-12), 0.0) << to_string(kind) << " agent " << a;
    }
    if (kind == CentralizedKind::kLbEkfI) {  // Y_k⁻¹: the whole matrix is PD
      EXPECT_GT(min_eigen_ratio_3d(filter->covariance_dense(), 1e-9), 0.0);
    }
  }
}

// One beacon fix in 3-D is a scalar Kalman update per coordinate, z included; the velocity moves x, y only.
// Agent 1 has no measurement: it keeps its prior and moves by its own input.
TEST(CentralizedFilter3d, BeaconFixInformsZAndVelocityMovesThePlane) {
  for (auto kind : {CentralizedKind::kEkf, CentralizedKind::kLbEkf, CentralizedKind::kLbEkfI}) {
    CentralizedFilterParams params;
    params.process_var = 0.5;
    params.bandwidth = 2;
    const auto filter =
        make_centralized_filter_3d(kind, VecX::Zero(6), {Mat3::Identity() * 4.0, Mat3::Identity()}, params);
    CentralizedMeasurements m;
    m.beacon_var = 2.0;
    m.beacon_fixes.emplace_back(0, Vec2(3.0, -6.0));
    m.beacon_fix_z.push_back(9.0);
    m.velocity_inputs = {Vec2(0.5, -0.25), Vec2(1.0, 2.0)};
    filter->step(m);
    // M = (1/4 + 1/2)⁻¹ = 4/3 on every axis; x = M · y / 2.
    EXPECT_MATRIX_NEAR(filter->covariance_block_full(0), MatX(Mat3::Identity() * (4.0 / 3.0)), 1e-12)
        << to_string(kind);
    VecX expected(6);
    expected << 2.0, -4.0, 6.0, 0.0, 0.0, 0.0;
    EXPECT_MATRIX_NEAR(filter->mean(), expected, 1e-12) << to_string(kind);
    filter->step(CentralizedMeasurements{});  // prediction only
    expected << 2.5, -4.25, 6.0, 1.0, 2.0, 0.0;
    EXPECT_MATRIX_NEAR(filter->mean(), expected, 1e-12) << to_string(kind);
    EXPECT_MATRIX_NEAR(filter->covariance_block_full(0), MatX(Mat3::Identity() * (4.0 / 3.0 + 0.5)), 1e-12);
    EXPECT_MATRIX_NEAR(filter->covariance_block_full(1), MatX(Mat3::Identity() * 1.5), 1e-12);

    CentralizedMeasurements no_z = m;  // a 3-D fix needs its z
    no_z.beacon_fix_z.clear();
    EXPECT_THROW(filter->step(no_z), std::invalid_argument) << to_string(kind);
  }
}

TEST(CentralizedFilter3d, RejectsAMeanOfTheWrongDimension) {
  EXPECT_THROW(make_centralized_filter_3d(CentralizedKind::kEkf, VecX::Zero(2), {Mat3::Identity()}, {}),
               std::invalid_argument);
  EXPECT_EQ(
      make_centralized_filter(CentralizedKind::kEkf, VecX::Zero(2), {Mat2::Identity()}, {})->dimension(), 2);
}

}  // namespace
}  // namespace swarmloc::estimators::centralized::filter_3d_test
