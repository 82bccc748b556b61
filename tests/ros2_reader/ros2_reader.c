/* An independent ROS 2-style reader for the dds.ros2 acceptance test (tests/integration/test_ros2.cpp,
 * docs/ros2.md). Plain Cyclone C with its own IDL (ros2_msgs.idl, from the ROS .msg files): it creates
 * the topics a ROS 2 node would (rt/<name>, pkg::msg::dds_::Name_, ROS 2's default QoS, default
 * partition) and prints every sample it takes, one per line, plus every writer the DCPSPublication
 * built-in topic announces:
 *   pose <agent> <sec> <nanosec> <frame_id> <x> <y> <z> <qx> <qy> <qz> <qw> <covariance[0..35]>
 *   truth <sec> <nanosec> <frame_id> <count> <x0> <y0> <z0> <qw0> ...
 *   ranges <step> <sec> <nanosec> <frame_id> <count> <agent> <peer> <range_m> <std_m> ...
 *   publication <topic name> <type name>
 * With --murp (replay --murp --ros2, tests/integration/test_murp_ros2.cpp) it reads instead, for every
 * ordered pair of VEHICLES (e.g. 1,2,3), rt/swarmloc/murp/vehicle_<A>/vehicle_<B>/pose and …/truth:
 *   murp_pose <A> <B> <sec> <nanosec> <frame_id> <x> <y> <z> <qx> <qy> <qz> <qw> <covariance[0..35]>
 *   murp_truth <A> <B> <sec> <nanosec> <frame_id> <x> <y> <z> <qx> <qy> <qz> <qw>
 * keeping up to 1000 samples per topic (a replay is a burst of windows; the history depth is the reader's
 * own choice and plays no part in matching).
 * The participant's configuration comes from CYCLONEDDS_URI (the test uses deploy/ros2/cyclonedds.xml).
 * Usage: ros2_reader DOMAIN AGENTS MAX_SECONDS, or ros2_reader --murp DOMAIN VEHICLES MAX_SECONDS. Ends
 * once the writers it matched are gone (the run ended; without --murp: the truth writer came and went and
 * no pose writer is left), or after MAX_SECONDS. */
#include <dds/dds.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ros2_msgs.h"

#define ROS2_READER_BATCH 32
#define ROS2_READER_MAX_VEHICLES 8

static dds_entity_t ros2_reader_create_with_depth(dds_entity_t participant,
                                                  const dds_topic_descriptor_t* descriptor,
                                                  const char* topic_name, int32_t depth) {
  dds_entity_t topic = dds_create_topic(participant, descriptor, topic_name, NULL, NULL);
  if (topic < 0) {
    fprintf(stderr, "dds_create_topic %s: %s\n", topic_name, dds_strretcode(topic));
    exit(1);
  }
  /* ROS 2's default profile: reliable, keep-last 10 (unless told otherwise), volatile. */
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, depth);
  dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
  dds_entity_t reader = dds_create_reader(participant, topic, qos, NULL);
  dds_delete_qos(qos);
  if (reader < 0) {
    fprintf(stderr, "dds_create_reader %s: %s\n", topic_name, dds_strretcode(reader));
    exit(1);
  }
  return reader;
}

static dds_entity_t ros2_reader_create(dds_entity_t participant, const dds_topic_descriptor_t* descriptor,
                                       const char* topic_name) {
  return ros2_reader_create_with_depth(participant, descriptor, topic_name, 10);
}

static int32_t ros2_reader_matched(dds_entity_t reader, uint32_t* ever) {
  dds_subscription_matched_status_t status;
  if (dds_get_subscription_matched_status(reader, &status) < 0) return 0;
  if (status.total_count > *ever) *ever = status.total_count;
  return status.current_count;
}

static void ros2_reader_print_header(const std_msgs_msg_dds__Header_* header) {
  printf(" %d %u %s", header->stamp.sec, header->stamp.nanosec,
         header->frame_id != NULL && header->frame_id[0] != '\0' ? header->frame_id : "-");
}

static void ros2_reader_print_pose(const void* sample, int agent, int unused) {
  (void)unused;
  const geometry_msgs_msg_dds__PoseWithCovarianceStamped_* pose = sample;
  const geometry_msgs_msg_dds__Pose_* p = &pose->pose.pose;
  printf("pose %d", agent);
  ros2_reader_print_header(&pose->header);
  printf(" %.17g %.17g %.17g %.17g %.17g %.17g %.17g", p->position.x, p->position.y, p->position.z,
         p->orientation.x, p->orientation.y, p->orientation.z, p->orientation.w);
  for (int k = 0; k < 36; k++) printf(" %.17g", pose->pose.covariance[k]);
  printf("\n");
}

static void ros2_reader_print_truth(const void* sample, int agent, int unused) {
  (void)agent;
  (void)unused;
  const geometry_msgs_msg_dds__PoseArray_* array = sample;
  printf("truth");
  ros2_reader_print_header(&array->header);
  printf(" %u", array->poses._length);
  for (uint32_t k = 0; k < array->poses._length; k++) {
    const geometry_msgs_msg_dds__Pose_* p = &array->poses._buffer[k];
    printf(" %.17g %.17g %.17g %.17g", p->position.x, p->position.y, p->position.z, p->orientation.w);
  }
  printf("\n");
}

static void ros2_reader_print_ranges(const void* sample, int agent, int unused) {
  (void)agent;
  (void)unused;
  const swarmloc_msgs_msg_dds__RangeArray_* array = sample;
  printf("ranges %lld", (long long)array->step);
  ros2_reader_print_header(&array->header);
  printf(" %u", array->ranges._length);
  for (uint32_t k = 0; k < array->ranges._length; k++) {
    const swarmloc_msgs_msg_dds__Range_* r = &array->ranges._buffer[k];
    printf(" %d %d %.17g %.17g", r->agent, r->peer, r->range_m, r->std_m);
  }
  printf("\n");
}

static void ros2_reader_print_publication(const void* sample, int agent, int unused) {
  (void)agent;
  (void)unused;
  const dds_builtintopic_endpoint_t* endpoint = sample;
  printf("publication %s %s\n", endpoint->topic_name, endpoint->type_name);
}

static void ros2_reader_print_murp_pose_fields(const geometry_msgs_msg_dds__Pose_* p) {
  printf(" %.17g %.17g %.17g %.17g %.17g %.17g %.17g", p->position.x, p->position.y, p->position.z,
         p->orientation.x, p->orientation.y, p->orientation.z, p->orientation.w);
}

static void ros2_reader_print_murp_pose(const void* sample, int observer, int peer) {
  const geometry_msgs_msg_dds__PoseWithCovarianceStamped_* pose = sample;
  printf("murp_pose %d %d", observer, peer);
  ros2_reader_print_header(&pose->header);
  ros2_reader_print_murp_pose_fields(&pose->pose.pose);
  for (int k = 0; k < 36; k++) printf(" %.17g", pose->pose.covariance[k]);
  printf("\n");
}

static void ros2_reader_print_murp_truth(const void* sample, int observer, int peer) {
  const geometry_msgs_msg_dds__PoseStamped_* pose = sample;
  printf("murp_truth %d %d", observer, peer);
  ros2_reader_print_header(&pose->header);
  ros2_reader_print_murp_pose_fields(&pose->pose);
  printf("\n");
}

/// Takes every sample waiting on `reader` and prints each valid one with `print`.
static void ros2_reader_take(dds_entity_t reader, void (*print)(const void*, int, int), int a, int b) {
  void* samples[ROS2_READER_BATCH] = {NULL};
  dds_sample_info_t infos[ROS2_READER_BATCH];
  int32_t count;
  while ((count = dds_take(reader, samples, infos, ROS2_READER_BATCH, ROS2_READER_BATCH)) > 0) {
    for (int32_t i = 0; i < count; i++) {
      if (infos[i].valid_data) print(samples[i], a, b);
    }
    dds_return_loan(reader, samples, count);
  }
}

static dds_entity_t ros2_reader_publications(dds_entity_t participant) {
  const dds_entity_t publications =
      dds_create_reader(participant, DDS_BUILTIN_TOPIC_DCPSPUBLICATION, NULL, NULL);
  if (publications < 0) {
    fprintf(stderr, "DCPSPublication reader: %s\n", dds_strretcode(publications));
    exit(1);
  }
  return publications;
}

/* --murp: every ordered pair's pose and truth topics (replay --murp --ros2). */
static int ros2_reader_murp(dds_domainid_t domain, const char* vehicle_list, double max_seconds) {
  int vehicles[ROS2_READER_MAX_VEHICLES];
  int count = 0;
  for (const char* at = vehicle_list; *at != '\0' && count < ROS2_READER_MAX_VEHICLES;) {
    char* end = NULL;
    const long vehicle = strtol(at, &end, 10);
    if (end == at) break;
    vehicles[count++] = (int)vehicle;
    at = *end == ',' ? end + 1 : end;
  }
  if (count < 2) {
    fprintf(stderr, "VEHICLES: at least two ids, comma-separated\n");
    return 2;
  }
  const dds_entity_t participant = dds_create_participant(domain, NULL, NULL);
  if (participant < 0) {
    fprintf(stderr, "dds_create_participant: %s\n", dds_strretcode(participant));
    return 1;
  }
  enum { kMaxPairs = ROS2_READER_MAX_VEHICLES * (ROS2_READER_MAX_VEHICLES - 1) };
  dds_entity_t pose_readers[kMaxPairs], truth_readers[kMaxPairs];
  int observers[kMaxPairs], peers[kMaxPairs];
  uint32_t ever[2 * kMaxPairs] = {0};
  int pairs = 0;
  const dds_entity_t waitset = dds_create_waitset(participant);
  for (int a = 0; a < count; a++) {
    for (int b = 0; b < count; b++) {
      if (a == b) continue;
      char topic[96];
      observers[pairs] = vehicles[a];
      peers[pairs] = vehicles[b];
      snprintf(topic, sizeof topic, "rt/swarmloc/murp/vehicle_%d/vehicle_%d/pose", vehicles[a], vehicles[b]);
      pose_readers[pairs] = ros2_reader_create_with_depth(
          participant, &geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc, topic, 1000);
      snprintf(topic, sizeof topic, "rt/swarmloc/murp/vehicle_%d/vehicle_%d/truth", vehicles[a], vehicles[b]);
      truth_readers[pairs] =
          ros2_reader_create_with_depth(participant, &geometry_msgs_msg_dds__PoseStamped__desc, topic, 1000);
      dds_waitset_attach(waitset, dds_create_readcondition(pose_readers[pairs], DDS_ANY_STATE), 0);
      dds_waitset_attach(waitset, dds_create_readcondition(truth_readers[pairs], DDS_ANY_STATE), 0);
      pairs++;
    }
  }
  const dds_entity_t publications = ros2_reader_publications(participant);
  dds_waitset_attach(waitset, dds_create_readcondition(publications, DDS_ANY_STATE), 0);

  const dds_time_t deadline = dds_time() + (dds_duration_t)(max_seconds * 1e9);
  int ended = 0;
  int met = 0;
  while (!ended && dds_time() < deadline) {
    dds_waitset_wait(waitset, NULL, 0, DDS_MSECS(100));
    int live = 0;
    met = 0;
    for (int k = 0; k < pairs; k++) {
      ros2_reader_take(pose_readers[k], ros2_reader_print_murp_pose, observers[k], peers[k]);
      ros2_reader_take(truth_readers[k], ros2_reader_print_murp_truth, observers[k], peers[k]);
      live += ros2_reader_matched(pose_readers[k], &ever[2 * k]);
      live += ros2_reader_matched(truth_readers[k], &ever[2 * k + 1]);
    }
    ros2_reader_take(publications, ros2_reader_print_publication, 0, 0);
    fflush(stdout);
    for (int k = 0; k < 2 * pairs; k++) met += ever[k] > 0 ? 1 : 0;
    /* The run is over once every writer that came has gone (a last take below). */
    ended = met > 0 && live == 0;
  }
  for (int k = 0; k < pairs; k++) {
    ros2_reader_take(pose_readers[k], ros2_reader_print_murp_pose, observers[k], peers[k]);
    ros2_reader_take(truth_readers[k], ros2_reader_print_murp_truth, observers[k], peers[k]);
  }
  fflush(stdout);
  fprintf(stderr, "ros2_reader --murp: %s; met %d of %d writers\n",
          ended ? "the run ended" : "MAX_SECONDS passed", met, 2 * pairs);
  dds_delete(participant);
  return 0;
}

int main(int argc, char** argv) {
  if (argc == 5 && strcmp(argv[1], "--murp") == 0) {
    const double max_seconds = atof(argv[4]);
    if (max_seconds <= 0.0) {
      fprintf(stderr, "MAX_SECONDS must be positive\n");
      return 2;
    }
    return ros2_reader_murp((dds_domainid_t)atoi(argv[2]), argv[3], max_seconds);
  }
  if (argc != 4) {
    fprintf(stderr, "usage: %s DOMAIN AGENTS MAX_SECONDS | %s --murp DOMAIN VEHICLES MAX_SECONDS\n", argv[0],
            argv[0]);
    return 2;
  }
  const dds_domainid_t domain = (dds_domainid_t)atoi(argv[1]);
  const int agents = atoi(argv[2]);
  const double max_seconds = atof(argv[3]);
  if (agents <= 0 || max_seconds <= 0.0) {
    fprintf(stderr, "AGENTS and MAX_SECONDS must be positive\n");
    return 2;
  }
  const dds_entity_t participant = dds_create_participant(domain, NULL, NULL);
  if (participant < 0) {
    fprintf(stderr, "dds_create_participant: %s\n", dds_strretcode(participant));
    return 1;
  }
  dds_entity_t* pose_readers = calloc((size_t)agents, sizeof *pose_readers);
  uint32_t* pose_ever = calloc((size_t)agents, sizeof *pose_ever);
  for (int agent = 0; agent < agents; agent++) {
    char topic[64];
    snprintf(topic, sizeof topic, "rt/swarmloc/agent_%d/pose", agent);
    pose_readers[agent] =
        ros2_reader_create(participant, &geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc, topic);
  }
  const dds_entity_t truth_reader =
      ros2_reader_create(participant, &geometry_msgs_msg_dds__PoseArray__desc, "rt/swarmloc/truth");
  const dds_entity_t ranges_reader =
      ros2_reader_create(participant, &swarmloc_msgs_msg_dds__RangeArray__desc, "rt/swarmloc/ranges");
  const dds_entity_t publications = ros2_reader_publications(participant);

  const dds_entity_t waitset = dds_create_waitset(participant);
  for (int agent = 0; agent < agents; agent++)
    dds_waitset_attach(waitset, dds_create_readcondition(pose_readers[agent], DDS_ANY_STATE), 0);
  dds_waitset_attach(waitset, dds_create_readcondition(truth_reader, DDS_ANY_STATE), 0);
  dds_waitset_attach(waitset, dds_create_readcondition(ranges_reader, DDS_ANY_STATE), 0);
  dds_waitset_attach(waitset, dds_create_readcondition(publications, DDS_ANY_STATE), 0);

  const dds_time_t deadline = dds_time() + (dds_duration_t)(max_seconds * 1e9);
  uint32_t truth_ever = 0;
  int ended = 0;
  while (!ended && dds_time() < deadline) {
    dds_waitset_wait(waitset, NULL, 0, DDS_MSECS(100));
    for (int agent = 0; agent < agents; agent++)
      ros2_reader_take(pose_readers[agent], ros2_reader_print_pose, agent, 0);
    ros2_reader_take(truth_reader, ros2_reader_print_truth, 0, 0);
    ros2_reader_take(ranges_reader, ros2_reader_print_ranges, 0, 0);
    ros2_reader_take(publications, ros2_reader_print_publication, 0, 0);
    fflush(stdout);
    /* The run is over once the truth writer came and went and no pose writer is left. */
    int live = ros2_reader_matched(truth_reader, &truth_ever);
    for (int agent = 0; agent < agents; agent++)
      live += ros2_reader_matched(pose_readers[agent], &pose_ever[agent]);
    ended = truth_ever > 0 && live == 0;
  }
  int pose_writers_met = 0;
  for (int agent = 0; agent < agents; agent++) pose_writers_met += pose_ever[agent] > 0 ? 1 : 0;
  fprintf(stderr, "ros2_reader: %s; matched the truth writer %u times, %d of %d agents' pose writers\n",
          ended ? "the run ended" : "MAX_SECONDS passed", truth_ever, pose_writers_met, agents);
  free(pose_readers);
  free(pose_ever);
  dds_delete(participant);
  return 0;
}
