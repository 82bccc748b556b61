#pragma once
// Distributed Jacobi localization from relative measurements (Atanasov et al. eq. (9), docs/algorithms.md
// §4.3, §4.5).
#include <cstdint>
#include <map>
#include <string_view>

#include "swarmloc/estimators/estimator.hpp"

namespace swarmloc::estimators::consensus {

/// Node i ≠ reference: x̂_i(t+1) = D_i⁻¹ (Σ_j 𝓔_ij⁻¹ x̂_j(t) − Σ_j 𝓔_ij⁻¹ s̄_ij(t)) (Atanasov et al. eq. (9)),
/// with s̄_ij the running mean of all samples s_ij(0…t) ([C-3]) and x̂_j the newest STATE received from j
/// (§4.5). The reference node (AgentSetup::anchor) never updates and publishes its initial guess (Atanasov et
/// al.: x_1 ≡ 0).
///
/// Measurements come from MeasurementBatch::relative (s = x_peer − x_self + ε). Under the shared-measurement
/// default [C-7] the world gives j the sample −s_ij of the same draw; the estimator just averages what it
/// gets.
///
/// Publishes STATE {x̂_i, covariance, anchor, degree}. The covariance is nominal: (Σ_j n_ij 𝓔_ij⁻¹)⁻¹, the
/// covariance of x̂_i if the neighbours' positions were exact (n_ij = samples received on edge ij); it is
/// optimistic and is not the BLUE covariance. The reference publishes zero covariance.
class JacobiLocalization final : public Estimator {
 public:
  explicit JacobiLocalization(const AgentSetup& setup);

  [[nodiscard]] std::string_view name() const override { return "jacobi"; }
  [[nodiscard]] Outbox initial_outbox() const override;
  StepOutput step(const StepInput& input) override;
  [[nodiscard]] Estimate estimate() const override;

  [[nodiscard]] const Vec2& mean() const { return x_; }
  /// Running mean s̄_ij and its sample count for neighbour j (count 0 if never measured).
  struct EdgeMean {
    Vec2 mean = Vec2::Zero();
    std::int64_t count = 0;
    Mat2 information = Mat2::Zero();  ///< 𝓔_ij⁻¹ of the newest sample
  };
  [[nodiscard]] const std::map<AgentId, EdgeMean>& edges() const { return edges_; }

 private:
  [[nodiscard]] Outbox published() const;
  [[nodiscard]] Mat2 nominal_covariance() const;

  AgentSetup setup_;
  Vec2 x_;
  std::map<AgentId, EdgeMean> edges_;
};

}  // namespace swarmloc::estimators::consensus
