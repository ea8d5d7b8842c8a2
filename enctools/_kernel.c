/* enctools' optional compiled kernel: the per-sample passes of the interpolation fit.
 *
 * Built at install time into a shared library (hatch_build.py) and called through ctypes
 * (enctools/kernel.py); without it the numpy passes run, to the same results to rounding.
 * Plain C99, no Python or numpy headers: the library does not depend on the Python it
 * was built for. Compiled with -ffp-contract=off so that an angle, a deviation and a
 * first deviation are the same doubles as numpy's (no fused multiply-add).
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define ENC_KERNEL_ABI 1
#define MAX_P1 64     /* columns + 1 (y): 2 * 64 device harmonics would not fit; the caller checks */
#define MAX_D1 8      /* trend terms */

int64_t enc_kernel_abi(void) { return ENC_KERNEL_ABI; }

/* The sums over the steps of a batch (X^T X and X^T y from the per-step tallies). */
typedef struct {
    int64_t *rhist;   /* samples per reference step */
    double *ysum;     /* y summed per device step */
    double *rysum;    /* y summed per reference step */
    double *rsum;     /* reference columns summed per device step (steps, n_ref) */
    double yty;
} Tally;

/* Two doubles side by side (GCC's and Clang's vector extension: SSE2 on x86-64, NEON on
 * arm64, plain pairs elsewhere); each lane is rounded as its scalar would be. */
typedef double v2d __attribute__((vector_size(16)));

static inline v2d load2(const double *p) { v2d x; memcpy(&x, p, sizeof x); return x; }

/* The pass over the samples, inlined with n_dev, n_ref and d1 constant where it is called.
 * n_dev and n_ref are even (cos and sin of each order): v is held as pairs, the last pair
 * (y, 0). */
static inline __attribute__((always_inline)) void pass(
    int64_t m, const int64_t *counts, double scale, int64_t shift, int64_t steps,
    const double *ref, double arcsec, const double *dev_table, const int64_t nd,
    const int64_t *ref_step, const double *ref_table, const int64_t nr, int64_t ref_steps,
    int64_t k, const int64_t *starts, const double *y0, const double *tz, const int64_t d1,
    const uint8_t *sectors, double *txy, uint8_t *seen, int64_t *per_step, Tally *tl)
{
    const int64_t p1 = nd + nr + 1, hd = nd / 2, hr = nr / 2, nv = hd + hr + 1;
    const int pow2 = (steps & (steps - 1)) == 0;
    double *const ysum = tl->ysum, *const rysum = tl->rysum, *const rsum = tl->rsum;
    int64_t *const rhist = tl->rhist;
    double yty = 0.0;
    for (int64_t g = 0; g < k; g++) {
        const int64_t lo = starts[g], hi = g + 1 < k ? starts[g + 1] : m;
        const double yg = y0[g];
        uint8_t bits = 0;
        v2d acc[MAX_D1][MAX_P1 / 2 + 1];
        for (int64_t t = 0; t < d1; t++)
            for (int64_t a = 0; a < nv; a++) acc[t][a] = (v2d){0.0, 0.0};
        for (int64_t i = lo; i < hi; i++) {
            const int64_t c = counts[i];
            int64_t s;
            if (pow2) {
                s = (c + shift) & (steps - 1);
            } else {
                s = (c + shift) % steps;
                if (s < 0) s += steps;
            }
            v2d v[MAX_P1 / 2 + 1];
            const double *row = dev_table + s * nd;
            for (int64_t a = 0; a < hd; a++) v[a] = load2(row + 2 * a);
            int64_t r = 0;
            if (nr) {
                r = ref_step[i];
                if (r < 0 || r >= ref_steps)        /* as numpy's take, mode "clip" */
                    r = r < 0 ? 0 : ref_steps - 1;
                const double *rr = ref_table + r * nr;
                for (int64_t a = 0; a < hr; a++) v[hd + a] = load2(rr + 2 * a);
            }
            const double angle = (double)c * scale;
            double y = angle - ref[i];
            y = y / arcsec;
            y = y - yg;
            v[nv - 1] = (v2d){y, 0.0};
            for (int64_t a = 0; a < nv; a++) acc[0][a] += v[a];
            for (int64_t t = 1; t < d1; t++) {
                const double w = tz[(t - 1) * m + i];
                const v2d ww = {w, w};
                for (int64_t a = 0; a < nv; a++) acc[t][a] += ww * v[a];
            }
            bits |= sectors[s];
            per_step[s] += 1;
            ysum[s] += y;
            yty += y * y;
            if (nr) {
                double *rs = rsum + s * nr;
                for (int64_t a = 0; a < hr; a++) {
                    const v2d x = load2(rs + 2 * a) + v[hd + a];
                    memcpy(rs + 2 * a, &x, sizeof x);
                }
                rysum[r] += y;
                rhist[r] += 1;
            }
        }
        for (int64_t t = 0; t < d1; t++)
            for (int64_t a = 0; a < p1; a++)
                txy[(t * p1 + a) * k + g] = acc[t][a / 2][a % 2];
        seen[g] = bits;
    }
    tl->yty = yty;
}

/* One device's batch of a trend-projected interpolation fit, in one pass over its samples.
 *
 * Per sample i (in the order of its groups, groups consecutive from starts[g]):
 *   step   = (counts[i] + shift) mod steps   [count] (floor modulo; a mask when a power of 2)
 *   y      = (counts[i] * scale - ref[i]) / arcsec - y0[g]  [arcsec]
 *   v      = dev_table[step] (n_dev columns), ref_table[ref_step[i]] (n_ref), y
 * and sums per group g: txy[t][c][g] = sum t_t(z) v_c over its samples (t_0 = 1, the other
 * t from tz, n_tz rows of m); seen[g] = OR of sectors[step]; per_step[step] += 1 (given
 * zeros). cross: with full, the p1 x p1 matrix sum v v^T; else the p1 vector sum v y
 * (given zeros). X^T X and X^T y are made from what each step gathered (the samples, y
 * and the reference's columns per device step; the samples and y per reference step),
 * not per sample. Tables are (steps, columns) row-major. Returns 0, or -1 when the sizes
 * exceed the limits or the scratch cannot be allocated.
 */
int64_t enc_interp_member(
    int64_t m, const int64_t *counts, double scale, int64_t shift, int64_t steps,
    const double *ref, double arcsec,
    const double *dev_table, int64_t n_dev,
    const int64_t *ref_step, const double *ref_table, int64_t n_ref, int64_t ref_steps,
    int64_t k, const int64_t *starts, const double *y0,
    const double *tz, int64_t n_tz, const uint8_t *sectors,
    double *txy, uint8_t *seen, double *cross, int64_t full, int64_t *per_step)
{
    const int64_t p1 = n_dev + n_ref + 1, d1 = n_tz + 1, p = p1 - 1;
    if (p1 > MAX_P1 || d1 > MAX_D1 || steps <= 0 || n_dev % 2 || n_ref % 2
            || (n_ref > 0 && (ref_step == NULL || ref_steps <= 0)))
        return -1;
    Tally tl = {0};
    tl.ysum = calloc((size_t)steps, sizeof(double));
    if (n_ref) {
        tl.rhist = calloc((size_t)ref_steps, sizeof(int64_t));
        tl.rysum = calloc((size_t)ref_steps, sizeof(double));
        tl.rsum = calloc((size_t)(steps * n_ref), sizeof(double));
    }
    if (!tl.ysum || (n_ref && (!tl.rhist || !tl.rysum || !tl.rsum))) {
        free(tl.ysum); free(tl.rhist); free(tl.rysum); free(tl.rsum);
        return -1;
    }
#define PASS(ND, NR, D1) pass(m, counts, scale, shift, steps, ref, arcsec, dev_table, ND, \
        ref_step, ref_table, NR, ref_steps, k, starts, y0, tz, D1, sectors, txy, seen, per_step, &tl)
    if (n_dev == 4 && n_ref == 4 && d1 == 2) PASS(4, 4, 2);
    else if (n_dev == 8 && n_ref == 0 && d1 == 2) PASS(8, 0, 2);
    else if (n_dev == 4 && n_ref == 0 && d1 == 2) PASS(4, 0, 2);
    else if (n_dev == 8 && n_ref == 4 && d1 == 2) PASS(8, 4, 2);
    else PASS(n_dev, n_ref, d1);
#undef PASS
    /* X^T y of the device's columns: sum over steps of the column times y gathered there */
    double *xty = full ? NULL : cross;
    double xtyv[MAX_P1] = {0};
    for (int64_t s = 0; s < steps; s++) {
        const double *row = dev_table + s * n_dev;
        const double ys = tl.ysum[s];
        if (ys != 0.0)
            for (int64_t a = 0; a < n_dev; a++) xtyv[a] += row[a] * ys;
    }
    for (int64_t rr = 0; n_ref && rr < ref_steps; rr++) {
        const double *row = ref_table + rr * n_ref;
        const double ys = tl.rysum[rr];
        if (ys != 0.0)
            for (int64_t a = 0; a < n_ref; a++) xtyv[n_dev + a] += row[a] * ys;
    }
    xtyv[p] = tl.yty;
    if (!full) {
        for (int64_t a = 0; a < p1; a++) xty[a] += xtyv[a];
    } else {
        for (int64_t a = 0; a < p1; a++) {
            cross[a * p1 + p] += xtyv[a];
            if (a < p) cross[p * p1 + a] += xtyv[a];
        }
        for (int64_t s = 0; s < steps; s++) {       /* device x device, device x reference */
            const double *row = dev_table + s * n_dev;
            const double h = (double)per_step[s];
            if (h == 0.0) continue;
            for (int64_t a = 0; a < n_dev; a++) {
                for (int64_t b = 0; b < n_dev; b++) cross[a * p1 + b] += h * row[a] * row[b];
                for (int64_t b = 0; b < n_ref; b++) {
                    const double x = row[a] * tl.rsum[s * n_ref + b];
                    cross[a * p1 + n_dev + b] += x;
                    cross[(n_dev + b) * p1 + a] += x;
                }
            }
        }
        for (int64_t rr = 0; n_ref && rr < ref_steps; rr++) {  /* reference x reference */
            const double *row = ref_table + rr * n_ref;
            const double h = (double)tl.rhist[rr];
            if (h == 0.0) continue;
            for (int64_t a = 0; a < n_ref; a++)
                for (int64_t b = 0; b < n_ref; b++)
                    cross[(n_dev + a) * p1 + n_dev + b] += h * row[a] * row[b];
        }
    }
    free(tl.ysum); free(tl.rhist); free(tl.rysum); free(tl.rsum);
    return 0;
}
