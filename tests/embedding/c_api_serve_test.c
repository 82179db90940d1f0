/* The C API's serve from C (C11 and POSIX, lamina::c only): lamina_serve of the phantom on a
 * free port in a thread of its own, a client reading the skin's POLYDATA off the wire, the stop
 * flag ending the serve, and bad options, a missing scene and a port in use refused with a
 * one-line message. Exit code 0 = every check held. */
#define _POSIX_C_SOURCE 200809L
#include <arpa/inet.h>
#include <lamina/c_api.h>
#include <netinet/in.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "c_check.h"

static int32_t free_port(int keep_listening, int* fd_out) {
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  struct sockaddr_in a;
  memset(&a, 0, sizeof a);
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  if (bind(fd, (struct sockaddr*)&a, sizeof a) != 0 || getsockname(fd, (struct sockaddr*)&a, &len))
    return -1;
  if (keep_listening) {
    listen(fd, 1);
    *fd_out = fd;
  } else {
    close(fd);
  }
  return ntohs(a.sin_port);
}

static double now_s(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int read_exactly(int fd, unsigned char* out, size_t n) {
  size_t got = 0;
  while (got < n) {
    const ssize_t r = recv(fd, out + got, n - got, 0);
    if (r <= 0) return 0;
    got += (size_t)r;
  }
  return 1;
}

struct serve_call {
  lamina_serve_options options;
  volatile int32_t stop;
  lamina_status status;
};

static void* serve_thread(void* arg) {
  struct serve_call* c = arg;
  c->status = lamina_serve("phantom", &c->options, &c->stop);
  return NULL;
}

int main(void) {
  lamina_serve_options o;
  lamina_serve_options_default(&o);
  CHECK(o.port == 18944 && o.rate_hz == 1000.0 && o.web == 0 && o.duration_s == 0.0);

  /* Bad options: refused by name before anything listens. */
  lamina_serve_options bad = o;
  bad.send_hz = -1.0;
  CHECK(lamina_serve("phantom", &bad, NULL) == LAMINA_ERROR_INVALID_INPUT);
  CHECK(strstr(lamina_last_error(), "--send-hz") != NULL);
  CHECK(lamina_serve("phantom", NULL, NULL) == LAMINA_ERROR_INVALID_INPUT);
  CHECK(lamina_serve("no/such/scene.json", &o, NULL) == LAMINA_ERROR_INVALID_INPUT);
  CHECK(strstr(lamina_last_error(), "no/such/scene.json") != NULL);
  int busy_fd = -1;
  lamina_serve_options busy = o;
  busy.port = free_port(1, &busy_fd);
  CHECK(lamina_serve("phantom", &busy, NULL) == LAMINA_ERROR_INVALID_INPUT);
  printf("a port in use: %s\n", lamina_last_error());
  close(busy_fd);

  /* The phantom served until the flag is set; a client reads the skin. */
  struct serve_call call;
  call.options = o;
  call.options.port = free_port(0, NULL);
  call.options.rate_hz = 500.0;
  call.stop = 0;
  call.status = LAMINA_ERROR_INTERNAL;
  pthread_t thread;
  CHECK(pthread_create(&thread, NULL, serve_thread, &call) == 0);
  const double start = now_s();
  int fd = -1;
  while (now_s() - start < 60.0) {
    fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in a;
    memset(&a, 0, sizeof a);
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons((uint16_t)call.options.port);
    if (connect(fd, (struct sockaddr*)&a, sizeof a) == 0) break;
    close(fd);
    fd = -1;
    const struct timespec pause = {0, 50000000};
    nanosleep(&pause, NULL);
  }
  CHECK(fd >= 0);
  int skin_points = -1;
  while (fd >= 0 && skin_points < 0 && now_s() - start < 60.0) {
    unsigned char h[58];
    if (!read_exactly(fd, h, sizeof h)) break;
    uint64_t size = 0;
    for (int i = 0; i < 8; ++i) size = (size << 8) | h[42 + i];
    static unsigned char body[1 << 24];
    if (size > sizeof body || !read_exactly(fd, body, (size_t)size)) break;
    if (memcmp(h + 2, "POLYDATA", 8) == 0 && strncmp((const char*)h + 14, "LaminaSkin", 20) == 0)
      skin_points = (int)((uint32_t)body[0] << 24 | (uint32_t)body[1] << 16 |
                          (uint32_t)body[2] << 8 | body[3]);
  }
  if (fd >= 0) close(fd);
  printf("the skin streamed: %d points\n", skin_points);
  CHECK(skin_points > 1000);
  call.stop = 1;
  const double stopped = now_s();
  pthread_join(thread, NULL);
  CHECK(call.status == LAMINA_OK);
  printf("stopped %.2f s after the flag\n", now_s() - stopped);
  CHECK(now_s() - stopped < 5.0);
  return failures == 0 ? 0 : 1;
}
