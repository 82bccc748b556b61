#pragma once
// Receiver-side loss injection (DESIGN.md §5). The decision depends only on
// (seed, sender, receiver, topic family, seq), so the simulator and DDS drop the same samples.
#include <cstdint>

#include "swarmloc/core/random.hpp"
#include "swarmloc/core/types.hpp"

namespace swarmloc::core {

enum class TopicFamily : std::uint8_t { kMeasurement = 0, kState = 1, kInformation = 2, kConsensus = 3, kBelief = 4, kEstimate = 5, kControl = 6 };

struct LinkLossParams {
  double loss_probability = 0.0;  ///< Bernoulli drop probability in [0, 1]
};

class LinkLossModel {
 public:
  LinkLossModel(std::uint64_t seed, LinkLossParams params) : seed_(seed), params_(params) {}

  /// True if the sample `seq` from `sender` to `receiver` on `family` is dropped.
  [[nodiscard]] bool drops(AgentId sender, AgentId receiver, TopicFamily family, std::uint64_t seq) const {
    if (params_.loss_probability <= 0.0) return false;
    if (params_.loss_probability >= 1.0) return true;
    const auto h = hash_keys(seed_, static_cast<std::uint64_t>(Stream::kLinkLoss), sender, receiver,
                             static_cast<std::uint64_t>(family), seq);
    return unit_uniform(h) < params_.loss_probability;
  }

  [[nodiscard]] const LinkLossParams& params() const { return params_; }

 private:
  std::uint64_t seed_;
  LinkLossParams params_;
};

}  // namespace swarmloc::core
