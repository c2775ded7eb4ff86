// The memory floor of the refit (docs/wide-bvh.md, "Refit: the floor on this machine"):
// memcpy of N MiB split between T threads, best of 15. gcc -O2 -pthread copy_bandwidth.c
// -o copy_bandwidth && ./copy_bandwidth 1024 2
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
typedef struct { char *d, *s; size_t n; } job;
static void *run(void *p) { job *j = p; memcpy(j->d, j->s, j->n); return 0; }
static double now() { struct timespec t; clock_gettime(CLOCK_MONOTONIC, &t); return t.tv_sec + t.tv_nsec * 1e-9; }
int main(int argc, char **argv) {
  size_t n = (size_t)atol(argv[1]) << 20; int threads = atoi(argv[2]);
  char *s = malloc(n), *d = malloc(n); memset(s, 1, n); memset(d, 2, n);
  double best = 1e9;
  for (int r = 0; r < 15; r++) {
    pthread_t t[8]; job j[8]; double t0 = now();
    for (int i = 0; i < threads; i++) { j[i].d = d + i * (n / threads); j[i].s = s + i * (n / threads); j[i].n = n / threads; pthread_create(&t[i], 0, run, &j[i]); }
    for (int i = 0; i < threads; i++) pthread_join(t[i], 0);
    double dt = now() - t0; if (dt < best) best = dt;
  }
  printf("%zu MiB, %d threads: best %.2f ms, %.1f GB/s copied (%.1f GB/s of traffic: read + write)\n", n >> 20, threads, best * 1e3, n / best / 1e9, 2 * n / best / 1e9);
}
