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

#define ENC_KERNEL_ABI 3
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

/* ---- selfcal: one revolution's binned moments and its repeated sample positions ----
 * (enctools/methods/harmonics.py, _bin_moments and FourierSeries; selfcal_uncertainty.py,
 * SampleRepeats). The same doubles as the numpy passes up to the order of the sums. */

/* theta = u - delta_hat(u) of the angle map (harmonics.FourierSeries: in each of mbins
 * bins a polynomial of mp terms in s, map[bin][p] (its table transposed: one bin's terms
 * side by side), Horner from the last term). */
static inline __attribute__((always_inline)) double mapped(
    double u, const double *map, int64_t mp, int64_t mbins, double per_rad)
{
    if (mp == 0) return u;
    const double pos = u * per_rad;
    int64_t f = (int64_t)pos;                 /* floor, without the maths library */
    if ((double)f > pos) f--;
    const double b = (double)f;
    double s = pos - b;
    s *= 2.0;
    s -= 1.0;
    const int64_t idx = f & (mbins - 1);
    const double *q = map + idx * mp;
    double out = q[mp - 1];
    for (int64_t p = mp - 2; p >= 0; p--) {
        out *= s;
        out += q[p];
    }
    return u - out;
}

#define MAX_CHANNELS 16
#define MAX_TERMS 32
#define BLOCK 256     /* samples whose powers of s are made in one pass */

/* The bin b, offset s and trapezoid weight w of samples j0..j0+n-1 of x (s1 samples), and
 * the powers s^p, p < terms, of each (power[j][p], s^p = s^(p-1) s as numpy makes them). */
static inline __attribute__((always_inline)) void block_powers(
    const double *x, int64_t s1, int64_t j0, int64_t n, double per_rad, int64_t nb,
    int64_t terms, int64_t *bin, double *w, double *power)
{
    for (int64_t i = 0; i < n; i++) {
        const int64_t j = j0 + i;
        w[i] = (j == 0 ? x[1] - x[0] : j == s1 - 1 ? x[j] - x[j - 1] : x[j + 1] - x[j - 1])
               * 0.5;
        const double pos = x[j] * per_rad;
        int64_t b = (int64_t)pos;       /* a first sample rounded below 0 truncates to 0 */
        if (b >= nb) b = nb - 1;
        double s = pos - (double)b;
        s *= 2.0;
        s -= 1.0;
        bin[i] = b;
        double *q = power + i * terms;   /* a sample's powers side by side: accumulate's order */
        q[0] = 1.0;
        q[1] = s;
        for (int64_t p = 2; p < terms; p++) q[p] = q[p - 1] * s;
    }
}

/* Add a block's samples to their bins' sums: loc holds the current bin's (c x terms) and is
 * added into by_bin when the bin changes; inlined with c and terms constant where called.
 * A run of samples in one bin is summed a channel at a time, its terms held in registers
 * (all c x terms at once spill: 48 doubles at selfcal's default); each sum still runs over
 * the bin's samples in order. */
static inline __attribute__((always_inline)) void accumulate(
    const double *restrict values, int64_t stride, int64_t n, const int64_t *restrict bin,
    const double *restrict w, const double *restrict power, const int64_t c,
    const int64_t terms, double *restrict by_bin, double *restrict loc, int64_t *cur,
    int64_t *count, int64_t *width)
{
    const int64_t ct = c * terms;
    int64_t i0 = 0;
    while (i0 < n) {
        if (bin[i0] != *cur) {
            if (*cur >= 0)
                for (int64_t a = 0; a < ct; a++) by_bin[*cur * ct + a] += loc[a];
            for (int64_t a = 0; a < ct; a++) loc[a] = 0.0;
            if (*count > *width) *width = *count;
            *cur = bin[i0];
            *count = 0;
        }
        int64_t i1 = i0 + 1;
        while (i1 < n && bin[i1] == bin[i0]) i1++;
        *count += i1 - i0;
        for (int64_t k = 0; k < c; k++) {
            double acc[MAX_TERMS];
            double *l = loc + k * terms;
            for (int64_t p = 0; p < terms; p++) acc[p] = l[p];
            const double *vk = values + k * stride;
            for (int64_t i = i0; i < i1; i++) {
                const double wv = vk[i] * w[i];
                const double *sp = power + i * terms;
                for (int64_t p = 0; p < terms; p++) acc[p] += wv * sp[p];
            }
            for (int64_t p = 0; p < terms; p++) l[p] = acc[p];
        }
        i0 = i1;
    }
}

/* On x86-64 Linux with GCC 12 or later the moments are also compiled for AVX2 (x86-64-v3)
 * and AVX-512 (x86-64-v4), the clone the CPU can run chosen when the library loads (an
 * ifunc): 10-18% less time a revolution. -ffp-contract=off keeps every clone's doubles the
 * baseline's (no fused multiply-add; IEEE sums and products are the same in any width), so a
 * built library still runs on any machine of its platform. Elsewhere: the baseline alone. */
#if defined(__x86_64__) && defined(__linux__) && defined(__GNUC__) && !defined(__clang__) \
    && __GNUC__ >= 12
#define MOMENT_CLONES __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define MOMENT_CLONES
#endif

/* Samples i0..i0+n-1 of c channels held in pieces (piece q: lengths[q] samples, channel k's
 * row at rows[q * c + k]; *piece and *off: where sample i0 is) copied into buf (c rows of
 * BLOCK), minus[k] taken off each value when minus is given: the doubles of numpy's
 * `values - minus[:, None]` of the pieces joined. Advances *piece and *off past the block. */
static inline __attribute__((always_inline)) void gather(
    int64_t n, int64_t c, const int64_t *lengths, const double *const *rows,
    const double *minus, int64_t *piece, int64_t *off, double *restrict buf)
{
    int64_t i = 0;
    while (i < n) {
        while (*off == lengths[*piece]) {
            (*piece)++;
            *off = 0;
        }
        int64_t take = lengths[*piece] - *off;
        if (take > n - i) take = n - i;
        for (int64_t k = 0; k < c; k++) {
            const double *src = rows[*piece * c + k] + *off;
            double *dst = buf + k * BLOCK + i;
            if (minus) {
                const double m = minus[k];
                for (int64_t t = 0; t < take; t++) dst[t] = src[t] - m;
            } else {
                memcpy(dst, src, sizeof(double) * (size_t)take);
            }
        }
        i += take;
        *off += take;
    }
}

/* Moments M_pcb = sum_(j in bin b) w_j v_cj s_j^p (out: terms x c x nb) of c channels over
 * one revolution of x_j = theta(u_j) - start (written into x), theta the angle map (mp = 0:
 * theta = u); w the trapezoid weights of x, b = floor(x nb / 2 pi) (the last bin takes what
 * rounds past 2 pi), s the offset from the bin's centre in half-widths. The channels' s1
 * samples come in `pieces` pieces (the batches a revolution was cut from, not joined:
 * lengths[q] samples each, channel k's row of piece q at rows[q * c + k]), v = value -
 * minus[k] (minus NULL: the value). Each bin's sums run over its samples in order, as
 * numpy's. Returns 0; -1 for sizes beyond the limits or pieces that do not add up to s1;
 * -2 when x falls (the numpy pass turns it round); -3 when a bin holds more samples than the
 * numpy layout pads (its None: the direct sums run), so that both choose alike. */
MOMENT_CLONES int64_t enc_rev_moments(
    int64_t s1, const double *u, int64_t c, int64_t pieces, const int64_t *lengths,
    const double *const *rows, const double *minus, const double *map, int64_t mp,
    int64_t mbins, double start, int64_t nb, int64_t terms, double *x, double *out)
{
    if (c < 1 || c > MAX_CHANNELS || terms < 2 || terms > MAX_TERMS || s1 < 3 || nb < 1
            || pieces < 1)
        return -1;
    int64_t total = 0;
    for (int64_t q = 0; q < pieces; q++) {
        if (lengths[q] < 0) return -1;
        total += lengths[q];
    }
    if (total != s1) return -1;
    const double map_per_rad = (double)mbins / 6.283185307179586;
    for (int64_t j = 0; j < s1; j++) x[j] = mapped(u[j], map, mp, mbins, map_per_rad) - start;
    if (x[s1 - 1] < x[0]) return -2;
    const int64_t ct = c * terms;
    double *by_bin = calloc((size_t)(nb * ct), sizeof(double));  /* a bin's sums side by side */
    double *power = malloc(sizeof(double) * BLOCK * (size_t)terms);
    double *buf = malloc(sizeof(double) * BLOCK * (size_t)c);     /* a block's values */
    if (!by_bin || !power || !buf) {
        free(by_bin);
        free(power);
        free(buf);
        return -1;
    }
    double loc[MAX_CHANNELS * MAX_TERMS] = {0}, w[BLOCK];
    int64_t bin[BLOCK], cur = -1, count = 0, width = 0, piece = 0, off = 0;
    for (int64_t j0 = 0; j0 < s1; j0 += BLOCK) {
        const int64_t n = s1 - j0 < BLOCK ? s1 - j0 : BLOCK;
        block_powers(x, s1, j0, n, (double)nb / 6.283185307179586, nb, terms, bin, w, power);
        gather(n, c, lengths, rows, minus, &piece, &off, buf);
        if (c == 4 && terms == 12)   /* selfcal's four heads at the default band */
            accumulate(buf, BLOCK, n, bin, w, power, 4, 12, by_bin, loc, &cur, &count, &width);
        else
            accumulate(buf, BLOCK, n, bin, w, power, c, terms, by_bin, loc, &cur, &count,
                       &width);
    }
    for (int64_t a = 0; a < ct; a++) by_bin[cur * ct + a] += loc[a];
    if (count > width) width = count;
    for (int64_t b0 = 0; b0 < nb; b0 += 64)  /* bins, channels, terms -> terms, channels, bins */
        for (int64_t a = 0; a < ct; a++) {
            const int64_t k = a / terms, p = a % terms;
            for (int64_t b = b0; b < nb && b < b0 + 64; b++)
                out[(p * c + k) * nb + b] = by_bin[b * ct + a];
        }
    free(by_bin);
    free(power);
    free(buf);
    return nb * width > 4 * s1 + 4096 ? -3 : 0;
}

/* How many of n sample positions rint((u_j - start) / quantum) are among the m ascending,
 * distinct `ordered` (selfcal_uncertainty.SampleRepeats): one merge when the positions do
 * not fall (u rising), else -1 (the numpy binary search runs). */
#define ROUND_SHIFT 6755399441055744.0   /* 1.5 * 2^52 */
#define ROUND_LIMIT 2251799813685248.0   /* 2^51 */

int64_t enc_repeat_count(int64_t n, const double *u, double start, double quantum,
                         int64_t m, const int64_t *ordered)
{
    int64_t found = 0, i = 0, last = INT64_MIN;
    for (int64_t j = 0; j < n; j++) {
        const double r = (u[j] - start) / quantum;
        if (!(r > -ROUND_LIMIT && r < ROUND_LIMIT)) return -1;
        /* rint (to nearest, ties to even) without the maths library: exact below 2^51 */
        const int64_t q = (int64_t)((r + ROUND_SHIFT) - ROUND_SHIFT);
        if (q < last) return -1;
        last = q;
        while (i < m && ordered[i] < q) i++;
        if (i < m && ordered[i] == q) found++;
    }
    return found;
}

/* A readings batch's angle coordinate and channels (revolutions.batch_channels): u_j the
 * mean of the nu coordinate columns' counts, (sum_k counts) * u_scale + u_offset, and row r
 * of values (nv rows of n) counts_r * v_scale[r] + v_offset[r] - u_j, each in numpy's order
 * of operations; *step the largest |u_j - u_(j-1)| (0 for one sample). Returns the sense of
 * u: 1 rising, -1 falling (strictly), else 0. */
int64_t enc_head_channels(int64_t n, int64_t nu, const int64_t *const *coordinate,
                          double u_scale, double u_offset, int64_t nv,
                          const int64_t *const *channel, const double *v_scale,
                          const double *v_offset, double *u, double *values, double *step)
{
    int rising = 1, falling = 1;
    double largest = 0.0;
    for (int64_t j = 0; j < n; j++) {
        double a = (double)coordinate[0][j];
        for (int64_t k = 1; k < nu; k++) a += (double)coordinate[k][j];
        a *= u_scale;
        a += u_offset;
        u[j] = a;
        if (j > 0) {
            rising &= a > u[j - 1];
            falling &= a < u[j - 1];
            const double d = a - u[j - 1];
            const double m = d < 0.0 ? -d : d;
            if (m > largest) largest = m;
        }
    }
    *step = largest;
    for (int64_t r = 0; r < nv; r++) {
        const int64_t *counts = channel[r];
        double *row = values + r * n;
        const double scale = v_scale[r], offset = v_offset[r];
        for (int64_t j = 0; j < n; j++) {
            double v = (double)counts[j];
            v *= scale;
            v += offset;
            v -= u[j];
            row[j] = v;
        }
    }
    return rising ? 1 : falling ? -1 : 0;
}
