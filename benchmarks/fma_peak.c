/* The fp32 arithmetic ceiling of this CPU: every thread runs fused multiply-adds on registers only
 * (ACC independent vector accumulators, enough to hide the FMA latency on every x86 core we know,
 * and few enough to stay in the vector registers), so nothing but the FMA units limits it. Built by
 * benchmarks/_common.py (fma_peak, through mitnerf.fields.native.compiled: -O3 -march=native
 * -ffp-contract=fast): 16 accumulators of 16 floats
 * where AVX-512 is (32 registers), else 12 of 8 floats (16 registers).
 *
 *   double fma_gflops(int threads, long iterations)   -> GFLOP/s over all threads (2 FLOPs per FMA lane)
 */
#include <pthread.h>
#include <time.h>

#ifdef __AVX512F__
#define ACC 16
#define LANES 16
#else
#define ACC 12
#define LANES 8
#endif
typedef float vf __attribute__((vector_size(4 * LANES)));

typedef struct { long n; float out; } job_t;

static void* run(void* arg) {
    job_t* j = arg;
    vf acc[ACC];
    const vf a = (vf){0} + 0.999999f, b = (vf){0} + 1e-7f;
    for (int k = 0; k < ACC; k++) acc[k] = (vf){0} + (float)k;
    for (long i = 0; i < j->n; i++)
        for (int k = 0; k < ACC; k++) acc[k] = acc[k] * a + b;   /* contracted into one FMA */
    float s = 0;
    for (int k = 0; k < ACC; k++)
        for (int l = 0; l < LANES; l++) s += acc[k][l];
    j->out = s;                                                   /* keeps the loop alive */
    return 0;
}

double fma_gflops(int threads, long iterations) {
    pthread_t t[64];
    job_t jobs[64];
    if (threads < 1) threads = 1;
    if (threads > 64) threads = 64;
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (int i = 0; i < threads; i++) {
        jobs[i].n = iterations;
        pthread_create(&t[i], 0, run, &jobs[i]);
    }
    for (int i = 0; i < threads; i++) pthread_join(t[i], 0);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    const double s = (t1.tv_sec - t0.tv_sec) + 1e-9 * (t1.tv_nsec - t0.tv_nsec);
    return 2.0 * LANES * ACC * (double)iterations * threads / s / 1e9;
}
