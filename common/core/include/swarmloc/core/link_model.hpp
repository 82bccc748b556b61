#pragma once
// Receiver-side loss injection (docs/design.md §5). The decision depends only on
// (seed, sender, receiver, topic family, seq), so the simulator and DDS drop the same samples.
//
// Two loss processes per (sender, receiver, family) link:
//  - Bernoulli: each sample is dropped independently with probability `loss_probability`.
//  - Gilbert–Elliott bursts (`burst_mean_length` > 0): a two-state Markov chain over the link's seq
//    numbers, Good (delivered) and Bad (dropped), in the Gilbert special case (loss 0 in Good, 1 in
//    Bad). Its stationary loss is `loss_probability` and the mean run of consecutive drops (a burst)
//    is `burst_mean_length` samples.
//
// How the chain stays a pure function of (seed, sender, receiver, family, seq): a two-state chain with
// P(G→B) = p, P(B→G) = r and p + r <= 1 is the same process as "at each seq, with probability
// rho = p + r, draw the state afresh from the stationary law (Bad with probability L = p / (p + r));
// otherwise keep the previous state". Both coins of seq n are hashes of (seed, link, n), so the state at
// seq n is the fresh draw at the latest refresh index m <= n, found by walking back from n (seq 0 always
// refreshes). No history is stored: any process, in any order, computes the same state for the same seq.
// With mean burst length B and loss L: r = 1/B, p = L r / (1 − L), rho = 1 / ((1 − L) B); p + r <= 1
// requires B >= 1/(1 − L), which is the mean burst length of Bernoulli loss itself (B = 1/(1 − L) gives
// rho = 1, i.e. exactly independent losses). The walk back takes 1/rho = (1 − L) B hashes on average.
#include <cstdint>

#include "swarmloc/core/random.hpp"
#include "swarmloc/core/types.hpp"

namespace swarmloc::core {

enum class TopicFamily : std::uint8_t {
  kMeasurement = 0,
  kState = 1,
  kInformation = 2,
  kConsensus = 3,
  kBelief = 4,
  kEstimate = 5,
  kControl = 6,
  kObservations = 7
};

struct LinkLossParams {
  double loss_probability = 0.0;   ///< mean drop probability in [0, 1]
  double burst_mean_length = 0.0;  ///< 0 = Bernoulli; else Gilbert–Elliott, >= 1 / (1 − loss_probability)
};

/// The shortest mean burst (in samples) a Gilbert–Elliott chain with this mean loss can have in this
/// model: 1 / (1 − loss), the mean run of drops of independent (Bernoulli) loss. Infinite for loss >= 1.
inline double min_burst_mean_length(double loss_probability) { return 1.0 / (1.0 - loss_probability); }

class LinkLossModel {
 public:
  LinkLossModel(std::uint64_t seed, LinkLossParams params)
      : seed_(seed),
        params_(params),
        refresh_probability_(params.burst_mean_length > 0.0 && params.loss_probability < 1.0
                                 ? 1.0 / ((1.0 - params.loss_probability) * params.burst_mean_length)
                                 : 1.0) {}

  /// True if the sample `seq` from `sender` to `receiver` on `family` is dropped.
  [[nodiscard]] bool drops(AgentId sender, AgentId receiver, TopicFamily family, std::uint64_t seq) const {
    if (!(params_.loss_probability > 0.0)) return false;
    if (params_.loss_probability >= 1.0) return true;
    if (!(params_.burst_mean_length > 0.0)) {
      const auto h = hash_keys(seed_, static_cast<std::uint64_t>(Stream::kLinkLoss), sender, receiver,
                               static_cast<std::uint64_t>(family), seq);
      return unit_uniform(h) < params_.loss_probability;
    }
    // Gilbert–Elliott: the state at the latest refresh index <= seq (see the header comment).
    const auto link = hash_keys(seed_, static_cast<std::uint64_t>(Stream::kLinkBurst), sender, receiver,
                                static_cast<std::uint64_t>(family));
    for (std::uint64_t n = seq;; --n) {
      if (n == 0 || unit_uniform(hash_keys(link, n, 0)) < refresh_probability_) {
        return unit_uniform(hash_keys(link, n, 1)) < params_.loss_probability;
      }
    }
  }

  [[nodiscard]] const LinkLossParams& params() const { return params_; }

 private:
  std::uint64_t seed_;
  LinkLossParams params_;
  double refresh_probability_;  ///< rho = P(G→B) + P(B→G); 1 for Bernoulli
};

}  // namespace swarmloc::core
