// A Fast DDS (eProsima, not Cyclone) subscriber to swarmloc's estimate topic. Prints one CSV line per
// received sample on stdout, so check.sh can compare them with the run directory's estimates.csv.
//
// What it must agree on with swarmloc (common/dds/src/endpoints.hpp, qos.cpp, docs/scenario.md):
//   topic "swarmloc_estimate", type "swarmloc::msg::Estimate" (XCDR1 @final, no TypeObject),
//   partition "est", reliable + volatile (the writer is reliable, keep-last 4, volatile).
// Discovery: swarmloc's participants use unicast discovery with fixed ports and no multicast
// (common/dds/src/cyclone_config.cpp), so this reader lists each agent's discovery port as an initial
// peer; Cyclone answers an unknown participant's SPDP directly, so no swarmloc setting changes.
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <memory>
#include <string>
#include <thread>

#include "swarmlocPubSubTypes.h"

namespace fdds = eprosima::fastdds::dds;
using eprosima::fastrtps::rtps::IPLocator;
using eprosima::fastrtps::rtps::Locator_t;

namespace {

std::atomic<bool> g_stop{false};

void on_signal(int) { g_stop.store(true); }

struct Options {
  int domain = 0;
  int agents = 0;
  int participant_id = 119;  // the last RTPS index whose ports stay inside the domain's 250-port block
  std::string address = "127.0.0.1";
  double max_seconds = 600.0;
};

// swarmloc's port layout (common/dds/src/cyclone_config.cpp): agent i's discovery port is
// 7410 + 2 i + 250 d (Base moves by 200 every 100 indices, which keeps the formula linear).
int agent_discovery_port(int agent, int domain) { return 7410 + 2 * agent + 250 * domain; }

[[noreturn]] void usage(const char* argv0) {
  std::fprintf(stderr,
               "usage: %s --domain D --agents N [--address 127.0.0.1] [--participant-id 119] "
               "[--max-seconds 600]\n",
               argv0);
  std::exit(2);
}

Options parse(int argc, char** argv) {
  Options options;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (i + 1 >= argc) usage(argv[0]);
    const char* value = argv[++i];
    if (arg == "--domain") {
      options.domain = std::atoi(value);
    } else if (arg == "--agents") {
      options.agents = std::atoi(value);
    } else if (arg == "--address") {
      options.address = value;
    } else if (arg == "--participant-id") {
      options.participant_id = std::atoi(value);
    } else if (arg == "--max-seconds") {
      options.max_seconds = std::atof(value);
    } else {
      usage(argv[0]);
    }
  }
  // The orchestrator takes slot N (and a fusion centre N + 1): our index must come after them.
  if (options.agents <= 0 || options.participant_id < options.agents + 2 || options.participant_id > 119) {
    std::fprintf(stderr, "need --agents N with N + 2 <= --participant-id <= 119\n");
    std::exit(2);
  }
  return options;
}

class EstimateListener : public fdds::DataReaderListener {
 public:
  void on_subscription_matched(fdds::DataReader*, const fdds::SubscriptionMatchedStatus& status) override {
    std::fprintf(stderr, "fastdds reader: %d writer(s) matched\n", status.current_count);
  }

  void on_data_available(fdds::DataReader* reader) override {
    swarmloc::msg::Estimate sample;
    fdds::SampleInfo info;
    while (reader->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;  // disposal / unregistration
      const auto& h = sample.hdr();
      const auto& mean = sample.mean_m();
      const auto& cov = sample.covariance();
      std::printf("%d,%lld,%u,%u,%lld,%d,%.17g,%.17g,%.17g,%.17g,%.17g,%zu\n", sample.agent_id(),
                  static_cast<long long>(h.step()), sample.steps_run(), h.seq(),
                  static_cast<long long>(h.world_stamp_ns()), sample.valid() ? 1 : 0, mean[0], mean[1],
                  cov[0], cov[1], cov[2], sample.links().size());
      received_.fetch_add(1);
    }
  }

  long received() const { return received_.load(); }

 private:
  std::atomic<long> received_{0};
};

}  // namespace

int main(int argc, char** argv) {
  const Options options = parse(argc, argv);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  // Block-buffered output: this runs on Fast DDS's receive thread, one write per sample would slow it.
  static char out_buffer[1 << 20];
  std::setvbuf(stdout, out_buffer, _IOFBF, sizeof out_buffer);

  fdds::DomainParticipantQos pqos;
  pqos.name("swarmloc_fastdds_reader");
  // UDP on the given address only (no shared memory, no other interfaces), like Cyclone's config.
  auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
  udp->interfaceWhiteList.push_back(options.address);
  // Every agent sends to this one socket; the 208 KiB default overflowed on this loaded 2-core
  // machine (UDP RcvbufErrors) and keep-last 4 writers then had nothing left to resend.
  udp->receiveBufferSize = 4u << 20;
  pqos.transport().user_transports.push_back(udp);
  pqos.transport().use_builtin_transports = false;
  auto& wire = pqos.wire_protocol();
  wire.participant_id = options.participant_id;
  // Unicast metatraffic on our own port only: swarmloc's participants never send multicast.
  Locator_t own;
  IPLocator::setIPv4(own, options.address);
  own.port = static_cast<uint32_t>(7410 + 2 * options.participant_id + 250 * options.domain);
  wire.builtin.metatrafficUnicastLocatorList.push_back(own);
  for (int agent = 0; agent < options.agents; ++agent) {
    Locator_t peer;
    IPLocator::setIPv4(peer, options.address);
    peer.port = static_cast<uint32_t>(agent_discovery_port(agent, options.domain));
    wire.builtin.initialPeersList.push_back(peer);
  }
  // The agents do not know us: we must announce ourselves to them. Announce often, so an agent that
  // starts after us is found within ~0.2 s instead of Fast DDS's default 3 s.
  wire.builtin.discovery_config.leaseDuration_announcementperiod =
      eprosima::fastrtps::Duration_t(0, 200000000);

  auto* factory = fdds::DomainParticipantFactory::get_instance();
  fdds::DomainParticipant* participant = factory->create_participant(options.domain, pqos);
  if (participant == nullptr) {
    std::fprintf(stderr, "fastdds reader: create_participant failed (domain %d)\n", options.domain);
    return 1;
  }
  fdds::TypeSupport type(new swarmloc::msg::EstimatePubSubType());
  type.register_type(participant);  // registered under "swarmloc::msg::Estimate", Cyclone's name
  fdds::Topic* topic =
      participant->create_topic("swarmloc_estimate", type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);

  fdds::SubscriberQos sqos = fdds::SUBSCRIBER_QOS_DEFAULT;
  sqos.partition().push_back("est");
  fdds::Subscriber* subscriber = participant->create_subscriber(sqos);

  fdds::DataReaderQos rqos = fdds::DATAREADER_QOS_DEFAULT;
  rqos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
  rqos.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
  // Keep all on our side (history is not a matching QoS): nothing is overwritten before we take it.
  rqos.history().kind = fdds::KEEP_ALL_HISTORY_QOS;
  // The topic is keyed by agent id; Fast DDS's default allows 10 instances per reader and silently
  // drops samples of any further agent (the first run here got exactly 10 of 20 agents).
  auto& limits = rqos.resource_limits();
  limits.max_instances = options.agents + 2;
  limits.max_samples_per_instance = 400;
  limits.max_samples = limits.max_instances * limits.max_samples_per_instance;
  EstimateListener listener;
  fdds::DataReader* reader = topic != nullptr && subscriber != nullptr
                                 ? subscriber->create_datareader(topic, rqos, &listener)
                                 : nullptr;
  if (reader == nullptr) {
    std::fprintf(stderr, "fastdds reader: topic/subscriber/reader creation failed\n");
    return 1;
  }
  std::printf("agent,step,steps_run,seq,world_stamp_ns,valid,x_m,y_m,cov_xx,cov_xy,cov_yy,links\n");
  std::fflush(stdout);
  std::fprintf(stderr, "fastdds reader: domain %d, %d agent peers, waiting\n", options.domain,
               options.agents);

  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(options.max_seconds);
  while (!g_stop.load() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  subscriber->delete_datareader(reader);
  participant->delete_contained_entities();
  factory->delete_participant(participant);
  std::fflush(stdout);
  std::fprintf(stderr, "fastdds reader: %ld samples received\n", listener.received());
  return 0;
}
