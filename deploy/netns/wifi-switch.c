/* wifi-switch: a userspace Ethernet switch with WiFi-like links, for deploy/netns/multihost.sh.
 *
 *   wifi-switch DELAY_MS JITTER_MS LOSS_PCT SEED PORT...
 *
 * Run in the switch namespace, on veth ports that are NOT enslaved to a bridge. It forwards every frame
 * that arrives on one port to the port where its destination MAC was last seen (learned from source
 * MACs), or to every other port when the destination is broadcast, multicast or not yet learned. Each
 * copy it sends is lost with probability LOSS_PCT/100 and otherwise delayed by DELAY_MS plus a uniform
 * jitter in [-JITTER_MS, +JITTER_MS] (clamped at 0), drawn per frame: frames can overtake each other,
 * as with netem's jitter. The kernel here has no netem (docs/measurements/feasibility.md §1); this is
 * the C counterpart of the Python forwarder measured there.
 *
 * IPv4 multicast frames (destination MAC 01:00:5e:...) are dropped and counted: with it, a run's
 * discovery can only have been unicast. On SIGTERM or SIGINT it prints one line of counters on stdout:
 *   wifi-switch: received R forwarded F lost L multicast_dropped M udp_multicast_dropped U
 * The hosts must have checksum offload off (`ethtool -K eth0 tx off sg off tso off gso off`):
 * otherwise their frames leave with partial checksums that the receiving host rejects.
 *
 * Plain C (no project headers), so that a user can build it alone: cc -O2 -o wifi-switch wifi-switch.c
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <linux/if_ether.h>
#include <linux/if_packet.h>
#include <net/if.h>
#include <poll.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#define MAX_PORTS 16
#define MAX_FRAME 65536
#define MAX_MACS 1024

struct frame {
  int64_t due_ns;
  uint64_t order; /* ties: arrival order */
  int port;
  size_t len;
  unsigned char* data;
};

struct heap {
  struct frame* items;
  size_t size, capacity;
};

struct mac_entry {
  unsigned char mac[6];
  int port;
};

static volatile sig_atomic_t stop_requested;
static int sockets[MAX_PORTS];
static int port_count;
static struct mac_entry macs[MAX_MACS];
static int mac_count;
static uint64_t rng_state;
static struct { uint64_t received, forwarded, lost, multicast_dropped, udp_multicast_dropped; } counters;

static void on_signal(int sig) {
  (void)sig;
  stop_requested = 1;
}

static int64_t now_ns(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (int64_t)t.tv_sec * 1000000000 + t.tv_nsec;
}

/* xorshift64*: uniform in [0, 1). */
static double uniform01(void) {
  rng_state ^= rng_state >> 12;
  rng_state ^= rng_state << 25;
  rng_state ^= rng_state >> 27;
  return (double)((rng_state * 2685821657736338717ULL) >> 11) / 9007199254740992.0;
}

static int earlier(const struct frame* a, const struct frame* b) {
  return a->due_ns < b->due_ns || (a->due_ns == b->due_ns && a->order < b->order);
}

static int heap_push(struct heap* h, struct frame f) {
  if (h->size == h->capacity) {
    size_t capacity = h->capacity ? 2 * h->capacity : 1024;
    struct frame* items = realloc(h->items, capacity * sizeof *items);
    if (items == NULL) return -1;
    h->items = items;
    h->capacity = capacity;
  }
  size_t i = h->size++;
  while (i > 0 && earlier(&f, &h->items[(i - 1) / 2])) {
    h->items[i] = h->items[(i - 1) / 2];
    i = (i - 1) / 2;
  }
  h->items[i] = f;
  return 0;
}

static struct frame heap_pop(struct heap* h) {
  struct frame top = h->items[0];
  struct frame last = h->items[--h->size];
  size_t i = 0;
  for (;;) {
    size_t child = 2 * i + 1;
    if (child >= h->size) break;
    if (child + 1 < h->size && earlier(&h->items[child + 1], &h->items[child])) child++;
    if (!earlier(&h->items[child], &last)) break;
    h->items[i] = h->items[child];
    i = child;
  }
  if (h->size > 0) h->items[i] = last;
  return top;
}

static int open_port(const char* name) {
  int fd = socket(AF_PACKET, SOCK_RAW | SOCK_NONBLOCK, htons(ETH_P_ALL));
  if (fd < 0) return -1;
  struct sockaddr_ll addr;
  memset(&addr, 0, sizeof addr);
  addr.sll_family = AF_PACKET;
  addr.sll_protocol = htons(ETH_P_ALL);
  addr.sll_ifindex = (int)if_nametoindex(name);
  if (addr.sll_ifindex == 0 || bind(fd, (struct sockaddr*)&addr, sizeof addr) != 0) {
    close(fd);
    return -1;
  }
  int buffer = 8 << 20;
  setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &buffer, sizeof buffer);
  setsockopt(fd, SOL_SOCKET, SO_SNDBUFFORCE, &buffer, sizeof buffer);
  return fd;
}

static void learn(const unsigned char* mac, int port) {
  if (mac[0] & 1) return; /* a group address is never a source */
  for (int i = 0; i < mac_count; i++) {
    if (memcmp(macs[i].mac, mac, 6) == 0) {
      macs[i].port = port;
      return;
    }
  }
  if (mac_count < MAX_MACS) {
    memcpy(macs[mac_count].mac, mac, 6);
    macs[mac_count++].port = port;
  }
}

static int port_of(const unsigned char* mac) {
  if (mac[0] & 1) return -1;
  for (int i = 0; i < mac_count; i++)
    if (memcmp(macs[i].mac, mac, 6) == 0) return macs[i].port;
  return -1;
}

static int is_ipv4_multicast(const unsigned char* frame) {
  return frame[0] == 0x01 && frame[1] == 0x00 && frame[2] == 0x5e;
}

static int is_udp(const unsigned char* frame, size_t len) {
  return len >= 34 && frame[12] == 0x08 && frame[13] == 0x00 && frame[23] == 17;
}

struct link_model {
  int64_t delay_ns, jitter_ns;
  double loss;
};

/* The newest due time per (ingress, egress) port pair: a link delivers in order. */
static int64_t last_due[MAX_PORTS][MAX_PORTS];

static int enqueue_copy(struct heap* queue, const struct link_model* link, const unsigned char* frame,
                        size_t len, int from, int port, uint64_t* order) {
  if (uniform01() < link->loss) {
    counters.lost++;
    return 0;
  }
  int64_t delay = link->delay_ns;
  if (link->jitter_ns > 0) delay += (int64_t)((2.0 * uniform01() - 1.0) * (double)link->jitter_ns);
  if (delay < 0) delay = 0;
  int64_t due = now_ns() + delay;
  if (due < last_due[from][port]) due = last_due[from][port];
  last_due[from][port] = due;
  unsigned char* copy = malloc(len);
  if (copy == NULL) return -1;
  memcpy(copy, frame, len);
  struct frame f = {due, (*order)++, port, len, copy};
  return heap_push(queue, f);
}

static int receive_from(int port, struct heap* queue, const struct link_model* link, unsigned char* buffer,
                        uint64_t* order) {
  for (;;) {
    struct sockaddr_ll from;
    socklen_t from_len = sizeof from;
    ssize_t n = recvfrom(sockets[port], buffer, MAX_FRAME, 0, (struct sockaddr*)&from, &from_len);
    if (n < 0) return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR ? 0 : -1;
    if (from.sll_pkttype == PACKET_OUTGOING || n < 14) continue; /* our own transmissions */
    counters.received++;
    size_t len = (size_t)n;
    learn(buffer + 6, port);
    if (is_ipv4_multicast(buffer)) {
      counters.multicast_dropped++;
      if (is_udp(buffer, len)) counters.udp_multicast_dropped++;
      continue;
    }
    int target = port_of(buffer);
    for (int p = 0; p < port_count; p++) {
      if (p == port || (target >= 0 && p != target)) continue;
      if (enqueue_copy(queue, link, buffer, len, port, p, order) != 0) return -1;
    }
  }
}

static void send_due(struct heap* queue) {
  int64_t now = now_ns();
  while (queue->size > 0 && queue->items[0].due_ns <= now) {
    struct frame f = heap_pop(queue);
    if (send(sockets[f.port], f.data, f.len, 0) == (ssize_t)f.len)
      counters.forwarded++;
    else
      counters.lost++; /* a full veth queue drops, as a radio would */
    free(f.data);
  }
}

static int poll_timeout_ms(const struct heap* queue) {
  if (queue->size == 0) return 200;
  int64_t wait = queue->items[0].due_ns - now_ns();
  if (wait <= 0) return 0;
  return wait > 200000000 ? 200 : (int)((wait + 999999) / 1000000);
}

static int run(const struct link_model* link) {
  struct heap queue = {NULL, 0, 0};
  struct pollfd fds[MAX_PORTS];
  unsigned char* buffer = malloc(MAX_FRAME);
  uint64_t order = 0;
  if (buffer == NULL) return 1;
  for (int p = 0; p < port_count; p++) fds[p] = (struct pollfd){sockets[p], POLLIN, 0};
  while (!stop_requested) {
    int ready = poll(fds, (nfds_t)port_count, poll_timeout_ms(&queue));
    if (ready < 0 && errno != EINTR) break;
    for (int p = 0; ready > 0 && p < port_count; p++) {
      if ((fds[p].revents & POLLIN) && receive_from(p, &queue, link, buffer, &order) != 0) {
        perror("wifi-switch: receive");
        stop_requested = 1;
      }
    }
    send_due(&queue);
  }
  while (queue.size > 0) free(heap_pop(&queue).data);
  free(queue.items);
  free(buffer);
  return 0;
}

int main(int argc, char** argv) {
  if (argc < 7 || argc - 5 > MAX_PORTS) {
    fprintf(stderr, "usage: %s DELAY_MS JITTER_MS LOSS_PCT SEED PORT PORT [PORT...] (at most %d ports)\n",
            argv[0], MAX_PORTS);
    return 2;
  }
  struct link_model link = {(int64_t)(atof(argv[1]) * 1e6), (int64_t)(atof(argv[2]) * 1e6),
                            atof(argv[3]) / 100.0};
  rng_state = strtoull(argv[4], NULL, 10) * 0x9E3779B97F4A7C15ULL + 1;
  if (link.delay_ns < 0 || link.jitter_ns < 0 || link.loss < 0 || link.loss > 1) {
    fprintf(stderr, "wifi-switch: delay and jitter >= 0, loss in [0, 100]\n");
    return 2;
  }
  port_count = argc - 5;
  for (int p = 0; p < port_count; p++) {
    sockets[p] = open_port(argv[5 + p]);
    if (sockets[p] < 0) {
      fprintf(stderr, "wifi-switch: cannot open port %s: %s\n", argv[5 + p], strerror(errno));
      return 1;
    }
  }
  struct sigaction action;
  memset(&action, 0, sizeof action);
  action.sa_handler = on_signal;
  sigaction(SIGTERM, &action, NULL);
  sigaction(SIGINT, &action, NULL);
  int rc = run(&link);
  printf(
      "wifi-switch: received %llu forwarded %llu lost %llu multicast_dropped %llu udp_multicast_dropped "
      "%llu\n",
      (unsigned long long)counters.received, (unsigned long long)counters.forwarded,
      (unsigned long long)counters.lost, (unsigned long long)counters.multicast_dropped,
      (unsigned long long)counters.udp_multicast_dropped);
  fflush(stdout);
  return rc;
}
