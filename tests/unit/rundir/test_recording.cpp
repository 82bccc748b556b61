// --record files and replay (recording.hpp): bit-exact round trips of every batch and sample field,
// clear errors (never crashes) on hostile files, every single flipped bit refused (version 4 checksums),
// and older versions still read. The simulator's replays: tests/unit/sim/test_simulated_recording.cpp.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

#include "observation_sample.hpp"
#include "process_helpers.hpp"
#include "recording_bytes.hpp"
#include "swarmloc/rundir/recording.hpp"

namespace swarmloc::rundir {
namespace {

using testing::get_u32;
using testing::put_u32;
using testing::read_bytes;
using testing::records_of;
using testing::reseal;
using testing::without_checksums;

std::filesystem::path temp_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("swarmloc-recording-" + name + "-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// ---- Bit-exact comparison ----

void expect_same(const Vec2& a, const Vec2& b) {
  EXPECT_BITS(a.x(), b.x());
  EXPECT_BITS(a.y(), b.y());
}
void expect_same(const Mat2& a, const Mat2& b) {
  for (int k = 0; k < 4; ++k) EXPECT_BITS(a.data()[k], b.data()[k]);
}

void expect_same(const estimators::MeasurementBatch& a, const estimators::MeasurementBatch& b) {
  EXPECT_EQ(a.world_step, b.world_step);
  EXPECT_BITS(a.world_time_s, b.world_time_s);
  ASSERT_EQ(a.ranges.size(), b.ranges.size());
  for (std::size_t k = 0; k < a.ranges.size(); ++k) {
    EXPECT_EQ(a.ranges[k].peer, b.ranges[k].peer);
    EXPECT_BITS(a.ranges[k].range_m, b.ranges[k].range_m);
    EXPECT_BITS(a.ranges[k].std_m, b.ranges[k].std_m);
  }
  ASSERT_EQ(a.bearings.size(), b.bearings.size());
  for (std::size_t k = 0; k < a.bearings.size(); ++k) {
    EXPECT_EQ(a.bearings[k].peer, b.bearings[k].peer);
    EXPECT_BITS(a.bearings[k].bearing_rad, b.bearings[k].bearing_rad);
    EXPECT_BITS(a.bearings[k].std_rad, b.bearings[k].std_rad);
  }
  ASSERT_EQ(a.relative.size(), b.relative.size());
  for (std::size_t k = 0; k < a.relative.size(); ++k) {
    EXPECT_EQ(a.relative[k].peer, b.relative[k].peer);
    expect_same(a.relative[k].delta_m, b.relative[k].delta_m);
    expect_same(a.relative[k].covariance, b.relative[k].covariance);
  }
  ASSERT_EQ(a.paths.size(), b.paths.size());
  for (std::size_t k = 0; k < a.paths.size(); ++k) {
    EXPECT_EQ(a.paths[k].peer, b.paths[k].peer);
    EXPECT_EQ(a.paths[k].path_index, b.paths[k].path_index);
    EXPECT_BITS(a.paths[k].length_m, b.paths[k].length_m);
    EXPECT_BITS(a.paths[k].aoa_here_rad, b.paths[k].aoa_here_rad);
    EXPECT_BITS(a.paths[k].aoa_there_rad, b.paths[k].aoa_there_rad);
  }
  ASSERT_EQ(a.targets.size(), b.targets.size());
  for (std::size_t k = 0; k < a.targets.size(); ++k) {
    EXPECT_EQ(a.targets[k].target, b.targets[k].target);
    expect_same(a.targets[k].value, b.targets[k].value);
    expect_same(a.targets[k].covariance, b.targets[k].covariance);
    EXPECT_EQ(a.targets[k].kind, b.targets[k].kind);
  }
  ASSERT_EQ(a.fix.has_value(), b.fix.has_value());
  if (a.fix) {
    expect_same(a.fix->position_m, b.fix->position_m);
    expect_same(a.fix->covariance, b.fix->covariance);
  }
  ASSERT_EQ(a.motion.has_value(), b.motion.has_value());
  if (a.motion) {
    expect_same(a.motion->velocity_mps, b.motion->velocity_mps);
    EXPECT_BITS(a.motion->dt_s, b.motion->dt_s);
    expect_same(a.motion->process_cov, b.motion->process_cov);
  }
  ASSERT_EQ(a.odometry.has_value(), b.odometry.has_value());
  if (a.odometry) {
    ASSERT_EQ(a.odometry->segments.size(), b.odometry->segments.size());
    for (std::size_t k = 0; k < a.odometry->segments.size(); ++k) {
      EXPECT_BITS(a.odometry->segments[k].v_mps, b.odometry->segments[k].v_mps);
      EXPECT_BITS(a.odometry->segments[k].omega_radps, b.odometry->segments[k].omega_radps);
      EXPECT_BITS(a.odometry->segments[k].dt_s, b.odometry->segments[k].dt_s);
    }
    EXPECT_BITS(a.odometry->v_std, b.odometry->v_std);
    EXPECT_BITS(a.odometry->omega_std, b.odometry->omega_std);
  }
  ASSERT_EQ(a.range_bearings.size(), b.range_bearings.size());
  for (std::size_t k = 0; k < a.range_bearings.size(); ++k) {
    const auto& x = a.range_bearings[k];
    const auto& y = b.range_bearings[k];
    EXPECT_EQ(x.peer, y.peer);
    EXPECT_EQ(x.landmark, y.landmark);
    expect_same(x.landmark_m, y.landmark_m);
    expect_same(x.landmark_cov, y.landmark_cov);
    EXPECT_BITS(x.range_m, y.range_m);
    EXPECT_BITS(x.bearing_rad, y.bearing_rad);
    EXPECT_BITS(x.range_std_m, y.range_std_m);
    EXPECT_BITS(x.bearing_std_rad, y.bearing_std_rad);
  }
  EXPECT_EQ(a.neighbours, b.neighbours);
}

/// A batch with every field populated, including values that text formats lose (−0, NaN payloads,
/// infinities, subnormals, non-symmetric matrices).
estimators::MeasurementBatch full_batch(AgentId agent, std::int64_t step, int agents) {
  const double odd[] = {-0.0,
                        std::numeric_limits<double>::quiet_NaN(),
                        std::numeric_limits<double>::infinity(),
                        std::numeric_limits<double>::denorm_min(),
                        0.1 + 0.2,
                        -1e300};
  const AgentId peer = (agent + 1) % agents;
  estimators::MeasurementBatch b;
  b.world_step = step;
  b.world_time_s = 0.1 * static_cast<double>(step) + odd[4];
  b.ranges = {{peer, 3.25 + agent, odd[3]}, {(agent + 2) % agents, odd[0], 0.1}};
  b.bearings = {{peer, odd[1], 0.02}};
  Mat2 skew;
  skew << 1.0, 0.25, -0.5, odd[5];
  b.relative = {{peer, Vec2(odd[2], -2.0), skew}};
  b.paths = {{peer, 3, 12.5, -0.7, 2.9}};
  b.targets = {{7, Vec2(1.0, odd[0]), skew.transpose(), 1}};
  b.fix = estimators::AbsoluteFix{Vec2(5.0 + step, 6.0), skew, std::nullopt};
  b.motion = estimators::MotionInput{Vec2(0.3, odd[3]), 0.1, skew * 2.0};
  b.odometry = estimators::OdometryInput{{{0.5, -0.1, 0.02}, {0.6, odd[0], 0.03}}, 0.01, 0.02};
  estimators::RangeBearingMeasurement to_peer;
  to_peer.peer = peer;
  to_peer.range_m = 2.5, to_peer.bearing_rad = -3.1, to_peer.range_std_m = 0.1,
  to_peer.bearing_std_rad = 0.05;
  estimators::RangeBearingMeasurement to_landmark;
  to_landmark.peer = 999;  // unused for landmarks: any id is fine
  to_landmark.landmark = true;
  to_landmark.landmark_m = Vec2(odd[4], 7.0), to_landmark.landmark_cov = skew;
  to_landmark.range_m = 4.0, to_landmark.bearing_rad = odd[1];
  b.range_bearings = {to_peer, to_landmark};
  b.neighbours = {peer, (agent + 2) % agents};
  return b;
}

config::Scenario recorded_scenario() {
  config::Scenario s;
  s.seed = 3;
  s.world.agents = 4;
  s.world.anchors = 2;
  s.world.area_m = 10.0;
  s.world.comm_radius_m = 20.0;
  return s;
}

/// A 4-agent recording of `steps` full batches; returns its path.
std::filesystem::path write_tiny_recording(const std::filesystem::path& dir, int steps) {
  const auto s = recorded_scenario();
  auto world = world::build_world(s);
  world.initial_heading = {0.1, -0.2, 0.3, -0.0};
  const auto path = dir / "tiny.slrec";
  RecordingWriter writer(path, s, world);
  for (int step = 0; step < steps; ++step) {
    std::vector<Vec2> truth;
    std::vector<estimators::MeasurementBatch> batches;
    for (AgentId i = 0; i < 4; ++i) {
      truth.emplace_back(1.0 * i + step, -0.0);
      batches.push_back(full_batch(i, step, 4));
    }
    writer.append_step(step, truth, batches);
  }
  writer.close();
  return path;
}

TEST(Recording, EveryBatchFieldRoundTripsBitExactly) {
  const auto dir = temp_dir("roundtrip");
  const auto path = write_tiny_recording(dir, 3);
  const auto recording = load_recording(path);
  EXPECT_EQ(recording->version(), runtime::kRecordingVersion);
  EXPECT_EQ(recording->agents(), 4);
  ASSERT_EQ(recording->steps(), 3);
  EXPECT_TRUE(recording->has_pose_measurements());
  EXPECT_EQ(recording->scenario_yaml(), config::to_yaml(recorded_scenario()));
  auto world = world::build_world(recorded_scenario());
  world.initial_heading = {0.1, -0.2, 0.3, -0.0};
  EXPECT_EQ(recording->world().difference(world), "");
  world.initial_guess[2].x() += 1e-15;
  EXPECT_EQ(recording->world().difference(world), "agent 2's initial guess differs");
  for (std::int64_t step = 0; step < 3; ++step) {
    const auto truth = recording->truth(step);
    ASSERT_EQ(truth.size(), 4u);
    for (AgentId i = 0; i < 4; ++i) {
      expect_same(truth[static_cast<std::size_t>(i)], Vec2(1.0 * i + static_cast<double>(step), -0.0));
      expect_same(recording->batch(i, step), full_batch(i, step, 4));
    }
  }
  EXPECT_THROW((void)recording->truth(3), std::out_of_range);
  EXPECT_THROW((void)recording->batch(4, 0), std::out_of_range);
  EXPECT_THROW((void)recording->batch(0, -1), std::out_of_range);
}

TEST(Recording, WriterRejectsStepsOutOfOrderAndWrongAgentCounts) {
  const auto dir = temp_dir("writer");
  const auto s = recorded_scenario();
  const auto world = world::build_world(s);
  RecordingWriter writer(dir / "w.slrec", s, world);
  const std::vector<Vec2> truth(4, Vec2::Zero());
  const std::vector<estimators::MeasurementBatch> batches(4);
  EXPECT_THROW(writer.append_step(1, truth, batches), std::logic_error);
  EXPECT_THROW(writer.append_step(0, truth, std::vector<estimators::MeasurementBatch>(3)), std::logic_error);
  writer.append_step(0, truth, batches);
  writer.close();
  EXPECT_EQ(load_recording(dir / "w.slrec")->steps(), 1);
}

/// The error text of loading `bytes`, or "" if it loaded.
std::string load_error(const std::vector<std::uint8_t>& bytes) {
  try {
    (void)parse_recording(bytes, "hostile.slrec");
  } catch (const RecordingError& error) {
    return error.what();
  }
  return "";
}

TEST(Recording, HostileFilesGiveClearErrorsNamingFileAndOffset) {
  const auto dir = temp_dir("hostile");
  const auto good = read_bytes(write_tiny_recording(dir, 2));
  ASSERT_EQ(load_error(good), "");

  auto bad = good;
  bad[0] = 'X';
  EXPECT_NE(load_error(bad).find("hostile.slrec: byte 0: not a swarmloc recording (bad magic"),
            std::string::npos)
      << load_error(bad);
  bad = good;
  bad[6] = 99;  // version
  EXPECT_NE(load_error(bad).find("byte 6: format version 99 is not supported"), std::string::npos)
      << load_error(bad);
  bad = good;
  bad[5] = 'S';  // the kind byte of a sample log: damage, unless the header's checksum says otherwise
  EXPECT_NE(load_error(bad).find("byte 0: checksum mismatch in the file header"), std::string::npos)
      << load_error(bad);
  reseal(bad);
  EXPECT_NE(load_error(bad).find("is a sample log"), std::string::npos) << load_error(bad);

  // Layout: magic(5) kind(1) version(2) crc(4) | header record: 'H' length(4) crc(4), payload: yaml
  // length(4) yaml, agents(4), per agent anchor(1) guess(16) neighbour count(4) ids, heading count(4)
  // headings; crc(4) | per step 'T' length crc, payload: step(8) truth batches; crc | 'E' … count(8) crc.
  // Each hostile field below is written with every checksum recomputed (reseal): the reader's field checks
  // hold behind the checksums too.
  const auto records = records_of(good);
  ASSERT_EQ(records.size(), 4u);  // header, two steps, end
  EXPECT_EQ(records[0].tag, 'H');
  EXPECT_EQ(records[1].tag, 'T');
  EXPECT_EQ(records[3].tag, 'E');
  EXPECT_EQ(records[3].end(), good.size());
  const std::size_t yaml_at = records[0].payload_at;
  const std::uint32_t yaml_length = get_u32(good, yaml_at);
  const std::size_t agents_at = yaml_at + 4 + yaml_length;
  auto hostile = [&](std::size_t at, std::uint32_t value) {
    auto bytes = good;
    put_u32(bytes, at, value);
    reseal(bytes);
    return load_error(bytes);
  };
  EXPECT_NE(hostile(yaml_at, 0xFFFFFFF0u)
                .find("byte " + std::to_string(yaml_at) + ": scenario: count 4294967280 exceeds"),
            std::string::npos)
      << hostile(yaml_at, 0xFFFFFFF0u);
  EXPECT_NE(hostile(agents_at, 0x7FFFFFFF).find("agent count 2147483647 outside"), std::string::npos);
  EXPECT_NE(hostile(agents_at + 4 + 1 + 16, 0xFFFFFFFFu).find("neighbours: count 4294967295 exceeds"),
            std::string::npos);  // agent 0's neighbour count
  EXPECT_NE(hostile(agents_at + 4 + 1 + 16 + 4, 77).find("neighbour 77 outside [0, 4)"), std::string::npos);
  // The first batch: after step 0's number and truth.
  const std::size_t first_batch_at = records[1].payload_at + 8 + 4 * 16;
  EXPECT_NE(hostile(first_batch_at + 16, 0x40000000u).find("ranges: count 1073741824 exceeds"),
            std::string::npos);
  EXPECT_NE(hostile(first_batch_at + 16 + 4, 4).find("range peer 4 outside [0, 4)"), std::string::npos);
  bad = good;
  bad.push_back(0);
  EXPECT_NE(load_error(bad).find("1 bytes after the end marker"), std::string::npos) << load_error(bad);
  // Without resealing, a changed field is a checksum mismatch naming the record's first byte.
  bad = good;
  put_u32(bad, first_batch_at + 16 + 4, 4);
  EXPECT_NE(load_error(bad).find("hostile.slrec: byte " + std::to_string(records[1].at) +
                                 ": checksum mismatch in the step record"),
            std::string::npos)
      << load_error(bad);

  // Every truncation is an error (the end marker is missing or cut), never a crash.
  for (std::size_t size = 0; size < good.size(); ++size) {
    const std::vector<std::uint8_t> cut(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(size));
    EXPECT_NE(load_error(cut), "") << "a " << size << "-byte prefix loaded";
  }
  // Seeded random corruption: either a valid file or a RecordingError, nothing else.
  std::mt19937_64 rng(5);
  for (int trial = 0; trial < 3000; ++trial) {
    auto mutated = good;
    const int flips = 1 + static_cast<int>(rng() % 4);
    for (int f = 0; f < flips; ++f) mutated[rng() % mutated.size()] = static_cast<std::uint8_t>(rng());
    try {
      const auto recording = parse_recording(mutated, "fuzz.slrec");
      for (std::int64_t step = 0; step < recording->steps(); ++step) {
        for (AgentId i = 0; i < recording->agents(); ++i) (void)recording->batch(i, step);
      }
    } catch (const RecordingError&) {
      // expected for most mutations
    }
  }
  EXPECT_THROW((void)load_recording(dir / "missing.slrec"), RecordingError);
}

runtime::ReceivedSample sample_of(runtime::SampleMessage message, std::uint32_t seq) {
  runtime::ReceivedSample s;
  s.receiver = 2;
  s.receiver_steps = 17;
  s.source_timestamp_ns = 1'700'000'000'123'456'789;
  s.take_ns = 1'700'000'000'123'556'789;
  s.well_formed = seq % 2 == 0;
  s.header = runtime::Header{1, seq, 16, -5, 1'600'000'000};
  s.message = std::move(message);
  return s;
}

std::vector<runtime::ReceivedSample> every_family() {
  estimators::StateMessage state;
  state.mean_m = Vec2(1.5, -0.0);
  state.covariance << 0.5, 0.1, 0.2, std::numeric_limits<double>::quiet_NaN();
  state.anchor = true, state.active = false, state.inconsistent = true, state.degree = 65535;
  state.edge_ranges = {{-4, 1e4, 12.25, Vec2(-3.5, 1e-300)},
                       {7, 5e-310, std::numeric_limits<double>::infinity(), Vec2(2.0, 0.25)}};
  // A log records what arrived, hostile values included: NaN, -0, denormals, a negative variance.
  state.cavities = {{-2, Vec2(-0.0, 1e-300), 5e-310, 1.0 / 3.0},
                    {9, Vec2(3.5, std::numeric_limits<double>::quiet_NaN()),
                     -std::numeric_limits<double>::infinity(), -0.25}};
  estimators::InformationMessage information;
  information.target = -3;
  information.info_vec = VecX::LinSpaced(3, -1.0, 1.0);
  information.info_mat = MatX::Random(3, 2);
  information.world_step = (std::int64_t{1} << 40) + 7;
  estimators::ConsensusMessage consensus;
  consensus.tau = -1, consensus.round = 19, consensus.values = {1.0, std::numeric_limits<double>::infinity()};
  estimators::BeliefMessage belief;
  belief.iteration = 1LL << 40, belief.mean_m = Vec2(3.0, 4.0), belief.information = Mat2::Identity() * 7.0;
  belief.infinite_information = true;
  Mat2 asymmetric;
  asymmetric << 1.0, -2.0, 3.0, std::numeric_limits<double>::quiet_NaN();
  belief.contributions = {{-7, asymmetric, Vec2(-0.0, 5e-310)}, {2, Mat2::Identity(), Vec2(1.0, 2.0)}};
  return {sample_of(state, 0), sample_of(information, 1), sample_of(consensus, 2), sample_of(belief, 3)};
}

void expect_same(const runtime::ReceivedSample& a, const runtime::ReceivedSample& b) {
  EXPECT_EQ(a.receiver, b.receiver);
  EXPECT_EQ(a.receiver_steps, b.receiver_steps);
  EXPECT_EQ(a.source_timestamp_ns, b.source_timestamp_ns);
  EXPECT_EQ(a.take_ns, b.take_ns);
  EXPECT_EQ(a.well_formed, b.well_formed);
  EXPECT_EQ(a.header.agent_id, b.header.agent_id);
  EXPECT_EQ(a.header.seq, b.header.seq);
  EXPECT_EQ(a.header.step, b.header.step);
  EXPECT_EQ(a.header.sender_stamp_ns, b.header.sender_stamp_ns);
  EXPECT_EQ(a.header.world_stamp_ns, b.header.world_stamp_ns);
  ASSERT_EQ(a.family(), b.family());
  switch (a.family()) {
    case runtime::SampleFamily::kState: {
      const auto& x = std::get<estimators::StateMessage>(a.message);
      const auto& y = std::get<estimators::StateMessage>(b.message);
      expect_same(x.mean_m, y.mean_m);
      expect_same(x.covariance, y.covariance);
      EXPECT_EQ(x.anchor, y.anchor);
      EXPECT_EQ(x.active, y.active);
      EXPECT_EQ(x.inconsistent, y.inconsistent);
      EXPECT_EQ(x.degree, y.degree);
      ASSERT_EQ(x.edge_ranges.size(), y.edge_ranges.size());
      for (std::size_t k = 0; k < x.edge_ranges.size(); ++k) {
        EXPECT_EQ(x.edge_ranges[k].peer, y.edge_ranges[k].peer);
        EXPECT_EQ(x.edge_ranges[k].information, y.edge_ranges[k].information);
        EXPECT_EQ(x.edge_ranges[k].mean_range_m, y.edge_ranges[k].mean_range_m);
        EXPECT_EQ(x.edge_ranges[k].peer_mean_m, y.edge_ranges[k].peer_mean_m);
      }
      ASSERT_EQ(x.cavities.size(), y.cavities.size());
      for (std::size_t k = 0; k < x.cavities.size(); ++k) {
        EXPECT_EQ(x.cavities[k].peer, y.cavities[k].peer);
        expect_same(x.cavities[k].offset_m, y.cavities[k].offset_m);
        EXPECT_BITS(x.cavities[k].offset_z_m, y.cavities[k].offset_z_m);
        EXPECT_BITS(x.cavities[k].variance_m2, y.cavities[k].variance_m2);
      }
      break;
    }
    case runtime::SampleFamily::kInformation: {
      const auto& x = std::get<estimators::InformationMessage>(a.message);
      const auto& y = std::get<estimators::InformationMessage>(b.message);
      EXPECT_EQ(x.target, y.target);
      EXPECT_EQ(x.info_vec, y.info_vec);
      EXPECT_EQ(x.info_mat, y.info_mat);
      EXPECT_EQ(x.world_step, y.world_step);
      break;
    }
    case runtime::SampleFamily::kConsensus: {
      const auto& x = std::get<estimators::ConsensusMessage>(a.message);
      const auto& y = std::get<estimators::ConsensusMessage>(b.message);
      EXPECT_EQ(x.tau, y.tau);
      EXPECT_EQ(x.round, y.round);
      EXPECT_EQ(x.values, y.values);
      break;
    }
    case runtime::SampleFamily::kBelief: {
      const auto& x = std::get<estimators::BeliefMessage>(a.message);
      const auto& y = std::get<estimators::BeliefMessage>(b.message);
      EXPECT_EQ(x.iteration, y.iteration);
      expect_same(x.mean_m, y.mean_m);
      expect_same(x.information, y.information);
      EXPECT_EQ(x.infinite_information, y.infinite_information);
      ASSERT_EQ(x.contributions.size(), y.contributions.size());
      for (std::size_t k = 0; k < x.contributions.size(); ++k) {
        EXPECT_EQ(x.contributions[k].from, y.contributions[k].from);
        expect_same(x.contributions[k].information, y.contributions[k].information);
        expect_same(x.contributions[k].info_vec, y.contributions[k].info_vec);
      }
      break;
    }
    case runtime::SampleFamily::kObservations: {
      const auto& x = std::get<estimators::ObservationMessage>(a.message);
      const auto& y = std::get<estimators::ObservationMessage>(b.message);
      EXPECT_EQ(x.origin_step, y.origin_step);
      EXPECT_EQ(x.origin_pose, y.origin_pose);
      EXPECT_EQ(x.origin_covariance, y.origin_covariance);
      ASSERT_EQ(x.spans.size(), y.spans.size());
      for (std::size_t k = 0; k < x.spans.size(); ++k) {
        const auto& p = x.spans[k];
        const auto& q = y.spans[k];
        EXPECT_EQ(p.first_world_step, q.first_world_step);
        EXPECT_EQ(p.world_step, q.world_step);
        EXPECT_EQ(p.world_time_s, q.world_time_s);
        ASSERT_EQ(p.odometry.has_value(), q.odometry.has_value());
        if (p.odometry) {
          EXPECT_EQ(p.odometry->v_std, q.odometry->v_std);
          EXPECT_EQ(p.odometry->omega_std, q.odometry->omega_std);
          ASSERT_EQ(p.odometry->segments.size(), q.odometry->segments.size());
          for (std::size_t s = 0; s < p.odometry->segments.size(); ++s) {
            EXPECT_EQ(p.odometry->segments[s].v_mps, q.odometry->segments[s].v_mps);
            EXPECT_EQ(p.odometry->segments[s].omega_radps, q.odometry->segments[s].omega_radps);
            EXPECT_EQ(p.odometry->segments[s].dt_s, q.odometry->segments[s].dt_s);
          }
        }
        ASSERT_EQ(p.range_bearings.size(), q.range_bearings.size());
        for (std::size_t r = 0; r < p.range_bearings.size(); ++r) {
          EXPECT_EQ(p.range_bearings[r].peer, q.range_bearings[r].peer);
          EXPECT_EQ(p.range_bearings[r].landmark, q.range_bearings[r].landmark);
          EXPECT_EQ(p.range_bearings[r].landmark_m, q.range_bearings[r].landmark_m);
          EXPECT_EQ(p.range_bearings[r].landmark_cov, q.range_bearings[r].landmark_cov);
          EXPECT_EQ(p.range_bearings[r].range_m, q.range_bearings[r].range_m);
          EXPECT_EQ(p.range_bearings[r].bearing_rad, q.range_bearings[r].bearing_rad);
          EXPECT_EQ(p.range_bearings[r].range_std_m, q.range_bearings[r].range_std_m);
          EXPECT_EQ(p.range_bearings[r].bearing_std_rad, q.range_bearings[r].bearing_std_rad);
          EXPECT_EQ(p.range_bearings[r].age_s, q.range_bearings[r].age_s);
        }
      }
      break;
    }
  }
}

TEST(SampleLog, ObservationSamplesRoundTripFromVersionSeven) {
  const auto dir = temp_dir("observations");
  const auto path = dir / "agent_001.slrec";
  const runtime::ReceivedSample sample = sample_of(swarmloc::test::observation_sample(), 8);
  {
    runtime::SampleLogWriter writer(path, 4, 7);
    writer.append(sample);
    writer.close();
  }
  const auto log = load_sample_log(path);
  ASSERT_EQ(log.samples.size(), 1u);
  expect_same(log.samples[0], sample);
  EXPECT_STREQ(to_string(log.samples[0].family()), "observations");
}

TEST(SampleLog, EveryFamilyRoundTripsAndAnUnfinishedLogIsReadOnRequest) {
  const auto dir = temp_dir("samples");
  const auto path = dir / "agent_002.slrec";
  const auto samples = every_family();
  {
    runtime::SampleLogWriter writer(path, 4, 0xABCDEF);
    for (const auto& s : samples) writer.append(s);
    EXPECT_EQ(writer.count(), 4u);
    writer.close();
  }
  const auto log = load_sample_log(path);
  EXPECT_TRUE(log.complete);
  EXPECT_EQ(log.agents, 4);
  EXPECT_EQ(log.scenario_hash, 0xABCDEFu);
  ASSERT_EQ(log.samples.size(), 4u);
  for (std::size_t k = 0; k < 4; ++k) expect_same(log.samples[k], samples[k]);
  EXPECT_STREQ(to_string(log.samples[1].family()), "information");

  // A killed agent's file has no end marker and may end inside a record.
  const auto bytes = read_bytes(path);
  const auto records = records_of(bytes);
  ASSERT_EQ(records.size(), 6u);  // header, four samples, end
  const auto end_marker = static_cast<std::ptrdiff_t>(bytes.size() - records.back().at);
  const std::vector<std::uint8_t> cut(bytes.begin(), bytes.end() - end_marker - 20);  // part of the belief
  EXPECT_THROW((void)parse_sample_log(cut, "cut.slrec"), RecordingError);
  const auto partial = parse_sample_log(cut, "cut.slrec", true);
  EXPECT_FALSE(partial.complete);
  ASSERT_EQ(partial.samples.size(), 3u);
  expect_same(partial.samples[2], samples[2]);
  const std::vector<std::uint8_t> at_boundary(bytes.begin(), bytes.end() - end_marker);
  EXPECT_EQ(parse_sample_log(at_boundary, "b.slrec", true).samples.size(), 4u);
  // Hostile content is an error even when unfinished logs are accepted.
  auto bad = bytes;
  bad[records[0].payload_at] = 2;  // agent count 2: the first sample's receiver (2) is out of range
  EXPECT_THROW((void)parse_sample_log(bad, "bad.slrec", true), RecordingError);
  reseal(bad);
  EXPECT_THROW((void)parse_sample_log(bad, "bad.slrec", true), RecordingError);
  EXPECT_THROW((void)load_recording(path), RecordingError);  // a sample log is not a recording

  // Every truncation and seeded random corruption: a log or a RecordingError, never a crash.
  for (std::size_t size = 0; size < bytes.size(); ++size) {
    const std::vector<std::uint8_t> prefix(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(size));
    EXPECT_THROW((void)parse_sample_log(prefix, "prefix.slrec"), RecordingError) << size;
    if (size >= records[0].end()) {  // the header record is complete: an unfinished log reads
      EXPECT_NO_THROW((void)parse_sample_log(prefix, "prefix.slrec", true)) << size;
    }
  }
  std::mt19937_64 rng(9);
  for (int trial = 0; trial < 3000; ++trial) {
    auto mutated = bytes;
    for (int f = 0; f < 3; ++f) mutated[rng() % mutated.size()] = static_cast<std::uint8_t>(rng());
    try {
      (void)parse_sample_log(mutated, "fuzz.slrec", trial % 2 == 0);
    } catch (const RecordingError&) {
      // expected for most mutations
    }
  }
}

TEST(SampleLog, AVersionOneLogReadsWithItsInformationSamplesNotTiedToAWorldStep) {
  const auto dir = temp_dir("samples_v1");
  const auto path = dir / "agent_002.slrec";
  const runtime::ReceivedSample information = every_family()[1];
  {
    runtime::SampleLogWriter writer(path, 4, 7);
    writer.append(information);
    writer.close();
  }
  const auto bytes = read_bytes(path);
  ASSERT_EQ(bytes[6], runtime::kRecordingVersion);
  const auto v3 = without_checksums(bytes, 3);
  // Version 1 is that log without the payload's last field (i64 world_step, before the 9-byte end marker).
  std::vector<std::uint8_t> v1(v3.begin(), v3.end() - 9 - 8);
  v1.insert(v1.end(), v3.end() - 9, v3.end());
  v1[6] = 1;
  const auto log = parse_sample_log(v1, "v1.slrec");
  EXPECT_EQ(log.version, 1);
  ASSERT_EQ(log.samples.size(), 1u);
  auto expected = information;
  std::get<estimators::InformationMessage>(expected.message).world_step = -1;
  expect_same(log.samples[0], expected);
  auto next = bytes;
  next[6] = runtime::kRecordingVersion + 1;
  reseal(next);
  try {
    (void)parse_sample_log(next, "next.slrec");
    ADD_FAILURE() << "a version from the future was read";
  } catch (const RecordingError& e) {
    EXPECT_NE(
        std::string(e.what()).find("format version 10 is not supported (this build reads versions 1 to 9)"),
        std::string::npos)
        << e.what();
  }
}

TEST(SampleLog, AVersionTwoLogReadsWithItsBeliefsWithoutContributions) {
  const auto dir = temp_dir("samples_v2");
  const auto path = dir / "agent_002.slrec";
  const runtime::ReceivedSample belief = every_family()[3];
  const auto contributions = std::get<estimators::BeliefMessage>(belief.message).contributions.size();
  {
    runtime::SampleLogWriter writer(path, 4, 7);
    writer.append(belief);
    writer.close();
  }
  const auto v3 = without_checksums(read_bytes(path), 3);
  // Version 2 is that log without the payload's contributions (count + 52 bytes each) before the end marker.
  const auto cut = static_cast<std::ptrdiff_t>(9 + 4 + 52 * contributions);
  std::vector<std::uint8_t> v2(v3.begin(), v3.end() - cut);
  v2.insert(v2.end(), v3.end() - 9, v3.end());
  v2[6] = 2;
  const auto log = parse_sample_log(v2, "v2.slrec");
  EXPECT_EQ(log.version, 2);
  ASSERT_EQ(log.samples.size(), 1u);
  auto expected = belief;
  std::get<estimators::BeliefMessage>(expected.message).contributions.clear();
  expect_same(log.samples[0], expected);
}

/// A sample log holding one state sample as version 8 wrote it: the same file without the state's
/// cavities (the payload's last field: a count and 36 bytes each), its lengths and checksums rewritten.
std::vector<std::uint8_t> as_version_eight(const std::vector<std::uint8_t>& bytes, std::size_t cavities) {
  std::vector<std::uint8_t> old(bytes.begin(), bytes.begin() + 12);
  old[6] = 8;
  for (const auto& r : records_of(bytes)) {
    const bool state = r.tag == 'R' && bytes[r.payload_at + testing::kSampleFamilyAt] == 0;
    const std::size_t length = state ? r.length - 4 - 36 * cavities : r.length;
    const std::size_t at = old.size();
    old.insert(old.end(), bytes.begin() + static_cast<std::ptrdiff_t>(r.at),
               bytes.begin() + static_cast<std::ptrdiff_t>(r.payload_at + length));
    put_u32(old, at + 1, static_cast<std::uint32_t>(length));
    old.insert(old.end(), 4, 0);  // the payload's checksum, which reseal computes
  }
  reseal(old);
  return old;
}

TEST(SampleLog, CavitiesRoundTripFromVersionNineAndAVersionEightLogReadsWithout) {
  const auto dir = temp_dir("samples_v8");
  const auto path = dir / "agent_002.slrec";
  const runtime::ReceivedSample state = every_family()[0];
  const auto& cavities = std::get<estimators::StateMessage>(state.message).cavities;
  ASSERT_EQ(cavities.size(), 2u);
  {
    runtime::SampleLogWriter writer(path, 4, 7);
    writer.append(state);
    writer.close();
  }
  const auto bytes = read_bytes(path);
  ASSERT_EQ(bytes[6], 9);
  const auto log = parse_sample_log(bytes, "v9.slrec");
  ASSERT_EQ(log.samples.size(), 1u);
  expect_same(log.samples[0], state);
  const auto& read = std::get<estimators::StateMessage>(log.samples[0].message).cavities;
  ASSERT_EQ(read.size(), 2u);
  EXPECT_EQ(read[0].peer, -2);
  EXPECT_BITS(read[0].offset_m.x(), -0.0);
  EXPECT_BITS(read[0].offset_z_m, 5e-310);
  EXPECT_BITS(read[1].offset_z_m, -std::numeric_limits<double>::infinity());
  EXPECT_BITS(read[1].variance_m2, -0.25);

  const auto v8 = as_version_eight(bytes, cavities.size());
  ASSERT_EQ(v8.size(), bytes.size() - 4 - 2 * 36);
  const auto old = parse_sample_log(v8, "v8.slrec");
  EXPECT_EQ(old.version, 8);
  EXPECT_TRUE(old.complete);
  ASSERT_EQ(old.samples.size(), 1u);
  auto expected = state;
  std::get<estimators::StateMessage>(expected.message).cavities.clear();
  expect_same(old.samples[0], expected);
  EXPECT_TRUE(std::get<estimators::StateMessage>(old.samples[0].message).inconsistent);

  // A cavity count beyond the record's bytes is refused before anything is allocated.
  const auto sample = records_of(bytes)[1];
  ASSERT_EQ(sample.tag, 'R');
  const std::size_t count_at = sample.payload_at + sample.length - 4 - 2 * 36;
  ASSERT_EQ(get_u32(bytes, count_at), 2u);
  auto hostile = bytes;
  put_u32(hostile, count_at, 3);
  reseal(hostile);
  try {
    (void)parse_sample_log(hostile, "hostile.slrec");
    ADD_FAILURE() << "a cavity count beyond the record was read";
  } catch (const RecordingError& e) {
    EXPECT_NE(std::string(e.what()).find("byte " + std::to_string(count_at) + ": cavities: count 3 exceeds"),
              std::string::npos)
        << e.what();
  }
}

TEST(SampleLog, AVersionThreeLogReadsEveryFamilyAndItsUnfinishedFormToo) {
  const auto dir = temp_dir("samples_v3");
  const auto path = dir / "agent_002.slrec";
  const auto samples = every_family();
  {
    runtime::SampleLogWriter writer(path, 4, 0xABCDEF);
    for (const auto& s : samples) writer.append(s);
    writer.close();
  }
  const auto v3 = without_checksums(read_bytes(path), 3);
  const auto log = parse_sample_log(v3, "v3.slrec");
  EXPECT_EQ(log.version, 3);
  EXPECT_TRUE(log.complete);
  EXPECT_EQ(log.scenario_hash, 0xABCDEFu);
  ASSERT_EQ(log.samples.size(), samples.size());
  auto expected = samples;
  auto& state = std::get<estimators::StateMessage>(expected[0].message);
  state.edge_ranges.clear();   // new in version 5
  state.inconsistent = false;  // new in version 8
  state.cavities.clear();      // new in version 9
  for (std::size_t k = 0; k < samples.size(); ++k) expect_same(log.samples[k], expected[k]);
  const std::vector<std::uint8_t> cut(v3.begin(), v3.end() - 9 - 20);
  EXPECT_THROW((void)parse_sample_log(cut, "v3-cut.slrec"), RecordingError);
  EXPECT_EQ(parse_sample_log(cut, "v3-cut.slrec", true).samples.size(), 3u);
}

// ---- Checksums (version 4) ----

/// Flips bit `bit` of `bytes`.
std::vector<std::uint8_t> flipped(const std::vector<std::uint8_t>& bytes, std::size_t bit) {
  auto copy = bytes;
  copy[bit / 8] = static_cast<std::uint8_t>(copy[bit / 8] ^ (1u << (bit % 8)));
  return copy;
}

TEST(Recording, EverySingleFlippedBitIsRefusedNamingTheFileAndOffset) {
  const auto dir = temp_dir("bitflips");
  const auto good = read_bytes(write_tiny_recording(dir, 2));
  ASSERT_EQ(load_error(good), "");
  const auto records = records_of(good);
  std::size_t refused = 0;
  std::vector<std::size_t> accepted;
  for (std::size_t bit = 0; bit < 8 * good.size(); ++bit) {
    const auto error = load_error(flipped(good, bit));
    if (error.empty()) {
      accepted.push_back(bit);
      continue;
    }
    ++refused;
    EXPECT_EQ(error.rfind("hostile.slrec: byte ", 0), 0u) << "bit " << bit << ": " << error;
    // A flip inside a record's payload or its checksum names the record's first byte.
    const std::size_t at = bit / 8;
    for (const auto& r : records) {
      if (at >= r.payload_at && at < r.end()) {
        EXPECT_NE(error.find("byte " + std::to_string(r.at) + ": checksum mismatch in the "),
                  std::string::npos)
            << "bit " << bit << ": " << error;
      }
    }
  }
  EXPECT_TRUE(accepted.empty()) << accepted.size() << " single-bit flips were accepted, the first at bit "
                                << accepted.front();
  std::printf("  %zu of %zu single-bit flips of a %zu-byte recording refused\n", refused, 8 * good.size(),
              good.size());
}

TEST(SampleLog, EverySingleFlippedBitIsRefusedEvenWhereAnUnfinishedLogIsAccepted) {
  const auto dir = temp_dir("samples_bitflips");
  const auto path = dir / "agent_002.slrec";
  {
    runtime::SampleLogWriter writer(path, 4, 0xABCDEF);
    for (const auto& s : every_family()) writer.append(s);
    writer.close();
  }
  const auto bytes = read_bytes(path);
  auto refused = [](const std::vector<std::uint8_t>& log, bool allow_unfinished) {
    try {
      (void)parse_sample_log(log, "flip.slrec", allow_unfinished);
    } catch (const RecordingError& error) {
      return std::string(error.what()).rfind("flip.slrec: byte ", 0) == 0;
    }
    return false;
  };
  int accepted = 0;
  for (std::size_t bit = 0; bit < 8 * bytes.size(); ++bit) {
    const auto log = flipped(bytes, bit);
    if (!refused(log, false)) ++accepted, ADD_FAILURE() << "bit " << bit << " accepted";
    // A flipped length must not pass for a record cut by a kill.
    if (!refused(log, true)) ++accepted, ADD_FAILURE() << "bit " << bit << " accepted as unfinished";
  }
  // An unfinished log (killed writer, cut inside the belief): every flip in its complete records is refused;
  // the cut record itself cannot be checked and is dropped.
  const auto records = records_of(bytes);
  const std::vector<std::uint8_t> cut(bytes.begin(),
                                      bytes.begin() + static_cast<std::ptrdiff_t>(records[4].at + 30));
  ASSERT_EQ(parse_sample_log(cut, "flip.slrec", true).samples.size(), 3u);
  for (std::size_t bit = 0; bit < 8 * records[4].at; ++bit) {
    if (!refused(flipped(cut, bit), true))
      ++accepted, ADD_FAILURE() << "bit " << bit << " of the cut log accepted";
  }
  EXPECT_EQ(accepted, 0);
}

TEST(Recording, OldVersionsWithoutChecksumsStillReadBitExactly) {
  const auto dir = temp_dir("old-versions");
  const auto current = read_bytes(write_tiny_recording(dir, 3));
  // World recordings are the same in versions 1 to 3 (the versions changed sample payloads only).
  for (std::uint8_t version : {1, 2, 3}) {
    const auto old = without_checksums(current, version);
    const auto recording = parse_recording(old, "old.slrec");
    EXPECT_EQ(recording->version(), version);
    EXPECT_EQ(recording->scenario_yaml(), config::to_yaml(recorded_scenario()));
    ASSERT_EQ(recording->steps(), 3);
    for (std::int64_t step = 0; step < 3; ++step) {
      for (AgentId i = 0; i < 4; ++i) expect_same(recording->batch(i, step), full_batch(i, step, 4));
    }
    // The old reader's checks still apply: a cut file is refused.
    const std::vector<std::uint8_t> cut(old.begin(), old.end() - 1);
    EXPECT_NE(load_error(cut), "");
  }
}

TEST(Recording, WriteFailuresAndUnreadablePathsAreReported) {
  const auto s = recorded_scenario();
  const auto world = world::build_world(s);
  // A full disk: /dev/full takes the buffered writes and refuses the flush.
  if (std::filesystem::exists("/dev/full")) {
    RecordingWriter writer("/dev/full", s, world);
    try {
      writer.close();
      ADD_FAILURE() << "closing a recording on a full disk did not throw";
    } catch (const runtime::OutputError& error) {
      EXPECT_NE(std::string(error.what()).find("/dev/full: No space left on device"), std::string::npos)
          << error.what();
    }
    runtime::SampleLogWriter samples("/dev/full", 4, 7);
    for (const auto& sample : every_family()) samples.append(sample);
    EXPECT_THROW(samples.close(), runtime::OutputError);
  }
  const auto dir = temp_dir("unwritable");
  { std::ofstream(dir / "file") << "x"; }
  EXPECT_THROW(RecordingWriter(dir / "file" / "recording.slrec", s, world), runtime::OutputError);
  // A run directory instead of its recording: the error says which file to pass.
  try {
    (void)load_recording(dir);
    ADD_FAILURE() << "a directory was read as a recording";
  } catch (const RecordingError& error) {
    EXPECT_EQ(std::string(error.what()),
              dir.string() + ": is a directory; pass " + (dir / kRecordingFile).string());
  }
  const auto empty = dir / "empty.slrec";
  { std::ofstream{empty}; }
  EXPECT_THROW((void)load_recording(empty), RecordingError);
  EXPECT_THROW((void)load_sample_log(empty), RecordingError);
}

}  // namespace
}  // namespace swarmloc::rundir
