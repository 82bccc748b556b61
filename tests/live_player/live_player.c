/* The live player of the live-agent acceptance tests (tests/integration/test_live.cpp and
 * test_live_faults.cpp, docs/live.md): an independent ROS 2-style node in plain Cyclone C with its own IDL
 * (live_msgs.idl, from the ROS .msg files). It plays a recorded world into the robots' driver topics, as a
 * robot's UWB driver, wheel odometry and a motion-capture system would, and prints what the live agents
 * publish: in:  "name <id> <robot>", "range <step> <id> <peer> <range_m> <std_m>", "truth <step> <id> <x>
 * <y>" out: "pose <robot> <sec> <nanosec> <frame> <x> <y>", "tf <parent> <child> <sec> <nanosec> <x> <y>",
 *        "publication <topic> <type>"
 * Per step and robot it writes rt/<robot>/ranges (swarmloc_msgs/RangeArray), rt/<robot>/odom
 * (nav_msgs/Odometry, at rest) and rt/<robot>/truth (geometry_msgs/PoseStamped), stamped with the
 * robot's own clock (1000 (id + 1) s + step / rate). With --fault ID that robot's drivers misbehave:
 * step 40 is sent twice, 61 before 60, nothing for 5 s from step 80, and its clock jumps by +10 s at 150.
 * Usage: live_player DOMAIN INPUT OUTPUT RATE_HZ [--fault ID] [--linger S]. The participant's
 * configuration comes from CYCLONEDDS_URI (deploy/ros2/cyclonedds.xml in the tests). */
#include <dds/dds.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "live_msgs.h"

#define LP_MAX_ROBOTS 64
#define LP_MAX_STEPS 4000
#define LP_MAX_RANGES 64
#define LP_TAKE 32

typedef struct {
  char name[64];
  char base[80];
  char odom_frame[80];
  int nranges[LP_MAX_STEPS];
  swarmloc_msgs_msg_dds__Range_ ranges[LP_MAX_STEPS][LP_MAX_RANGES];
  double truth[LP_MAX_STEPS][2];
  dds_entity_t ranges_writer, odom_writer, truth_writer, pose_reader;
} lp_robot;

static lp_robot lp_robots[LP_MAX_ROBOTS];
static int lp_count = 0;
static int lp_steps = 0;
static FILE* lp_out = NULL;

static void lp_fail(const char* what, const char* detail) {
  fprintf(stderr, "live_player: %s %s\n", what, detail);
  exit(1);
}

static void lp_read_input(const char* path) {
  FILE* in = fopen(path, "r");
  if (in == NULL) lp_fail("cannot read", path);
  char kind[16];
  while (fscanf(in, "%15s", kind) == 1) {
    int step = 0, id = 0, peer = 0;
    double a = 0.0, b = 0.0;
    if (strcmp(kind, "name") == 0) {
      char name[64];
      if (fscanf(in, "%d %63s", &id, name) != 2 || id < 0 || id >= LP_MAX_ROBOTS)
        lp_fail("bad name line", path);
      snprintf(lp_robots[id].name, sizeof lp_robots[id].name, "%s", name);
      if (id + 1 > lp_count) lp_count = id + 1;
    } else if (strcmp(kind, "range") == 0) {
      if (fscanf(in, "%d %d %d %lf %lf", &step, &id, &peer, &a, &b) != 5 || step < 0 ||
          step >= LP_MAX_STEPS || id < 0 || id >= LP_MAX_ROBOTS ||
          lp_robots[id].nranges[step] >= LP_MAX_RANGES)
        lp_fail("bad range line", path);
      swarmloc_msgs_msg_dds__Range_* r = &lp_robots[id].ranges[step][lp_robots[id].nranges[step]++];
      r->agent = id;
      r->peer = peer;
      r->range_m = a;
      r->std_m = b;
      if (step + 1 > lp_steps) lp_steps = step + 1;
    } else if (strcmp(kind, "truth") == 0) {
      if (fscanf(in, "%d %d %lf %lf", &step, &id, &a, &b) != 4 || step < 0 || step >= LP_MAX_STEPS ||
          id < 0 || id >= LP_MAX_ROBOTS)
        lp_fail("bad truth line", path);
      lp_robots[id].truth[step][0] = a;
      lp_robots[id].truth[step][1] = b;
    } else {
      lp_fail("unknown line kind", kind);
    }
  }
  fclose(in);
}

static dds_qos_t* lp_ros2_qos(int depth) {
  /* ROS 2's default profile: reliable, keep-last, volatile. */
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, depth);
  dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
  return qos;
}

static dds_entity_t lp_endpoint(dds_entity_t pp, const dds_topic_descriptor_t* desc, const char* robot,
                                const char* leaf, int reader) {
  char name[160];
  if (robot != NULL)
    snprintf(name, sizeof name, "rt/%s/%s", robot, leaf);
  else
    snprintf(name, sizeof name, "rt/%s", leaf);
  dds_entity_t topic = dds_create_topic(pp, desc, name, NULL, NULL);
  if (topic < 0) lp_fail("dds_create_topic", name);
  dds_qos_t* qos = lp_ros2_qos(reader ? 1000 : 10);
  dds_entity_t e = reader ? dds_create_reader(pp, topic, qos, NULL) : dds_create_writer(pp, topic, qos, NULL);
  dds_delete_qos(qos);
  if (e < 0) lp_fail(reader ? "dds_create_reader" : "dds_create_writer", name);
  return e;
}

static void lp_stamp(std_msgs_msg_dds__Header_* h, long long stamp_ns, char* frame) {
  h->stamp.sec = (int32_t)(stamp_ns / 1000000000LL);
  h->stamp.nanosec = (uint32_t)(stamp_ns % 1000000000LL);
  h->frame_id = frame;
}

static void lp_publish(int id, int step, long long stamp_ns) {
  lp_robot* r = &lp_robots[id];
  swarmloc_msgs_msg_dds__RangeArray_ ranges;
  memset(&ranges, 0, sizeof ranges);
  lp_stamp(&ranges.header, stamp_ns, r->base);
  ranges.step = step;
  ranges.ranges._length = ranges.ranges._maximum = (uint32_t)r->nranges[step];
  ranges.ranges._buffer = r->ranges[step];
  ranges.ranges._release = false;
  if (dds_write(r->ranges_writer, &ranges) < 0) lp_fail("dds_write ranges", r->name);
  nav_msgs_msg_dds__Odometry_ odom;
  memset(&odom, 0, sizeof odom);
  lp_stamp(&odom.header, stamp_ns, r->odom_frame);
  odom.child_frame_id = r->base;
  odom.pose.pose.orientation.w = 1.0;
  if (dds_write(r->odom_writer, &odom) < 0) lp_fail("dds_write odom", r->name);
  geometry_msgs_msg_dds__PoseStamped_ truth;
  memset(&truth, 0, sizeof truth);
  static char map[] = "map";
  lp_stamp(&truth.header, stamp_ns, map);
  truth.pose.position.x = r->truth[step][0];
  truth.pose.position.y = r->truth[step][1];
  truth.pose.orientation.w = 1.0;
  if (dds_write(r->truth_writer, &truth) < 0) lp_fail("dds_write truth", r->name);
}

/* Takes what `reader` holds and prints each valid sample with `print`. */
static void lp_take(dds_entity_t reader, void (*print)(const void*, const char*), const char* robot) {
  void* samples[LP_TAKE] = {NULL};
  dds_sample_info_t infos[LP_TAKE];
  int32_t n;
  while ((n = dds_take(reader, samples, infos, LP_TAKE, LP_TAKE)) > 0) {
    for (int32_t k = 0; k < n; k++)
      if (infos[k].valid_data) print(samples[k], robot);
    dds_return_loan(reader, samples, n);
  }
}

static void lp_print_pose(const void* sample, const char* robot) {
  const geometry_msgs_msg_dds__PoseWithCovarianceStamped_* p = sample;
  fprintf(lp_out, "pose %s %d %u %s %.17g %.17g\n", robot, p->header.stamp.sec, p->header.stamp.nanosec,
          p->header.frame_id, p->pose.pose.position.x, p->pose.pose.position.y);
}

static void lp_print_tf(const void* sample, const char* unused) {
  (void)unused;
  const tf2_msgs_msg_dds__TFMessage_* m = sample;
  for (uint32_t k = 0; k < m->transforms._length; k++) {
    const geometry_msgs_msg_dds__TransformStamped_* t = &m->transforms._buffer[k];
    fprintf(lp_out, "tf %s %s %d %u %.17g %.17g\n", t->header.frame_id, t->child_frame_id,
            t->header.stamp.sec, t->header.stamp.nanosec, t->transform.translation.x,
            t->transform.translation.y);
  }
}

static void lp_print_publication(const void* sample, const char* unused) {
  (void)unused;
  const dds_builtintopic_endpoint_t* e = sample;
  fprintf(lp_out, "publication %s %s\n", e->topic_name, e->type_name);
}

static void lp_drain(dds_entity_t tf, dds_entity_t publications) {
  for (int id = 0; id < lp_count; id++) lp_take(lp_robots[id].pose_reader, lp_print_pose, lp_robots[id].name);
  lp_take(tf, lp_print_tf, NULL);
  lp_take(publications, lp_print_publication, NULL);
}

/* Waits up to 60 s until every robot's range writer reaches its agent's reader, then gives the agents
 * time to discover one another. */
static void lp_wait_for_agents(void) {
  const dds_time_t deadline = dds_time() + DDS_SECS(60);
  for (int id = 0; id < lp_count; id++) {
    dds_publication_matched_status_t status;
    while (dds_get_publication_matched_status(lp_robots[id].ranges_writer, &status) >= 0 &&
           status.current_count == 0) {
      if (dds_time() > deadline) lp_fail("no agent reads the ranges of", lp_robots[id].name);
      dds_sleepfor(DDS_MSECS(50));
    }
  }
  dds_sleepfor(DDS_SECS(3));
}

/* Robot `id`'s messages of `step` in the order its drivers send them (fault: see the top). */
static void lp_play_step(int id, int step, double rate_hz, int fault) {
  const long long period_ns = (long long)(1e9 / rate_hz);
  long long stamp_ns = 1000000000000LL * (id + 1) + step * period_ns;
  if (id != fault) {
    lp_publish(id, step, stamp_ns);
    return;
  }
  const int stop_from = 80, stop_to = 80 + (int)(5.0 * rate_hz);
  if (step >= 150) stamp_ns += 10000000000LL;      /* the robot's clock jumps by +10 s */
  if (step >= stop_from && step < stop_to) return; /* the driver stops for 5 s */
  if (step == 60) return;                          /* held back: sent after 61 */
  lp_publish(id, step, stamp_ns);
  if (step == 40) lp_publish(id, step, stamp_ns); /* sent twice */
  if (step == 61) lp_publish(id, 60, stamp_ns - period_ns);
}

int main(int argc, char** argv) {
  if (argc < 5) {
    fprintf(stderr, "usage: live_player DOMAIN INPUT OUTPUT RATE_HZ [--fault ID] [--linger S]\n");
    return 2;
  }
  const int domain = atoi(argv[1]);
  const double rate_hz = atof(argv[4]);
  int fault = -1;
  double linger_s = 1.0;
  for (int k = 5; k + 1 < argc; k += 2) {
    if (strcmp(argv[k], "--fault") == 0) fault = atoi(argv[k + 1]);
    if (strcmp(argv[k], "--linger") == 0) linger_s = atof(argv[k + 1]);
  }
  if (!(rate_hz > 0.0)) lp_fail("bad rate", argv[4]);
  lp_read_input(argv[2]);
  lp_out = fopen(argv[3], "w");
  if (lp_out == NULL) lp_fail("cannot write", argv[3]);

  const dds_entity_t pp = dds_create_participant((dds_domainid_t)domain, NULL, NULL);
  if (pp < 0) lp_fail("dds_create_participant", dds_strretcode(pp));
  for (int id = 0; id < lp_count; id++) {
    lp_robot* r = &lp_robots[id];
    if (r->name[0] == '\0') lp_fail("no name for a robot id", argv[2]);
    snprintf(r->base, sizeof r->base, "%.63s/base_link", r->name);
    snprintf(r->odom_frame, sizeof r->odom_frame, "%.63s/odom", r->name);
    r->ranges_writer = lp_endpoint(pp, &swarmloc_msgs_msg_dds__RangeArray__desc, r->name, "ranges", 0);
    r->odom_writer = lp_endpoint(pp, &nav_msgs_msg_dds__Odometry__desc, r->name, "odom", 0);
    r->truth_writer = lp_endpoint(pp, &geometry_msgs_msg_dds__PoseStamped__desc, r->name, "truth", 0);
    r->pose_reader =
        lp_endpoint(pp, &geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc, r->name, "pose", 1);
  }
  const dds_entity_t tf = lp_endpoint(pp, &tf2_msgs_msg_dds__TFMessage__desc, NULL, "tf", 1);
  const dds_entity_t publications = dds_create_reader(pp, DDS_BUILTIN_TOPIC_DCPSPUBLICATION, NULL, NULL);
  if (publications < 0) lp_fail("DCPSPublication reader", dds_strretcode(publications));

  lp_wait_for_agents();
  const dds_duration_t period = (dds_duration_t)(1e9 / rate_hz);
  dds_time_t next = dds_time();
  for (int step = 0; step < lp_steps; step++) {
    for (int id = 0; id < lp_count; id++) lp_play_step(id, step, rate_hz, fault);
    lp_drain(tf, publications);
    next += period;
    const dds_time_t now = dds_time();
    if (next > now) dds_sleepfor(next - now);
  }
  const dds_time_t end = dds_time() + (dds_duration_t)(linger_s * 1e9);
  while (dds_time() < end) {
    lp_drain(tf, publications);
    dds_sleepfor(DDS_MSECS(20));
  }
  lp_drain(tf, publications);
  fclose(lp_out);
  dds_delete(pp);
  return 0;
}
