#include "swarmloc/estimators/consensus/jacobi.hpp"

#include <Eigen/Cholesky>
#include <stdexcept>

namespace swarmloc::estimators::consensus {
namespace {

bool positive_definite(const Mat2& m) {
  const Eigen::LLT<Mat2> llt(m);
  return m.allFinite() && llt.info() == Eigen::Success;
}

}  // namespace

JacobiLocalization::JacobiLocalization(const AgentSetup& setup) : setup_(setup), x_(setup.initial_guess_m) {
  if (!setup.initial_guess_m.allFinite()) throw std::invalid_argument("jacobi: initial guess is not finite");
}

Mat2 JacobiLocalization::nominal_covariance() const {
  Mat2 information = Mat2::Zero();
  for (const auto& [peer, edge] : edges_) information += static_cast<double>(edge.count) * edge.information;
  if (!positive_definite(information)) return Mat2::Identity() * 1e12;
  return information.inverse();
}

Outbox JacobiLocalization::published() const {
  StateMessage state;
  state.mean_m = x_;
  state.anchor = setup_.anchor;
  state.covariance = setup_.anchor ? Mat2::Zero() : nominal_covariance();
  state.degree = static_cast<std::uint16_t>(edges_.size());
  Outbox outbox;
  outbox.state = state;
  return outbox;
}

Outbox JacobiLocalization::initial_outbox() const { return published(); }

StepOutput JacobiLocalization::step(const StepInput& input) {
  StepOutput out;
  // Running means over the samples received so far ([C-3]); a missing sample leaves s̄_ij unchanged
  // (docs/algorithms.md §4.5).
  if (input.measurements != nullptr) {
    for (const RelativeMeasurement& m : input.measurements->relative) {
      if (m.peer == setup_.id || !m.delta_m.allFinite() || !positive_definite(m.covariance)) continue;
      EdgeMean& edge = edges_[m.peer];
      edge.count += 1;
      edge.mean += (m.delta_m - edge.mean) / static_cast<double>(edge.count);
      edge.information = m.covariance.inverse();
    }
  }
  if (setup_.anchor || input.inbox == nullptr) {  // the reference never updates
    out.outbox = published();
    return out;
  }
  // Atanasov et al. eq. (9) over the neighbours with both a measurement mean and a STATE (the newest:
  // docs/algorithms.md §4.5).
  Mat2 D = Mat2::Zero();
  Vec2 b = Vec2::Zero();
  for (const auto& received : input.inbox->states) {
    const auto it = edges_.find(received.sender);
    if (it == edges_.end() || it->second.count == 0 || !received.message.mean_m.allFinite()) {
      ++out.diagnostics.neighbours_skipped;
      continue;
    }
    const EdgeMean& edge = it->second;
    D += edge.information;
    b += edge.information * (received.message.mean_m - edge.mean);  // x_i = x_j − s_ij + ε
    ++out.diagnostics.neighbours_used;
  }
  if (out.diagnostics.neighbours_used > 0 && positive_definite(D)) {
    x_ = D.llt().solve(b);
    out.diagnostics.updated = true;
  }
  out.outbox = published();
  return out;
}

Estimate JacobiLocalization::estimate() const {
  Estimate estimate;
  estimate.mean_m = x_;
  estimate.covariance = setup_.anchor ? Mat2::Zero() : nominal_covariance();
  estimate.valid = setup_.anchor || !edges_.empty();
  return estimate;
}

}  // namespace swarmloc::estimators::consensus
