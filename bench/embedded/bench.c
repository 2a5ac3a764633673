/* Host timing of one exported corrector: ns per sample of the float and double C exports and of
 * the no_std Rust exports (through the test's staticlib), over the held-out samples of
 * crates/spincal-cli/tests/firmware.rs. Built by run.sh with -DKIND=<kind>. */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#define CAT2(a, b) a##b
#define CAT(a, b) CAT2(a, b)
#define STR2(a) #a
#define STR(a) STR2(a)
#define F32(name) CAT(KIND, CAT(_f32_, name))
#define F64(name) CAT(KIND, CAT(_f64_, name))

#include STR(CAT(KIND, _f32.h))
#include STR(CAT(KIND, _f64.h))

void CAT(KIND, _rs_f32)(size_t n, const float *accel, const float *gyro, float *out, unsigned *flags);
void CAT(KIND, _rs_f64)(size_t n, const double *accel, const double *gyro, double *out, unsigned *flags);

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static volatile double sink;

int main(int argc, char **argv)
{
    size_t n, i, r;
    int k, rep, reps = argc > 1 ? atoi(argv[1]) : 5;
    const size_t rounds = 2000;
    double *a, *g, *o64, best[4], times[4][64];
    float *a32, *g32, *o32;
    unsigned *flags;
    if (scanf("%lu", (unsigned long *)&n) != 1 || reps < 1 || reps > 64) {
        return 2;
    }
    a = malloc(3 * n * sizeof *a);
    g = malloc(3 * n * sizeof *g);
    o64 = malloc(6 * n * sizeof *o64);
    a32 = malloc(3 * n * sizeof *a32);
    g32 = malloc(3 * n * sizeof *g32);
    o32 = malloc(6 * n * sizeof *o32);
    flags = malloc(n * sizeof *flags);
    for (i = 0; i < 3 * n; i += 3) {
        if (scanf("%lf %lf %lf %lf %lf %lf", &a[i], &a[i + 1], &a[i + 2], &g[i], &g[i + 1], &g[i + 2]) != 6) {
            return 3;
        }
        for (k = 0; k < 3; ++k) {
            a32[i + k] = (float)a[i + k];
            g32[i + k] = (float)g[i + k];
        }
    }
    for (rep = -1; rep < reps; ++rep) { /* rep -1: warm-up */
        double t0;
        F32(state) s32;
        F64(state) s64;
        double acc = 0;
        t0 = now();
        for (r = 0; r < rounds; ++r) {
            F32(init)(&s32);
            for (i = 0; i < n; ++i) {
                acc += F32(correct)(&F32(model), &s32, &a32[3 * i], &g32[3 * i], &o32[6 * (i & 7)], &o32[6 * (i & 7) + 3]);
            }
        }
        times[0][rep < 0 ? 0 : rep] = (now() - t0) / (double)(rounds * n) * 1e9;
        t0 = now();
        for (r = 0; r < rounds; ++r) {
            F64(init)(&s64);
            for (i = 0; i < n; ++i) {
                acc += F64(correct)(&F64(model), &s64, &a[3 * i], &g[3 * i], &o64[6 * (i & 7)], &o64[6 * (i & 7) + 3]);
            }
        }
        times[1][rep < 0 ? 0 : rep] = (now() - t0) / (double)(rounds * n) * 1e9;
        t0 = now();
        for (r = 0; r < rounds; ++r) {
            CAT(KIND, _rs_f32)(n, a32, g32, o32, flags);
            acc += o32[0];
        }
        times[2][rep < 0 ? 0 : rep] = (now() - t0) / (double)(rounds * n) * 1e9;
        t0 = now();
        for (r = 0; r < rounds; ++r) {
            CAT(KIND, _rs_f64)(n, a, g, o64, flags);
            acc += o64[0];
        }
        times[3][rep < 0 ? 0 : rep] = (now() - t0) / (double)(rounds * n) * 1e9;
        sink = acc;
    }
    for (k = 0; k < 4; ++k) {
        /* best and median of reps (insertion sort) */
        int x, y;
        for (x = 1; x < reps; ++x) {
            double v = times[k][x];
            for (y = x - 1; y >= 0 && times[k][y] > v; --y) {
                times[k][y + 1] = times[k][y];
            }
            times[k][y + 1] = v;
        }
        best[k] = times[k][0];
        printf("%s best %.2f median %.2f\n", k == 0 ? "C float" : k == 1 ? "C double" : k == 2 ? "Rust f32" : "Rust f64",
               best[k], times[k][reps / 2]);
    }
    return 0;
}
