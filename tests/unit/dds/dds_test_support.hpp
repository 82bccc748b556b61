#pragma once
// Shared helpers for the DDS tests: sample messages with every field set and exact comparisons.
#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <thread>

#include "eigen_gtest.hpp"
#include "swarmloc/dds/transport.hpp"

namespace swarmloc::dds::test {

inline runtime::Header make_header(AgentId agent, std::uint32_t seq) {
  runtime::Header header;
  header.agent_id = agent;
  header.seq = seq;
  header.step = 1000 + seq;
  header.sender_stamp_ns = -123'456'789'012LL + seq;  // skewed clocks can be negative
  header.world_stamp_ns = 9'876'543'210LL + seq;
  return header;
}

inline void expect_header_eq(const runtime::Header& actual, const runtime::Header& expected) {
  EXPECT_EQ(actual.agent_id, expected.agent_id);
  EXPECT_EQ(actual.seq, expected.seq);
  EXPECT_EQ(actual.step, expected.step);
  EXPECT_EQ(actual.sender_stamp_ns, expected.sender_stamp_ns);
  EXPECT_EQ(actual.world_stamp_ns, expected.world_stamp_ns);
}

inline Mat2 sym2(double xx, double xy, double yy) {
  Mat2 m;
  m << xx, xy, xy, yy;
  return m;
}

inline estimators::StateMessage make_state(double offset) {
  estimators::StateMessage m;
  m.mean_m = Vec2(12.25 + offset, -3.0625);
  m.covariance = sym2(0.5, -0.125 + offset, 2.0);
  m.anchor = true;
  m.active = false;
  m.degree = 7;
  return m;
}

inline estimators::InformationMessage make_information(int n) {
  estimators::InformationMessage m;
  m.target = 3;
  m.world_step = (std::int64_t{1} << 35) + 3;  // beyond 32 bits
  m.info_vec = VecX(n);
  m.info_mat = MatX(n, n);
  for (int r = 0; r < n; ++r) {
    m.info_vec(r) = 0.1 * (r + 1) - 1.0 / 3.0;
    for (int c = r; c < n; ++c) {
      const double value =
          (r == c ? 10.0 : 0.0) + 1.0 / (r + c + 1.0);  // Hilbert-like, not representable exactly
      m.info_mat(r, c) = value;
      m.info_mat(c, r) = value;
    }
  }
  return m;
}

inline estimators::ConsensusMessage make_consensus() {
  estimators::ConsensusMessage m;
  m.tau = 1LL << 40;
  m.round = -2;
  m.values = {0.1, -1e-300, 1e300, 42.0};
  return m;
}

inline estimators::BeliefMessage make_belief() {
  estimators::BeliefMessage m;
  m.iteration = 77;
  m.mean_m = Vec2(-1.0 / 7.0, 2.0 / 3.0);
  m.information = sym2(100.0, 1e-9, 3.5);
  m.infinite_information = true;
  m.contributions = {{3, sym2(2.0, -0.5, 1.0 / 3.0), Vec2(0.1, -7.25)},
                     {0, sym2(1e-300, 0.0, 5.0), Vec2(-0.0, 1e9)}};
  return m;
}

inline estimators::MeasurementBatch make_batch(std::int64_t world_step, std::int64_t world_stamp_ns) {
  estimators::MeasurementBatch b;
  b.world_step = world_step;
  b.world_time_s = 10.0 * static_cast<double>(world_stamp_ns) / 1e9;  // a dataset's clock, not the run's
  b.ranges = {{2, 10.5, 0.1}, {5, 1.0 / 3.0, 0.25}};
  estimators::AbsoluteFix fix;
  fix.position_m = Vec2(1.5, -2.5);
  fix.covariance = sym2(0.01, 0.002, 0.03);
  b.fix = fix;
  estimators::MotionInput motion;
  motion.velocity_mps = Vec2(0.3, -0.7);
  motion.dt_s = 0.1;
  motion.process_cov = sym2(1e-4, 0.0, 2e-4);
  b.motion = motion;
  b.neighbours = {2, 5, 9};
  b.bearings = {{2, 0.25, 0.01}};
  b.relative = {{5, Vec2(1.0 / 3.0, -4.5), sym2(0.01, 0.001, 0.02)}};
  b.targets = {{3, Vec2(7.0, 8.5), sym2(0.5, 0.0, 0.25), 1}};
  b.paths = {{2, 0, 12.75, 0.5, -2.0}, {2, 1, 14.0, 1.25, 3.0}};
  return b;
}

inline runtime::EstimateReport make_estimate(AgentId agent, std::uint32_t seq) {
  runtime::EstimateReport r;
  r.header = make_header(agent, seq);
  r.estimate.mean_m = Vec2(3.25 + agent, 1.0 / 3.0);
  r.estimate.covariance = sym2(0.2, 0.01, 0.3);
  r.estimate.valid = true;
  r.estimate.field = (VecX(3) << -1.5, 1.0 / 7.0, 1e-300).finished();  // joint_field's field estimate
  r.steps_run = 400 + seq;
  r.samples_published = 1234;
  r.samples_published_in_steps = 1201;
  r.cpu_s = 0.123456789;
  r.links = {{1, 10, 9, 1, 0, 0, 9, 7}, {4, 20, 15, 3, 2, 5, 24, 13}};
  for (std::size_t i = 0; i < r.rejected_by_reason.size(); ++i) {
    r.rejected_by_reason[i] = static_cast<std::uint32_t>(10 * i + 1);
  }
  return r;
}

inline void expect_state_eq(const estimators::StateMessage& a, const estimators::StateMessage& b) {
  EXPECT_MATRIX_NEAR(a.mean_m, b.mean_m, 0.0);
  EXPECT_MATRIX_NEAR(a.covariance, b.covariance, 0.0);
  EXPECT_EQ(a.anchor, b.anchor);
  EXPECT_EQ(a.active, b.active);
  EXPECT_EQ(a.degree, b.degree);
}

inline void expect_information_eq(const estimators::InformationMessage& a,
                                  const estimators::InformationMessage& b) {
  EXPECT_EQ(a.target, b.target);
  EXPECT_EQ(a.world_step, b.world_step);
  ASSERT_EQ(a.info_vec.size(), b.info_vec.size());
  ASSERT_EQ(a.info_mat.rows(), b.info_mat.rows());
  ASSERT_EQ(a.info_mat.cols(), b.info_mat.cols());
  if (a.info_vec.size() > 0) {  // EXPECT_MATRIX_NEAR's maxCoeff is undefined on empty matrices
    EXPECT_MATRIX_NEAR(a.info_vec, b.info_vec, 0.0);
    EXPECT_MATRIX_NEAR(a.info_mat, b.info_mat, 0.0);
  }
}

inline void expect_batch_eq(const estimators::MeasurementBatch& a, const estimators::MeasurementBatch& b) {
  EXPECT_EQ(a.world_step, b.world_step);
  EXPECT_EQ(a.world_time_s, b.world_time_s);
  ASSERT_EQ(a.ranges.size(), b.ranges.size());
  for (std::size_t i = 0; i < a.ranges.size(); ++i) {
    EXPECT_EQ(a.ranges[i].peer, b.ranges[i].peer);
    EXPECT_EQ(a.ranges[i].range_m, b.ranges[i].range_m);
    EXPECT_EQ(a.ranges[i].std_m, b.ranges[i].std_m);
  }
  ASSERT_EQ(a.fix.has_value(), b.fix.has_value());
  if (a.fix) {
    EXPECT_MATRIX_NEAR(a.fix->position_m, b.fix->position_m, 0.0);
    EXPECT_MATRIX_NEAR(a.fix->covariance, b.fix->covariance, 0.0);
    EXPECT_EQ(a.fix->z_m, b.fix->z_m);
  }
  ASSERT_EQ(a.motion.has_value(), b.motion.has_value());
  if (a.motion) {
    EXPECT_MATRIX_NEAR(a.motion->velocity_mps, b.motion->velocity_mps, 0.0);
    EXPECT_EQ(a.motion->dt_s, b.motion->dt_s);
    EXPECT_MATRIX_NEAR(a.motion->process_cov, b.motion->process_cov, 0.0);
  }
  EXPECT_EQ(a.neighbours, b.neighbours);
  ASSERT_EQ(a.bearings.size(), b.bearings.size());
  for (std::size_t i = 0; i < a.bearings.size(); ++i) {
    EXPECT_EQ(a.bearings[i].peer, b.bearings[i].peer);
    EXPECT_EQ(a.bearings[i].bearing_rad, b.bearings[i].bearing_rad);
    EXPECT_EQ(a.bearings[i].std_rad, b.bearings[i].std_rad);
  }
  ASSERT_EQ(a.relative.size(), b.relative.size());
  for (std::size_t i = 0; i < a.relative.size(); ++i) {
    EXPECT_EQ(a.relative[i].peer, b.relative[i].peer);
    EXPECT_MATRIX_NEAR(a.relative[i].delta_m, b.relative[i].delta_m, 0.0);
    EXPECT_MATRIX_NEAR(a.relative[i].covariance, b.relative[i].covariance, 0.0);
  }
  ASSERT_EQ(a.targets.size(), b.targets.size());
  for (std::size_t i = 0; i < a.targets.size(); ++i) {
    EXPECT_EQ(a.targets[i].target, b.targets[i].target);
    EXPECT_EQ(a.targets[i].kind, b.targets[i].kind);
    EXPECT_MATRIX_NEAR(a.targets[i].value, b.targets[i].value, 0.0);
    EXPECT_MATRIX_NEAR(a.targets[i].covariance, b.targets[i].covariance, 0.0);
  }
  ASSERT_EQ(a.paths.size(), b.paths.size());
  for (std::size_t i = 0; i < a.paths.size(); ++i) {
    EXPECT_EQ(a.paths[i].peer, b.paths[i].peer);
    EXPECT_EQ(a.paths[i].path_index, b.paths[i].path_index);
    EXPECT_EQ(a.paths[i].length_m, b.paths[i].length_m);
    EXPECT_EQ(a.paths[i].aoa_here_rad, b.paths[i].aoa_here_rad);
    EXPECT_EQ(a.paths[i].aoa_there_rad, b.paths[i].aoa_there_rad);
  }
}

inline void expect_estimate_eq(const runtime::EstimateReport& a, const runtime::EstimateReport& b) {
  expect_header_eq(a.header, b.header);
  EXPECT_MATRIX_NEAR(a.estimate.mean_m, b.estimate.mean_m, 0.0);
  EXPECT_MATRIX_NEAR(a.estimate.covariance, b.estimate.covariance, 0.0);
  EXPECT_EQ(a.estimate.valid, b.estimate.valid);
  ASSERT_EQ(a.estimate.field.size(), b.estimate.field.size());
  EXPECT_MATRIX_NEAR(a.estimate.field, b.estimate.field, 0.0);
  EXPECT_EQ(a.steps_run, b.steps_run);
  EXPECT_EQ(a.samples_published, b.samples_published);
  EXPECT_EQ(a.samples_published_in_steps, b.samples_published_in_steps);
  EXPECT_EQ(a.cpu_s, b.cpu_s);
  ASSERT_EQ(a.links.size(), b.links.size());
  for (std::size_t i = 0; i < a.links.size(); ++i) {
    EXPECT_EQ(a.links[i].sender, b.links[i].sender);
    EXPECT_EQ(a.links[i].arrived, b.links[i].arrived);
    EXPECT_EQ(a.links[i].delivered, b.links[i].delivered);
    EXPECT_EQ(a.links[i].dropped_injected, b.links[i].dropped_injected);
    EXPECT_EQ(a.links[i].rejected, b.links[i].rejected);
    EXPECT_EQ(a.links[i].first_seq, b.links[i].first_seq);
    EXPECT_EQ(a.links[i].last_seq, b.links[i].last_seq);
    EXPECT_EQ(a.links[i].delivered_in_steps, b.links[i].delivered_in_steps);
  }
  EXPECT_EQ(a.rejected_by_reason, b.rejected_by_reason);
}

/// Polls `done` every 20 ms until it returns true or `timeout_s` passes; returns the last result.
inline bool poll_until(double timeout_s, const std::function<bool()>& done) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < deadline) {
    if (done()) {
      return true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return done();
}

}  // namespace swarmloc::dds::test
