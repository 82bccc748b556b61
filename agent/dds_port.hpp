#pragma once
// The agent loop's outputs on the process's DDS topics (runtime/agent_loop.hpp's AgentPort): shared by
// the orchestrated agent (agent_node.cpp) and the live agent (live_agent.cpp).
#include <spdlog/spdlog.h>

#include <type_traits>

#include "swarmloc/dds/transport.hpp"
#include "swarmloc/runtime/agent_loop.hpp"

namespace swarmloc::agent {

class DdsPort : public runtime::AgentPort {
 public:
  DdsPort(dds::AgentTransport& transport, spdlog::logger& logger) : transport_(transport), logger_(logger) {}

  void publish(const runtime::AgentRuntime::Publication& publication) override {
    runtime::AgentRuntime::for_each_sample(
        publication, [this](const runtime::Header& header, const auto& message) {
          using Message = std::decay_t<decltype(message)>;
          if constexpr (std::is_same_v<Message, estimators::StateMessage>)
            transport_.publish_state(header, message);
          if constexpr (std::is_same_v<Message, estimators::InformationMessage>)
            transport_.publish_information(header, message);
          if constexpr (std::is_same_v<Message, estimators::ConsensusMessage>)
            transport_.publish_consensus(header, message);
          if constexpr (std::is_same_v<Message, estimators::BeliefMessage>)
            transport_.publish_belief(header, message);
          if constexpr (std::is_same_v<Message, estimators::ObservationMessage>)
            transport_.publish_observations(header, message);
        });
  }
  void flush() override {
    if (!transport_.wait_for_acks(kAckTimeoutS))
      logger_.warn("samples not acknowledged within {} s", kAckTimeoutS);
  }
  void report(const runtime::EstimateReport& report) override { transport_.publish_estimate(report); }

  static constexpr double kAckTimeoutS = 5.0;

 protected:
  dds::AgentTransport& transport_;
  spdlog::logger& logger_;
};

/// Hands the estimator samples of one DDS read to the agent loop, family by family.
inline void feed_samples(runtime::AgentLoop& loop, const dds::AgentInbound& inbound, double now_s) {
  auto feed = [&](const auto& samples) {
    for (const auto& sample : samples)
      loop.on_sample(runtime::InboundSample{sample.header, sample.message, sample.well_formed}, now_s);
  };
  feed(inbound.states);
  feed(inbound.information);
  feed(inbound.consensus);
  feed(inbound.beliefs);
  feed(inbound.observations);
}

}  // namespace swarmloc::agent
