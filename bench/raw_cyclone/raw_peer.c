/* One peer of the raw Cyclone DDS benchmark (bench/raw_cyclone/raw_cyclone.sh,
 * docs/measurements/raw-cyclone.md). Plain Cyclone C API, no swarmloc code: what a bare
 * reader/writer pair costs, to compare with the swarmloc-agent processes.
 *
 * Peer ID has one writer in partition "a<ID>" and one reader whose subscriber lists the partitions
 * "a<j>" of its neighbours j; both best-effort, keep-last 1, volatile; a sample carries BYTES bytes
 * of payload (an octet sequence). It writes one sample every 100 ms of its own monotonic clock, at a
 * random phase within the period, from the moment it starts. A data-available listener takes every
 * sample and counts it. The measured window is [START, START + SECONDS) of the wall clock (START in
 * seconds since the epoch, the same for every peer); at its edges the peer reads getrusage (user +
 * system CPU of all its threads) and its counters. It keeps writing for LINGER seconds after the window
 * (so the others' windows do not see it leave), then prints one line and exits:
 *   raw_peer id=I written=W received=R cpu_s=C window_s=E matched_writers=M matched_readers=K neighbours=D
 * where W, R and C are counted in the window only, E is the window as this peer timed it, and M and K
 * are the matched remote writers and readers at the window start (D each when discovery is complete).
 * The participant's configuration comes from CYCLONEDDS_URI (the launcher writes one per peer).
 *
 * Usage: raw_peer ID DOMAIN NEIGHBOURS START SECONDS [BYTES [LINGER]]
 *   NEIGHBOURS: comma-separated peer ids, or "-" for none. BYTES defaults to 200, LINGER to 1 s. */
#define _GNU_SOURCE
#include <dds/dds.h>
#include <errno.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#include "raw_sample.h"

#define RAW_PEER_PERIOD_NS INT64_C(100000000) /* 100 ms */
#define RAW_PEER_BATCH 16

static atomic_uint_fast64_t raw_peer_received;

static void raw_peer_fail(const char* what, dds_return_t rc) {
  fprintf(stderr, "raw_peer: %s: %s\n", what, dds_strretcode(rc));
  exit(1);
}

static int64_t raw_peer_now_ns(clockid_t clock) {
  struct timespec ts;
  clock_gettime(clock, &ts);
  return (int64_t)ts.tv_sec * INT64_C(1000000000) + ts.tv_nsec;
}

static void raw_peer_sleep_until(int64_t monotonic_ns) {
  struct timespec ts = {.tv_sec = (time_t)(monotonic_ns / INT64_C(1000000000)),
                        .tv_nsec = (long)(monotonic_ns % INT64_C(1000000000))};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR) {
  }
}

static double raw_peer_cpu_seconds(void) {
  struct rusage usage;
  getrusage(RUSAGE_SELF, &usage);
  return (double)usage.ru_utime.tv_sec + (double)usage.ru_utime.tv_usec * 1e-6 +
         (double)usage.ru_stime.tv_sec + (double)usage.ru_stime.tv_usec * 1e-6;
}

/* The listener: take everything available (loaned samples) and count the valid ones. */
static void raw_peer_on_data_available(dds_entity_t reader, void* arg) {
  (void)arg;
  void* samples[RAW_PEER_BATCH];
  dds_sample_info_t infos[RAW_PEER_BATCH];
  for (;;) {
    samples[0] = NULL;
    const dds_return_t n = dds_take(reader, samples, infos, RAW_PEER_BATCH, RAW_PEER_BATCH);
    if (n <= 0) break;
    uint_fast64_t valid = 0;
    for (dds_return_t k = 0; k < n; k++) {
      if (infos[k].valid_data) valid++;
    }
    atomic_fetch_add_explicit(&raw_peer_received, valid, memory_order_relaxed);
    dds_return_loan(reader, samples, n);
    if (n < RAW_PEER_BATCH) break;
  }
}

/* "3,17,42" -> a freshly allocated array of partition names "a3", "a17", "a42". */
static uint32_t raw_peer_partitions(const char* list, char*** names_out) {
  *names_out = NULL;
  if (strcmp(list, "-") == 0 || list[0] == '\0') return 0;
  uint32_t count = 1;
  for (const char* c = list; *c != '\0'; c++) count += (*c == ',');
  char** names = calloc(count, sizeof *names);
  uint32_t n = 0;
  const char* p = list;
  while (*p != '\0' && n < count) {
    char* end = NULL;
    const long id = strtol(p, &end, 10);
    if (end == p || id < 0) {
      fprintf(stderr, "raw_peer: bad neighbour list '%s'\n", list);
      exit(2);
    }
    names[n] = malloc(24);
    snprintf(names[n], 24, "a%ld", id);
    n++;
    p = (*end == ',') ? end + 1 : end;
  }
  *names_out = names;
  return n;
}

static void raw_peer_qos_data(dds_qos_t* qos) {
  dds_qset_reliability(qos, DDS_RELIABILITY_BEST_EFFORT, 0);
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 1);
  dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
}

int main(int argc, char** argv) {
  if (argc < 6) {
    fprintf(stderr, "usage: %s ID DOMAIN NEIGHBOURS START SECONDS [BYTES [LINGER]]\n", argv[0]);
    return 2;
  }
  const int id = atoi(argv[1]);
  const dds_domainid_t domain = (dds_domainid_t)strtoul(argv[2], NULL, 10);
  const char* neighbours = argv[3];
  const double start_epoch = strtod(argv[4], NULL);
  const double seconds = strtod(argv[5], NULL);
  const long bytes = argc > 6 ? strtol(argv[6], NULL, 10) : 200;
  const double linger = argc > 7 ? strtod(argv[7], NULL) : 1.0;
  if (id < 0 || seconds <= 0 || bytes < 0 || linger < 0) {
    fprintf(stderr, "raw_peer: bad arguments\n");
    return 2;
  }

  /* The wall-clock window, on the monotonic clock. */
  const int64_t mono0 = raw_peer_now_ns(CLOCK_MONOTONIC);
  const int64_t real0 = raw_peer_now_ns(CLOCK_REALTIME);
  const int64_t window_start = mono0 + (int64_t)(start_epoch * 1e9) - real0;
  const int64_t window_end = window_start + (int64_t)(seconds * 1e9);
  const int64_t exit_at = window_end + (int64_t)(linger * 1e9);

  const dds_entity_t participant = dds_create_participant(domain, NULL, NULL);
  if (participant < 0) raw_peer_fail("dds_create_participant", participant);
  const dds_entity_t topic =
      dds_create_topic(participant, &raw_cyclone_Sample_desc, "raw_cyclone_sample", NULL, NULL);
  if (topic < 0) raw_peer_fail("dds_create_topic", topic);

  char own_partition[24];
  snprintf(own_partition, sizeof own_partition, "a%d", id);
  dds_qos_t* qos = dds_create_qos();
  dds_qset_partition1(qos, own_partition);
  const dds_entity_t publisher = dds_create_publisher(participant, qos, NULL);
  dds_delete_qos(qos);
  if (publisher < 0) raw_peer_fail("dds_create_publisher", publisher);

  char** names = NULL;
  const uint32_t degree = raw_peer_partitions(neighbours, &names);
  qos = dds_create_qos();
  if (degree > 0)
    dds_qset_partition(qos, degree, (const char**)names);
  else
    dds_qset_partition1(qos, "none"); /* no neighbours: match no writer */
  const dds_entity_t subscriber = dds_create_subscriber(participant, qos, NULL);
  dds_delete_qos(qos);
  if (subscriber < 0) raw_peer_fail("dds_create_subscriber", subscriber);

  qos = dds_create_qos();
  raw_peer_qos_data(qos);
  const dds_entity_t writer = dds_create_writer(publisher, topic, qos, NULL);
  if (writer < 0) raw_peer_fail("dds_create_writer", writer);
  dds_listener_t* listener = dds_create_listener(NULL);
  dds_lset_data_available(listener, raw_peer_on_data_available);
  const dds_entity_t reader = dds_create_reader(subscriber, topic, qos, listener);
  dds_delete_listener(listener);
  dds_delete_qos(qos);
  if (reader < 0) raw_peer_fail("dds_create_reader", reader);

  raw_cyclone_Sample sample;
  memset(&sample, 0, sizeof sample);
  sample.id = id;
  sample.payload._length = sample.payload._maximum = (uint32_t)bytes;
  sample.payload._buffer = bytes > 0 ? malloc((size_t)bytes) : NULL;
  for (long k = 0; k < bytes; k++) sample.payload._buffer[k] = (uint8_t)(k * 7 + id);
  sample.payload._release = false;

  /* A random phase within the period, like the agents' spread tick phases. */
  srand48((long)id * 7919 + (long)getpid() + (long)(real0 % 1000003));
  int64_t next_write = raw_peer_now_ns(CLOCK_MONOTONIC) + (int64_t)(drand48() * (double)RAW_PEER_PERIOD_NS);

  uint64_t written = 0;
  uint64_t written_at_start = 0, received_at_start = 0, written_in = 0, received_in = 0;
  double cpu_at_start = 0, cpu_in = 0;
  int64_t started_at = 0, ended_at = 0;
  int32_t matched_writers = -1, matched_readers = -1;
  int phase = 0; /* 0 before the window, 1 in it, 2 after it */

  for (;;) {
    int64_t wake = next_write;
    if (phase == 0 && window_start < wake) wake = window_start;
    if (phase == 1 && window_end < wake) wake = window_end;
    if (phase == 2 && exit_at < wake) wake = exit_at;
    raw_peer_sleep_until(wake);
    const int64_t now = raw_peer_now_ns(CLOCK_MONOTONIC);

    if (phase == 0 && now >= window_start) {
      cpu_at_start = raw_peer_cpu_seconds();
      received_at_start = atomic_load_explicit(&raw_peer_received, memory_order_relaxed);
      written_at_start = written;
      started_at = now;
      dds_subscription_matched_status_t sub;
      dds_publication_matched_status_t pub;
      if (dds_get_subscription_matched_status(reader, &sub) == 0) matched_writers = sub.current_count;
      if (dds_get_publication_matched_status(writer, &pub) == 0) matched_readers = pub.current_count;
      phase = 1;
    }
    if (phase == 1 && now >= window_end) {
      cpu_in = raw_peer_cpu_seconds() - cpu_at_start;
      received_in = atomic_load_explicit(&raw_peer_received, memory_order_relaxed) - received_at_start;
      written_in = written - written_at_start;
      ended_at = now;
      phase = 2;
    }
    if (phase == 2 && now >= exit_at) break;

    if (now >= next_write) {
      sample.seq = (uint32_t)written;
      const dds_return_t rc = dds_write(writer, &sample);
      if (rc < 0) raw_peer_fail("dds_write", rc);
      written++;
      next_write += RAW_PEER_PERIOD_NS;
      /* Late by more than a period (machine saturated): skip, never write a burst. */
      if (next_write <= now) next_write = now + RAW_PEER_PERIOD_NS;
    }
  }

  printf(
      "raw_peer id=%d written=%llu received=%llu cpu_s=%.6f window_s=%.3f matched_writers=%d "
      "matched_readers=%d neighbours=%u\n",
      id, (unsigned long long)written_in, (unsigned long long)received_in, cpu_in,
      (double)(ended_at - started_at) * 1e-9, (int)matched_writers, (int)matched_readers, degree);
  fflush(stdout);

  dds_delete(participant);
  free(sample.payload._buffer);
  for (uint32_t k = 0; k < degree; k++) free(names[k]);
  free(names);
  return 0;
}
