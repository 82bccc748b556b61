// Centralized EKF / LB-EKF / LB-EKF-I (Khan et al. eqs. (10)–(12), Alg. 2; docs/algorithms.md §2.1–§2.4) and
// the posterior CRB recursion (§1.3).
#include <gtest/gtest.h>

#include <Eigen/LU>
#include <algorithm>
#include <random>

#include "eigen_gtest.hpp"
#include "swarmloc/estimators/centralized/centralized_filter.hpp"
#include "swarmloc/estimators/centralized/posterior_crb.hpp"
#include "swarmloc/estimators/centralized/relabeling.hpp"

namespace swarmloc::estimators::centralized {
namespace {

struct Scenario {
  std::vector<Vec2> truth;
  VecX initial_mean;
  std::vector<Mat2> initial_cov;
  std::vector<CentralizedMeasurements> steps;
};

// A small random network with beacons, ranges and velocity inputs.
Scenario make_scenario(int agents, int steps, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 20.0);
  std::normal_distribution<double> g(0.0, 1.0);
  Scenario s;
  for (int a = 0; a < agents; ++a) s.truth.emplace_back(u(rng), u(rng));
  s.initial_mean.resize(2 * agents);
  for (int a = 0; a < agents; ++a) {
    s.initial_mean.segment<2>(2 * a) = s.truth[static_cast<std::size_t>(a)] + Vec2(g(rng), g(rng));
    s.initial_cov.push_back(Mat2::Identity() * (1.0 + 0.1 * a));
  }
  const auto edges = disk_graph_edges(s.truth, 12.0);
  for (int k = 0; k < steps; ++k) {
    CentralizedMeasurements m;
    m.beacon_var = 2.0;
    m.range_var = 0.5;
    for (int b = 0; b < agents; b += 3) {
      m.beacon_fixes.emplace_back(b, s.truth[static_cast<std::size_t>(b)] + Vec2(g(rng), g(rng)));
    }
    for (const auto& [i, j] : edges) {
      const double rho = (s.truth[static_cast<std::size_t>(i)] - s.truth[static_cast<std::size_t>(j)]).norm();
      m.ranges.push_back({i, j, rho + 0.3 * g(rng)});
    }
    for (int a = 0; a < agents; ++a) m.velocity_inputs.emplace_back(0.1 * g(rng), 0.1 * g(rng));
    s.steps.push_back(m);
  }
  return s;
}

std::vector<int> random_labels(int agents, std::uint64_t seed) {
  std::vector<int> labels = identity_labels(agents);
  std::mt19937_64 rng(seed);
  std::shuffle(labels.begin(), labels.end(), rng);
  return labels;
}

TEST(CentralizedFilter, AssemblyMatchesExplicitJacobian) {
  const Scenario s = make_scenario(7, 1, 11);
  const CentralizedMeasurements& m = s.steps[0];
  const VecX x = s.initial_mean;
  // Explicit H by central differences of h(x) and R = blkdiag(σ_q I, σ_r I) (eqs. (6)–(8)).
  const auto h = [&](const VecX& p) {
    VecX out(static_cast<Eigen::Index>(2 * m.beacon_fixes.size() + m.ranges.size()));
    Eigen::Index row = 0;
    for (const auto& [b, fix] : m.beacon_fixes) {
      out.segment<2>(row) = p.segment<2>(2 * b);
      row += 2;
    }
    for (const auto& e : m.ranges) out(row++) = (p.segment<2>(2 * e.i) - p.segment<2>(2 * e.j)).norm();
    return out;
  };
  VecX y(h(x).size());
  Eigen::Index row = 0;
  for (const auto& [b, fix] : m.beacon_fixes) {
    y.segment<2>(row) = fix;
    row += 2;
  }
  for (const auto& e : m.ranges) y(row++) = e.range_m;
  MatX H(y.size(), x.size());
  for (Eigen::Index c = 0; c < x.size(); ++c) {
    VecX xp = x, xm = x;
    xp(c) += 1e-6;
    xm(c) -= 1e-6;
    H.col(c) = (h(xp) - h(xm)) / 2e-6;
  }
  VecX r_inv(y.size());
  r_inv.head(2 * static_cast<Eigen::Index>(m.beacon_fixes.size())).setConstant(1.0 / m.beacon_var);
  r_inv.tail(static_cast<Eigen::Index>(m.ranges.size())).setConstant(1.0 / m.range_var);
  const MatX S = H.transpose() * r_inv.asDiagonal() * H;
  const VecX b = H.transpose() * r_inv.asDiagonal() * (y - h(x));
  const MeasurementInformation info = assemble_measurement_information(m, x, {});
  EXPECT_MATRIX_NEAR(info.information, S, 1e-6);
  EXPECT_MATRIX_NEAR(info.vector, b, 1e-6);

  // Relabeled assembly is the permuted one.
  const std::vector<int> labels = random_labels(7, 3);
  const MeasurementInformation relabeled = assemble_measurement_information(m, x, labels);
  for (int a = 0; a < 7; ++a) {
    for (int c = 0; c < 7; ++c) {
      EXPECT_MATRIX_NEAR(relabeled.information.block(2 * labels[a], 2 * labels[c], 2, 2),
                         S.block(2 * a, 2 * c, 2, 2), 1e-6);
    }
  }
}

// Variances are variances: one beacon fix on one agent is a scalar Kalman update per coordinate.
TEST(CentralizedFilter, BeaconOnlyUpdateUsesVariancesUnsquared) {
  for (auto kind : {CentralizedKind::kEkf, CentralizedKind::kLbEkf, CentralizedKind::kLbEkfI}) {
    CentralizedFilterParams params;
    params.process_var = 0.5;
    params.bandwidth = 1;
    const auto filter = make_centralized_filter(kind, VecX::Zero(2), {Mat2::Identity() * 4.0}, params);
    CentralizedMeasurements m;
    m.beacon_var = 2.0;
    m.beacon_fixes.emplace_back(0, Vec2(3.0, -6.0));
    filter->step(m);
    // M = (1/4 + 1/2)⁻¹ = 4/3; x = 0 + M · y / 2.
    EXPECT_MATRIX_NEAR(filter->covariance_block(0), Mat2::Identity() * (4.0 / 3.0), 1e-12) << to_string(kind);
    EXPECT_MATRIX_NEAR(filter->mean(), Vec2(2.0, -4.0), 1e-12);
    filter->step(CentralizedMeasurements{});  // prediction only: P = M + σ_p
    EXPECT_MATRIX_NEAR(filter->covariance_block(0), Mat2::Identity() * (4.0 / 3.0 + 0.5), 1e-12);
  }
}

TEST(CentralizedFilter, VelocityInputIsAppliedAtTheNextStep) {
  const auto filter = make_centralized_filter(CentralizedKind::kEkf, Vec2(1.0, 1.0), {Mat2::Identity()}, {});
  CentralizedMeasurements m;
  m.velocity_inputs = {Vec2(0.5, -0.25)};
  filter->step(m);
  EXPECT_MATRIX_NEAR(filter->mean(), Vec2(1.0, 1.0), 0.0);
  filter->step(CentralizedMeasurements{});
  EXPECT_MATRIX_NEAR(filter->mean(), Vec2(1.5, 0.75), 1e-15);
}

TEST(CentralizedFilter, EkfIsInvariantToRelabeling) {
  const Scenario s = make_scenario(9, 5, 21);
  CentralizedFilterParams plain;
  CentralizedFilterParams relabeled;
  relabeled.labels = random_labels(9, 4);
  const auto a = make_centralized_filter(CentralizedKind::kEkf, s.initial_mean, s.initial_cov, plain);
  const auto b = make_centralized_filter(CentralizedKind::kEkf, s.initial_mean, s.initial_cov, relabeled);
  for (const auto& m : s.steps) {
    a->step(m);
    b->step(m);
  }
  EXPECT_MATRIX_NEAR(a->mean(), b->mean(), 1e-10);
  EXPECT_MATRIX_NEAR(a->covariance_dense(), b->covariance_dense(), 1e-10);
}

// docs/algorithms.md §2.4: both banded filters reduce to the EKF at L = n − 1.
TEST(CentralizedFilter, BandedFiltersWithFullBandwidthEqualTheEkf) {
  const int agents = 10;
  const Scenario s = make_scenario(agents, 8, 31);
  CentralizedFilterParams params;
  params.process_var = 0.05;
  params.labels = random_labels(agents, 5);
  params.bandwidth = 2 * agents - 1;
  const auto ekf = make_centralized_filter(CentralizedKind::kEkf, s.initial_mean, s.initial_cov, params);
  for (const auto& m : s.steps) ekf->step(m);
  for (auto kind : {CentralizedKind::kLbEkf, CentralizedKind::kLbEkfI}) {
    for (auto method : {BandInversionMethod::kWindows, BandInversionMethod::kSlidingCholesky}) {
      params.inversion = method;
      const auto banded = make_centralized_filter(kind, s.initial_mean, s.initial_cov, params);
      for (const auto& m : s.steps) banded->step(m);
      EXPECT_MATRIX_NEAR(banded->mean(), ekf->mean(), 1e-8) << to_string(kind);
      EXPECT_MATRIX_NEAR(banded->covariance_dense(), ekf->covariance_dense(), 1e-8) << to_string(kind);
      for (int a = 0; a < agents; ++a) {
        EXPECT_MATRIX_NEAR(banded->covariance_block(a), ekf->covariance_block(a), 1e-8);
      }
      EXPECT_EQ(banded->last_truncated_entries(), 0);
    }
  }
}

TEST(CentralizedFilter, BandedFiltersAgreeAcrossInversionMethods) {
  const int agents = 12;
  const Scenario s = make_scenario(agents, 6, 41);
  CentralizedFilterParams params;
  params.bandwidth = 5;
  for (auto kind : {CentralizedKind::kLbEkf, CentralizedKind::kLbEkfI}) {
    params.inversion = BandInversionMethod::kWindows;
    const auto windows = make_centralized_filter(kind, s.initial_mean, s.initial_cov, params);
    params.inversion = BandInversionMethod::kSlidingCholesky;
    const auto sliding = make_centralized_filter(kind, s.initial_mean, s.initial_cov, params);
    for (const auto& m : s.steps) {
      windows->step(m);
      sliding->step(m);
    }
    EXPECT_MATRIX_NEAR(windows->mean(), sliding->mean(), 1e-9) << to_string(kind);
    EXPECT_MATRIX_NEAR(windows->covariance_dense(), sliding->covariance_dense(), 1e-9) << to_string(kind);
  }
}

TEST(CentralizedFilter, ReportsMeasurementBandwidthAndTruncation) {
  const int agents = 12;
  const Scenario s = make_scenario(agents, 4, 51);
  const auto edges = disk_graph_edges(s.truth, 12.0);
  const int expected = measurement_bandwidth(graph_bandwidth(edges, identity_labels(agents)));
  CentralizedFilterParams params;
  params.bandwidth = 4;
  for (auto kind : {CentralizedKind::kLbEkf, CentralizedKind::kLbEkfI}) {
    const auto filter = make_centralized_filter(kind, s.initial_mean, s.initial_cov, params);
    for (const auto& m : s.steps) {
      filter->step(m);  // LB-EKF-I: Y_k stays PD despite the truncation
      EXPECT_EQ(filter->last_measurement_bandwidth(), expected) << to_string(kind);
      EXPECT_GT(filter->last_truncated_entries(), 0);
    }
    EXPECT_TRUE(filter->mean().allFinite());
  }
}

TEST(CentralizedFilter, RejectsInconsistentSetup) {
  EXPECT_THROW(make_centralized_filter(CentralizedKind::kEkf, VecX::Zero(3), {Mat2::Identity()}, {}),
               std::invalid_argument);
  CentralizedFilterParams params;
  params.labels = {0, 0};
  EXPECT_THROW(make_centralized_filter(CentralizedKind::kLbEkf, VecX::Zero(4),
                                       {Mat2::Identity(), Mat2::Identity()}, params),
               std::invalid_argument);
}

// §1.3: with σ_p = 0 and a static network, J_t = J_prior + t·J_1.
TEST(PosteriorCrb, StaticNetworkAccumulatesInformationLinearly) {
  const Scenario s = make_scenario(6, 4, 61);
  VecX truth(12);
  for (int a = 0; a < 6; ++a) truth.segment<2>(2 * a) = s.truth[static_cast<std::size_t>(a)];
  PosteriorCrb crb(s.initial_cov, 0.0);
  const MatX j1 = assemble_measurement_information(s.steps[0], truth, {}).information;
  MatX prior = MatX::Zero(12, 12);
  for (int a = 0; a < 6; ++a)
    prior.block<2, 2>(2 * a, 2 * a) = s.initial_cov[static_cast<std::size_t>(a)].inverse();
  for (int t = 1; t <= 4; ++t) {
    crb.step(s.steps[0], truth);
    EXPECT_MATRIX_NEAR(crb.information(), prior + t * j1, 1e-9);
  }
  const MatX bound = (prior + 4 * j1).inverse();
  EXPECT_NEAR(crb.total_bound(), bound.trace(), 1e-9);
  EXPECT_MATRIX_NEAR(crb.agent_bound(2), bound.block(4, 4, 2, 2), 1e-9);
}

// The EKF covariance linearized at the truth equals the posterior CRB recursion.
TEST(PosteriorCrb, MatchesEkfCovarianceWhenLinearizedAtTruth) {
  const Scenario s = make_scenario(6, 3, 71);
  VecX truth(12);
  for (int a = 0; a < 6; ++a) truth.segment<2>(2 * a) = s.truth[static_cast<std::size_t>(a)];
  CentralizedFilterParams params;
  params.process_var = 0.1;
  const auto ekf = make_centralized_filter(CentralizedKind::kEkf, truth, s.initial_cov, params);
  PosteriorCrb crb(s.initial_cov, 0.1);
  for (CentralizedMeasurements m : s.steps) {
    m.velocity_inputs.clear();
    for (auto& e : m.ranges) e.range_m = (truth.segment<2>(2 * e.i) - truth.segment<2>(2 * e.j)).norm();
    for (auto& [b, fix] : m.beacon_fixes) fix = truth.segment<2>(2 * b);
    ekf->step(m);  // zero residuals keep the estimate at the truth
    crb.step(m, truth);
    EXPECT_MATRIX_NEAR(ekf->covariance_dense(), crb.bound(), 1e-9);
  }
}

}  // namespace
}  // namespace swarmloc::estimators::centralized
