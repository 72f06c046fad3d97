/* viscera's socket device: a reference client in C, what a haptic driver's loop does.
 *
 *   cc -O2 -o haptic_client docs/haptics/haptic_client.c -lm
 *   ./haptic_client [port 47000] [seconds 5] [rate_hz 1000]
 *
 * It asks the server what it drives (HELLO, then one INFO per tool), then, every period, sends
 * the pose of tool 0 (its start pose, pitch swinging 5 deg at 0.5 Hz) as a POSE and waits until
 * the period ends for the FORCE that answers it; a driver would command that force to its
 * motors there. It prints the force ten times a second and a summary; it exits 1 when nothing
 * was answered. The protocol (fields, units) is viscera.teleop.protocol's docstring: UDP on
 * loopback, little-endian, packed structs, every message at most 512 bytes. Linux or a BSD (ppoll).
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <math.h>
#include <poll.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

enum { HELLO = 1, INFO = 2, POSE = 3, FORCE = 4, BYE = 5, VERSION = 1, MAX_TOOLS = 6, MAX_BYTES = 512 };

#pragma pack(push, 1) /* the wire format has no padding */
typedef struct { char magic[4]; uint16_t version, type; } header_t;
typedef struct { header_t h; uint32_t sequence; double client_time; } hello_t;
typedef struct { header_t h; uint32_t sequence, length; char json[MAX_BYTES - 16]; } info_t;
typedef struct { uint32_t tool; double q[5]; } pose_tool_t; /* pitch deg, yaw deg, depth m, roll deg, jaw deg */
typedef struct {
  header_t h; uint32_t sequence; double client_time; uint32_t count; pose_tool_t tools[MAX_TOOLS];
} pose_t;
/* coupling: N m, N m, N, N m, N m to render on the hand; tissue: N, world frame */
typedef struct { uint32_t tool, flags; double coupling[5], tissue[3]; } force_tool_t;
typedef struct {
  header_t h; uint32_t sequence; double client_time, sim_time; uint32_t count, dropped[4];
  force_tool_t tools[MAX_TOOLS];
} force_t;
typedef struct { header_t h; uint32_t sequence; } bye_t;
#pragma pack(pop)

_Static_assert(sizeof(hello_t) == 20 && offsetof(pose_t, tools) == 24 && sizeof(pose_tool_t) == 44, "POSE layout");
_Static_assert(offsetof(force_t, tools) == 48 && sizeof(force_tool_t) == 72 && sizeof(bye_t) == 12, "FORCE layout");

static double now_s(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

static header_t header(uint16_t type) {
  header_t h = {{'V', 'S', 'C', 'R'}, VERSION, type};
  return h;
}

/* wait until `deadline` (CLOCK_MONOTONIC s) for a datagram; its size, or 0 when none came */
static ssize_t receive(int fd, void *buffer, size_t size, double deadline) {
  for (;;) {
    double left = deadline - now_s();
    if (left <= 0) return 0;
    struct timespec timeout = {(time_t)left, (long)((left - (time_t)left) * 1e9)};
    struct pollfd p = {fd, POLLIN, 0};
    if (ppoll(&p, 1, &timeout, NULL) <= 0) return 0;
    ssize_t n = recv(fd, buffer, size, 0);
    if (n > 0) return n;
  }
}

int main(int argc, char **argv) {
  int port = argc > 1 ? atoi(argv[1]) : 47000;
  double seconds = argc > 2 ? atof(argv[2]) : 5.0, rate = argc > 3 ? atof(argv[3]) : 1000.0;
  uint16_t one = 1;
  if (*(uint8_t *)&one != 1 || port <= 0 || seconds <= 0 || rate <= 0) {
    fprintf(stderr, "usage: haptic_client [port] [seconds] [rate_hz] (little-endian hosts only)\n");
    return 2;
  }
  int fd = socket(AF_INET, SOCK_DGRAM, 0);
  struct sockaddr_in server = {.sin_family = AF_INET, .sin_port = htons(port)};
  inet_pton(AF_INET, "127.0.0.1", &server.sin_addr);
  if (fd < 0 || connect(fd, (struct sockaddr *)&server, sizeof server) != 0) { perror("socket"); return 1; }

  /* HELLO until an INFO comes: it tells tool 0's start pose */
  double start_pose[5] = {0, 0, 0, 0, 0};
  info_t info;
  int got_info = 0;
  for (int attempt = 0; attempt < 50 && !got_info; attempt++) {
    hello_t hello = {header(HELLO), (uint32_t)attempt, now_s()};
    send(fd, &hello, sizeof hello, 0);
    ssize_t n;
    while ((n = receive(fd, &info, sizeof info - 1, now_s() + 0.1)) > 0) {
      if (n < 16 || info.h.type != INFO || info.length != (uint32_t)(n - 16)) continue;
      info.json[info.length] = '\0';
      printf("INFO %s\n", info.json);
      const char *tool = strstr(info.json, "\"index\":0,");
      const char *initial = tool ? strstr(tool, "\"initial\":[") : NULL;
      if (initial && sscanf(initial, "\"initial\":[%lf,%lf,%lf,%lf,%lf", &start_pose[0], &start_pose[1],
                            &start_pose[2], &start_pose[3], &start_pose[4]) == 5)
        got_info = 1;
    }
  }
  if (!got_info) { fprintf(stderr, "haptic_client: no INFO from 127.0.0.1:%d\n", port); return 1; }

  double period = 1.0 / rate, start = now_s();
  long periods = (long)(seconds * rate), answered = 0, late = 0;
  uint32_t sequence = 1000;
  force_t force;
  for (long k = 0; k < periods; k++) {
    double deadline = start + (k + 1) * period;
    pose_t pose = {header(POSE), ++sequence, now_s(), 1, {{0, {0}}}};
    memcpy(pose.tools[0].q, start_pose, sizeof start_pose);
    pose.tools[0].q[0] += 5.0 * sin(2 * M_PI * 0.5 * (pose.client_time - start));
    send(fd, &pose, offsetof(pose_t, tools) + pose.count * sizeof(pose_tool_t), 0);
    int in_time = 0;
    ssize_t n;
    while (!in_time && (n = receive(fd, &force, sizeof force, deadline)) > 0) {
      size_t expected = offsetof(force_t, tools) + force.count * sizeof(force_tool_t);
      if (n < (ssize_t)offsetof(force_t, tools) || force.h.type != FORCE || n != (ssize_t)expected) continue;
      if (force.sequence != sequence) { late++; continue; } /* an earlier period's, come late */
      in_time = 1;
      answered++;
      if (k % (long)(rate / 10 > 1 ? rate / 10 : 1) == 0)
        printf("t %.3f s latency %.3f ms tool %u coupling %.4f N m %.4f N m %.4f N %.4f N m %.4f N m "
               "tissue %.4f %.4f %.4f N flags %u dropped %u\n", force.sim_time, 1e3 * (now_s() - force.client_time),
               force.tools[0].tool, force.tools[0].coupling[0], force.tools[0].coupling[1], force.tools[0].coupling[2],
               force.tools[0].coupling[3], force.tools[0].coupling[4], force.tools[0].tissue[0],
               force.tools[0].tissue[1], force.tools[0].tissue[2], force.tools[0].flags,
               force.dropped[0] + force.dropped[1] + force.dropped[2] + force.dropped[3]);
    }
    struct timespec wake = {(time_t)deadline, (long)((deadline - (time_t)deadline) * 1e9)};
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &wake, NULL); /* absolute: no drift */
  }
  bye_t bye = {header(BYE), ++sequence};
  send(fd, &bye, sizeof bye, 0);
  printf("sent %ld, answered in time %ld (%.2f %%), late %ld, %.1f Hz\n", periods, answered,
         100.0 * answered / periods, late, periods / (now_s() - start));
  close(fd);
  return answered > 0 ? 0 : 1;
}
