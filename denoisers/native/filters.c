/* bnerr's native CPU kernels for three filters of denoisers/filters.py: the edge-avoiding
   a-trous filter (bnerr_atrous: every pass of it, the color and the variance;
   bnerr_luminance_variance: its spatial variance estimate) and the
   bilateral / joint bilateral filter (bnerr_bilateral: any image and guide channel counts).

   Package data of denoisers.native, which binds it; built by bnerr.native's machinery at first
   use with the system C compiler into a shared library loaded with ctypes; no Python or torch
   headers. float32 planes [C, H, W],
   contiguous. Borders replicate: a tap outside the image reads the nearest pixel (coordinates
   are clamped). Each output pixel is computed by the same operations whatever thread or vector
   lane computes it, so results do not depend on the thread count. Built with
   -ffp-contract=off: every product and sum rounds as written, in the torch path's order where
   that path has one.

   Vectorisation: each inner loop runs over a block of up to BLOCK contiguous pixels of one row
   with restrict pointers and no branches, so the compiler turns it into SIMD code; the exp and
   log are polynomials (about 1 ulp) made of plain float and integer operations for that reason.
   A tap whose shifted block leaves the image reads a clamped copy of the block instead.

   Return codes: 0 success, 1 bad sizes or out of memory (the caller then runs its torch path). */

/* Floating-point exceptions are never unmasked here, so GCC may compute both sides of a select
   (Clang's default): with GCC's default it keeps the clamps as branches and does not vectorise
   the loops that hold them. Results are unchanged: the rounding of every operation is the same. */
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC optimize("no-trapping-math")
#endif

#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define BLOCK 256
#define MAX_THREADS 64
#define MAX_CHANNELS 16

/* a * b + c: one fused multiply-add where the CPU has it (the polynomials below only: shorter
   dependency chains, one rounding fewer; the weights' own arithmetic rounds as written). */
#ifdef __FMA__
#define MADD(a, b, c) fmaf((a), (b), (c))
#else
#define MADD(a, b, c) ((a) * (b) + (c))
#endif

/* exp(x) for x in [-87, 88] (callers clamp): Cephes' expf, round-to-nearest split into
   n ln 2 + r, its degree-5 polynomial of r (evaluated in Estrin's order), times 2^n built from
   its bits. */
static inline float exp_poly(float x) {
    const float magic = 12582912.0f; /* 1.5 * 2^23: adding it rounds to an integer */
    float t = x * 1.44269504088896341f + magic;
    float n = t - magic;
    float r = x - n * 0.693359375f;
    r = r - n * -2.12194440e-4f;
    const float r2 = r * r;
    const float a = MADD(1.9875691500e-4f, r, 1.3981999507e-3f);
    const float b = MADD(8.3334519073e-3f, r, 4.1665795894e-2f);
    const float c = MADD(1.6666665459e-1f, r, 5.0000001201e-1f);
    const float p = MADD(MADD(a, r2, b), r2, c);
    const float e = MADD(p, r2, r) + 1.0f;
    int32_t bits;
    memcpy(&bits, &t, 4);
    bits = (bits - 0x4B400000 + 127) << 23;
    float scale;
    memcpy(&scale, &bits, 4);
    return e * scale;
}

/* log(x) for a normal positive x: Cephes' logf, x = m 2^e with m in [sqrt(1/2), sqrt(2)), its
   degree-8 polynomial of m - 1 (Estrin's order), e ln 2 added in two parts. */
static inline float log_poly(float x) {
    int32_t bits;
    memcpy(&bits, &x, 4);
    int32_t e = ((bits >> 23) & 0xff) - 126;
    bits = (bits & 0x007fffff) | 0x3f000000; /* m in [0.5, 1) */
    float m;
    memcpy(&m, &bits, 4);
    int32_t low = m < 0.707106781186547524f;
    e = e - low;
    const float twice = m + m; /* computed either way: a branch would stop the vectoriser */
    m = (low ? twice : m) - 1.0f;
    const float z = m * m, z2 = z * z;
    const float a = MADD(-1.1514610310e-1f, m, 1.1676998740e-1f);
    const float b = MADD(-1.2420140846e-1f, m, 1.4249322787e-1f);
    const float c = MADD(-1.6668057665e-1f, m, 2.0000714765e-1f);
    const float d = MADD(-2.4999993993e-1f, m, 3.3333331174e-1f);
    const float p = MADD(MADD(7.0376836292e-2f, z2, MADD(a, z, b)), z2, MADD(c, z, d));
    float y = (p * m) * z;
    const float fe = (float)e;
    y = MADD(fe, -2.12194440e-4f, y);
    y = MADD(-0.5f, z, y);
    return MADD(fe, 0.693359375f, m + y);
}

static inline int64_t clamp64(int64_t v, int64_t lo, int64_t hi) {
    return v < lo ? lo : (v > hi ? hi : v);
}

/* Columns x0 + dx .. x0 + dx + n - 1 of a row, clamped into [0, W): a pointer into the row when
   all are inside, else a copy in tmp. */
static inline const float *span(const float *row, int64_t x, int64_t n, int64_t W, float *tmp) {
    if (x >= 0 && x + n <= W) return row + x;
    /* The columns left of the image, those inside, those right of it: two fills and one copy
       (a clamp per element made these copies a third of a pass's instructions at 1080p). */
    const int64_t lo = clamp64(-x, 0, n), hi = clamp64(W - x, lo, n);
    for (int64_t i = 0; i < lo; ++i) tmp[i] = row[0];
    if (hi > lo) memcpy(tmp + lo, row + x + lo, sizeof(float) * (size_t)(hi - lo));
    for (int64_t i = hi; i < n; ++i) tmp[i] = row[W - 1];
    return tmp;
}

/* Run fn on tasks[0 .. n-1] (stride bytes apart), tasks 1.. on new threads, task 0 on this one;
   a task whose thread cannot be created runs here. */
static void run_parallel(void *(*fn)(void *), char *tasks, size_t stride, int n) {
    pthread_t ids[MAX_THREADS];
    int started = 0;
    for (int i = 1; i < n; ++i) {
        if (pthread_create(&ids[i], 0, fn, tasks + i * stride) != 0) break;
        started = i;
    }
    for (int i = started + 1; i < n; ++i) fn(tasks + i * stride);
    fn(tasks);
    for (int i = 1; i <= started; ++i) pthread_join(ids[i], 0);
}

static int clamp_threads(int threads, int64_t rows) {
    if (threads < 1) threads = 1;
    if (threads > MAX_THREADS) threads = MAX_THREADS;
    if (threads > rows) threads = (int)rows;
    return threads;
}

/* ------------------------------------------------------------------------------------------ */
/* A-trous. Planes of the current pass: color [3], variance, normal4 [4] (unit normal and 1.0
   where the ray escaped), depth, depth_width; scratch: luminance and 1 / phi_luminance. */

typedef struct {
    const float *color, *var, *normal4, *depth, *depth_width;
    float *lum, *inv_lum, *out_color, *out_var;
    int64_t H, W, step, y0, y1;
    float sigma_color, sigma_normal, sigma_depth, floor;
    int squarings; /* k where sigma_normal = 2^k, 1 <= k <= MAX_SQUARINGS; else 0 */
    const float *lw;   /* luminance weights [3] */
    const float *blur; /* 3 x 3 variance blur */
} ajob_t;

/* 1 / (sigma_color sqrt(s) + 1e-6), s = the 3 x 3 blur of the variance rows (above, at, below
   the row) around columns x0 .. x1 - 1, clamped at the borders. */
static void blur_columns(const float *const *rows, const float *blur, int64_t W, int64_t x0,
                         int64_t x1, float sigma_color, float *inv) {
    for (int64_t x = x0; x < x1; ++x) {
        float s = 0.0f;
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b) s = s + blur[a * 3 + b] * rows[a][clamp64(x + b - 1, 0, W - 1)];
        inv[x] = 1.0f / (sigma_color * sqrtf(s) + 1e-6f);
    }
}

/* blur_columns for columns 1 .. W - 2 (no clamps needed). */
__attribute__((noinline)) static void blur_inner(const float *restrict r0,
                                                 const float *restrict r1,
                                                 const float *restrict r2, const float *blur,
                                                 int64_t W, float sigma_color,
                                                 float *restrict inv) {
    const float b0 = blur[0], b1 = blur[1], b2 = blur[2], b3 = blur[3], b4 = blur[4];
    const float b5 = blur[5], b6 = blur[6], b7 = blur[7], b8 = blur[8];
    for (int64_t x = 1; x < W - 1; ++x) {
        float s = 0.0f;
        s = s + b0 * r0[x - 1];
        s = s + b1 * r0[x];
        s = s + b2 * r0[x + 1];
        s = s + b3 * r1[x - 1];
        s = s + b4 * r1[x];
        s = s + b5 * r1[x + 1];
        s = s + b6 * r2[x - 1];
        s = s + b7 * r2[x];
        s = s + b8 * r2[x + 1];
        inv[x] = 1.0f / (sigma_color * sqrtf(s) + 1e-6f);
    }
}

/* Phase 1 of a pass, rows y0 .. y1: luminance and 1 / (sigma_color sqrt(g3x3(var)) + 1e-6). */
static void *atrous_prepare(void *arg) {
    const ajob_t *j = (const ajob_t *)arg;
    const int64_t H = j->H, W = j->W, P = H * W;
    for (int64_t y = j->y0; y < j->y1; ++y) {
        const float *c = j->color + y * W;
        float *lum = j->lum + y * W, *inv = j->inv_lum + y * W;
        for (int64_t x = 0; x < W; ++x)
            lum[x] = (j->lw[0] * c[x] + j->lw[1] * c[P + x]) + j->lw[2] * c[2 * P + x];
        const float *rows[3];
        for (int a = 0; a < 3; ++a) rows[a] = j->var + clamp64(y + a - 1, 0, H - 1) * W;
        /* The border columns with clamped indices, the others in a loop without clamps (which
           the compiler vectorises); the same sums in the same order either way. */
        blur_columns(rows, j->blur, W, 0, W < 2 ? W : 1, j->sigma_color, inv);
        blur_inner(rows[0], rows[1], rows[2], j->blur, W, j->sigma_color, inv);
        if (W > 1) blur_columns(rows, j->blur, W, W - 1, W, j->sigma_color, inv);
    }
    return 0;
}

/* The pixel data one tap reads (q) or its block's centre pixels hold (p). */
typedef struct {
    const float *c[3], *lum, *var, *n[4], *z;
} taprow_t;

typedef struct {
    float c[3][BLOCK], v[BLOCK], w[BLOCK];
} aacc_t;

/* c = c^(2^k) over n values (k squarings); k is a constant where this is inlined. */
static inline __attribute__((always_inline)) void square_k(int64_t n, float *restrict c, int k) {
    for (int64_t i = 0; i < n; ++i) {
        float v = c[i];
        for (int t = 0; t < k; ++t) v = v * v;
        c[i] = v;
    }
}

/* square_k with k = 1 .. MAX_SQUARINGS, each a loop of its own with the squarings unrolled. */
#define MAX_SQUARINGS 8
static void power_of_two(int64_t n, float *restrict c, int k) {
    switch (k) {
    case 1: square_k(n, c, 1); break;
    case 2: square_k(n, c, 2); break;
    case 3: square_k(n, c, 3); break;
    case 4: square_k(n, c, 4); break;
    case 5: square_k(n, c, 5); break;
    case 6: square_k(n, c, 6); break;
    case 7: square_k(n, c, 7); break;
    default: square_k(n, c, 8); break;
    }
}

/* The sums of one tap: weight (exp(a) * f) * h (f NULL: exp(a) * h), its color and its squared
   variance added to the accumulators. */
static inline __attribute__((always_inline)) void tap_sums(
    int64_t n, const float *restrict a, const float *restrict f, const float *restrict qc0,
    const float *restrict qc1, const float *restrict qc2, const float *restrict qv,
    float *restrict s0, float *restrict s1, float *restrict s2, float *restrict sv,
    float *restrict sw, float h) {
    for (int64_t i = 0; i < n; ++i) {
        const float wt = (f ? exp_poly(a[i]) * f[i] : exp_poly(a[i])) * h;
        sw[i] = sw[i] + wt;
        s0[i] = s0[i] + wt * qc0[i];
        s1[i] = s1[i] + wt * qc1[i];
        s2[i] = s2[i] + wt * qc2[i];
        sv[i] = sv[i] + (wt * wt) * qv[i];
    }
}

/* One tap over n pixels (n <= BLOCK): weight h * exp(max(-80, sigma_n log(max(cos, floor)) - e)),
   e = |l_p - l_q| / phi_l + |z_p - z_q| / phi_z; sigma_n 0: -80 |esc_p - esc_q| - e. Short loops
   (exponent terms, log, exp and sums) instead of one: each has a shorter dependency chain, so the
   CPU overlaps more pixels (about twice as fast as the single loop).

   sigma_n = 2^k (squarings k, 1 .. MAX_SQUARINGS; 128, the default and every tuned filter's, is
   2^7): h * exp(max(-80, -e)) * max(cos, floor)^sigma_n, the power by k squarings instead of a
   log and a multiplication (a quarter fewer instructions per tap). The same weight within
   float32 rounding (k squarings: about 2^k / 2 ulps, the log's path about as many), except one
   that the log's path raises to exp(-80) (1.8e-35, below any output's ulp) may be smaller. */
__attribute__((noinline)) static void atrous_tap(
    int64_t n, const float *restrict qc0, const float *restrict qc1, const float *restrict qc2,
    const float *restrict ql, const float *restrict qv, const float *restrict qn0,
    const float *restrict qn1, const float *restrict qn2, const float *restrict qn3,
    const float *restrict qz, const float *restrict pl, const float *restrict pz,
    const float *restrict pn0, const float *restrict pn1, const float *restrict pn2,
    const float *restrict pn3, const float *restrict inv_l, const float *restrict inv_z,
    float *restrict s0, float *restrict s1, float *restrict s2, float *restrict sv,
    float *restrict sw, float h, float sigma_n, float floor, int squarings) {
    float ea[BLOCK], cosa[BLOCK];
    float *restrict e = ea, *restrict cs = cosa;
    for (int64_t i = 0; i < n; ++i) {
        float t = fabsf(ql[i] - pl[i]) * inv_l[i];
        e[i] = t + fabsf(qz[i] - pz[i]) * inv_z[i];
    }
    if (sigma_n != 0.0f) {
        for (int64_t i = 0; i < n; ++i) {
            float c = qn0[i] * pn0[i];
            c = c + qn1[i] * pn1[i];
            c = c + qn2[i] * pn2[i];
            c = c + qn3[i] * pn3[i];
            cs[i] = c < floor ? floor : c;
        }
        if (squarings > 0) {
            power_of_two(n, cs, squarings);
            for (int64_t i = 0; i < n; ++i) e[i] = -e[i] < -80.0f ? -80.0f : -e[i];
            tap_sums(n, e, cs, qc0, qc1, qc2, qv, s0, s1, s2, sv, sw, h);
            return;
        }
        for (int64_t i = 0; i < n; ++i) {
            const float a = log_poly(cs[i]) * sigma_n - e[i];
            cs[i] = a < -80.0f ? -80.0f : a;
        }
    } else {
        for (int64_t i = 0; i < n; ++i) {
            const float a = fabsf(qn3[i] - pn3[i]) * -80.0f - e[i];
            cs[i] = a < -80.0f ? -80.0f : a;
        }
    }
    tap_sums(n, cs, 0, qc0, qc1, qc2, qv, s0, s1, s2, sv, sw, h);
}

/* Pointers to the 10 planes of row y, columns x .. x + n - 1 (clamped copies in tmp). */
static taprow_t atrous_row(const ajob_t *j, int64_t y, int64_t x, int64_t n, float (*tmp)[BLOCK]) {
    const int64_t W = j->W, P = j->H * W, o = y * W;
    taprow_t r;
    for (int k = 0; k < 3; ++k) r.c[k] = span(j->color + k * P + o, x, n, W, tmp[k]);
    r.lum = span(j->lum + o, x, n, W, tmp[3]);
    r.var = span(j->var + o, x, n, W, tmp[4]);
    for (int k = 0; k < 4; ++k) r.n[k] = span(j->normal4 + k * P + o, x, n, W, tmp[5 + k]);
    r.z = span(j->depth + o, x, n, W, tmp[9]);
    return r;
}

static const float B3[5] = {1.0f / 16.0f, 1.0f / 4.0f, 3.0f / 8.0f, 1.0f / 4.0f, 1.0f / 16.0f};

/* The 25 taps of one pass over the block of row y starting at column x0 (n pixels). */
static void atrous_block(const ajob_t *j, int64_t y, int64_t x0, int64_t n, aacc_t *acc,
                         float (*tmp)[BLOCK]) {
    const int64_t W = j->W, P = j->H * W, o = y * W + x0, s = j->step;
    const float *pn[4];
    for (int k = 0; k < 4; ++k) pn[k] = j->normal4 + k * P + o;
    /* 1 / (sigma_z |grad z| d + 1e-6) for each of the 6 tap distances d of the 5 x 5 kernel. */
    static const int D2[6] = {0, 1, 2, 4, 5, 8};
    float inv_z[6][BLOCK];
    for (int k = 0; k < 6; ++k) {
        const float d = (float)(sqrt((double)D2[k]) * (double)s);
        for (int64_t i = 0; i < n; ++i)
            inv_z[k][i] = 1.0f / ((j->sigma_depth * j->depth_width[o + i]) * d + 1e-6f);
    }
    memset(acc, 0, sizeof(*acc));
    for (int iy = 0; iy < 5; ++iy) {
        const int64_t qy = clamp64(y + (iy - 2) * s, 0, j->H - 1);
        for (int ix = 0; ix < 5; ++ix) {
            const taprow_t q = atrous_row(j, qy, x0 + (ix - 2) * s, n, tmp);
            const int d2 = (iy - 2) * (iy - 2) + (ix - 2) * (ix - 2);
            int k = 0;
            while (D2[k] != d2) ++k;
            atrous_tap(n, q.c[0], q.c[1], q.c[2], q.lum, q.var, q.n[0], q.n[1], q.n[2], q.n[3],
                       q.z, j->lum + o, j->depth + o, pn[0], pn[1], pn[2], pn[3],
                       j->inv_lum + o, inv_z[k], acc->c[0], acc->c[1], acc->c[2], acc->v, acc->w,
                       B3[iy] * B3[ix], j->sigma_normal, j->floor, j->squarings);
        }
    }
}

/* Phase 2 of a pass, rows y0 .. y1: the weighted means of color and (squared weights) variance. */
static void *atrous_rows(void *arg) {
    const ajob_t *j = (const ajob_t *)arg;
    const int64_t W = j->W, P = j->H * W;
    aacc_t acc;
    float tmp[10][BLOCK];
    for (int64_t y = j->y0; y < j->y1; ++y) {
        for (int64_t x0 = 0; x0 < W; x0 += BLOCK) {
            const int64_t n = W - x0 < BLOCK ? W - x0 : BLOCK, o = y * W + x0;
            atrous_block(j, y, x0, n, &acc, tmp);
            for (int64_t i = 0; i < n; ++i) {
                for (int k = 0; k < 3; ++k) j->out_color[k * P + o + i] = acc.c[k][i] / acc.w[i];
                j->out_var[o + i] = acc.v[i] / (acc.w[i] * acc.w[i]);
            }
        }
    }
    return 0;
}

static void atrous_pass(ajob_t *jobs, int threads) {
    run_parallel(atrous_prepare, (char *)jobs, sizeof(ajob_t), threads);
    run_parallel(atrous_rows, (char *)jobs, sizeof(ajob_t), threads);
}

/* All passes of the filter: pass i has hole spacing 2^i and reads the previous pass's color and
   variance; out [3, H, W] receives the last pass's color. sigmas: color, normal, depth; floor:
   the smallest cosine the normal weight takes the log of. */
int bnerr_atrous(const float *color, const float *variance, const float *normal4,
                 const float *depth, const float *depth_width, float *out, int64_t H, int64_t W,
                 int iterations, float sigma_color, float sigma_normal, float sigma_depth,
                 float floor, const float *lum_weights, const float *blur, int threads) {
    if (H < 1 || W < 1 || iterations < 1 || iterations > 20) return 1;
    const int64_t P = H * W;
    float *buf = (float *)malloc(sizeof(float) * (size_t)P * 7);
    if (!buf) return 1;
    /* buf: a color [3] and two variance planes, luminance, 1 / phi_l. The passes alternate
       between buf's color and out, in the order that ends in out. */
    float *col[2] = {out, buf}, *var[2] = {buf + 3 * P, buf + 4 * P};
    threads = clamp_threads(threads, H);
    int squarings = 0;
    for (int k = 1; k <= MAX_SQUARINGS; ++k)
        if (sigma_normal == (float)(1 << k)) squarings = k;
    ajob_t jobs[MAX_THREADS];
    const float *c = color, *v = variance;
    for (int it = 0; it < iterations; ++it) {
        float *oc = col[(iterations - 1 - it) & 1], *ov = var[it & 1];
        for (int i = 0; i < threads; ++i) {
            ajob_t jb = {c, v, normal4, depth, depth_width, buf + 5 * P, buf + 6 * P, oc, ov,
                         H, W, (int64_t)1 << it, H * i / threads, H * (i + 1) / threads,
                         sigma_color, sigma_normal, sigma_depth, floor, squarings,
                         lum_weights, blur};
            jobs[i] = jb;
        }
        atrous_pass(jobs, threads);
        c = oc;
        v = ov;
    }
    free(buf);
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Spatial variance of the luminance: box(l^2) - box(l)^2 (at least 0) in a (2r+1)^2 window with a
   replicate border, l = (w0 R + w1 G) + w2 B (SVGF's estimate without history). */

typedef struct {
    const float *color, *lw;
    float *lum, *out; /* lum: [2, H, W] scratch, luminance and its square */
    float *row;       /* this job's scratch: 2 (W + 2r) + 2 W floats */
    int64_t H, W, r, y0, y1;
} vjob_t;

static void *variance_lum(void *arg) {
    const vjob_t *j = (const vjob_t *)arg;
    const int64_t W = j->W, P = j->H * W;
    for (int64_t i = j->y0 * W; i < j->y1 * W; ++i) {
        const float l = (j->lw[0] * j->color[i] + j->lw[1] * j->color[P + i]) + j->lw[2] * j->color[2 * P + i];
        j->lum[i] = l;
        j->lum[P + i] = l * l;
    }
    return 0;
}

/* Sums of 2r + 1 consecutive values of pad (W + 2r values) into out (W values). */
__attribute__((noinline)) static void window_sums(const float *restrict pad, int64_t W, int64_t r,
                                                  float *restrict out) {
    for (int64_t x = 0; x < W; ++x) out[x] = pad[x];
    for (int64_t d = 1; d <= 2 * r; ++d)
        for (int64_t x = 0; x < W; ++x) out[x] = out[x] + pad[x + d];
}

static void *variance_rows(void *arg) {
    const vjob_t *j = (const vjob_t *)arg;
    const int64_t W = j->W, H = j->H, P = H * W, r = j->r;
    float *buf = j->row;
    float *pad[2] = {buf, buf + W + 2 * r}, *box[2] = {buf + 2 * (W + 2 * r), buf + 2 * (W + 2 * r) + W};
    const float scale = 1.0f / (float)((2 * r + 1) * (2 * r + 1));
    for (int64_t y = j->y0; y < j->y1; ++y) {
        for (int c = 0; c < 2; ++c) {
            /* Column sums of the window's rows, then window sums along the padded row. */
            float *col = pad[c] + r;
            const float *src = j->lum + c * P;
            memcpy(col, src + clamp64(y - r, 0, H - 1) * W, sizeof(float) * (size_t)W);
            for (int64_t d = -r + 1; d <= r; ++d) {
                const float *row = src + clamp64(y + d, 0, H - 1) * W;
                for (int64_t x = 0; x < W; ++x) col[x] = col[x] + row[x];
            }
            for (int64_t i = 0; i < r; ++i) {
                pad[c][i] = col[0];
                col[W + i] = col[W - 1];
            }
            window_sums(pad[c], W, r, box[c]);
        }
        float *out = j->out + y * W;
        for (int64_t x = 0; x < W; ++x) {
            const float m = box[0][x] * scale, v = box[1][x] * scale - m * m;
            out[x] = v > 0.0f ? v : 0.0f;
        }
    }
    return 0;
}

/* color [3, H, W] -> out [H, W]; lum_weights [3]; radius r >= 0. */
int bnerr_luminance_variance(const float *color, float *out, int64_t H, int64_t W, int64_t r,
                             const float *lum_weights, int threads) {
    if (H < 1 || W < 1 || r < 0 || r > 64) return 1;
    threads = clamp_threads(threads, H);
    const int64_t per_job = 2 * (W + 2 * r) + 2 * W;
    float *lum = (float *)malloc(sizeof(float) * (size_t)(2 * H * W + threads * per_job));
    if (!lum) return 1;
    vjob_t jobs[MAX_THREADS];
    for (int i = 0; i < threads; ++i) {
        vjob_t jb = {color, lum_weights, lum, out, lum + 2 * H * W + i * per_job,
                     H, W, r, H * i / threads, H * (i + 1) / threads};
        jobs[i] = jb;
    }
    run_parallel(variance_lum, (char *)jobs, sizeof(vjob_t), threads);
    run_parallel(variance_rows, (char *)jobs, sizeof(vjob_t), threads);
    free(lum);
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Bilateral. weight_q = space_q exp(scale sum_c (g_q - g_p)^2), out = sum_q w_q v_q / sum_q w_q
   (kornia's bilateral_blur with an L2 color distance, taps in row-major order). Weights whose
   exponent is below -80 are 0 (they are below 2e-35 of the centre's). */

typedef struct {
    const float *image, *guide, *space;
    float *out;
    int64_t H, W, ci, cg, ky, kx, y0, y1;
    float scale;
} bjob_t;

/* d2 (+)= (q - p)^2 over n pixels; first: d2 = instead of d2 +=. */
__attribute__((noinline)) static void bil_distance(int64_t n, const float *restrict q,
                                                   const float *restrict p, float *restrict d2,
                                                   int first) {
    if (first) {
        for (int64_t i = 0; i < n; ++i) {
            const float d = q[i] - p[i];
            d2[i] = d * d;
        }
    } else {
        for (int64_t i = 0; i < n; ++i) {
            const float d = q[i] - p[i];
            d2[i] = d2[i] + d * d;
        }
    }
}

/* w = exp(scale d2) * space (0 below exp(-80)); norm += w. */
__attribute__((noinline)) static void bil_weight(int64_t n, const float *restrict d2,
                                                 float *restrict w, float *restrict norm,
                                                 float scale, float space) {
    for (int64_t i = 0; i < n; ++i) {
        float a = d2[i] * scale;
        const int none = !(a >= -80.0f);
        a = none ? -80.0f : a;
        const float wt = none ? 0.0f : exp_poly(a) * space;
        w[i] = wt;
        norm[i] = norm[i] + wt;
    }
}

__attribute__((noinline)) static void bil_accumulate(int64_t n, const float *restrict v,
                                                     const float *restrict w,
                                                     float *restrict acc) {
    for (int64_t i = 0; i < n; ++i) acc[i] = acc[i] + v[i] * w[i];
}

static void bil_block(const bjob_t *j, int64_t y, int64_t x0, int64_t n, float (*acc)[BLOCK],
                      float *norm, float (*tmp)[BLOCK]) {
    const int64_t W = j->W, P = j->H * W, ry = j->ky / 2, rx = j->kx / 2;
    float d2[BLOCK], w[BLOCK];
    memset(norm, 0, sizeof(float) * BLOCK);
    for (int64_t c = 0; c < j->ci; ++c) memset(acc[c], 0, sizeof(float) * BLOCK);
    for (int64_t ty = 0; ty < j->ky; ++ty) {
        const int64_t o = clamp64(y + ty - ry, 0, j->H - 1) * W;
        for (int64_t tx = 0; tx < j->kx; ++tx) {
            const int64_t x = x0 + tx - rx;
            for (int64_t c = 0; c < j->cg; ++c)
                bil_distance(n, span(j->guide + c * P + o, x, n, W, tmp[0]),
                             j->guide + c * P + y * W + x0, d2, c == 0);
            bil_weight(n, d2, w, norm, j->scale, j->space[ty * j->kx + tx]);
            for (int64_t c = 0; c < j->ci; ++c)
                bil_accumulate(n, span(j->image + c * P + o, x, n, W, tmp[0]), w, acc[c]);
        }
    }
}

static void *bil_rows(void *arg) {
    const bjob_t *j = (const bjob_t *)arg;
    const int64_t W = j->W, P = j->H * W;
    float acc[MAX_CHANNELS][BLOCK], norm[BLOCK], tmp[1][BLOCK];
    for (int64_t y = j->y0; y < j->y1; ++y) {
        for (int64_t x0 = 0; x0 < W; x0 += BLOCK) {
            const int64_t n = W - x0 < BLOCK ? W - x0 : BLOCK, o = y * W + x0;
            bil_block(j, y, x0, n, acc, norm, tmp);
            for (int64_t c = 0; c < j->ci; ++c)
                for (int64_t i = 0; i < n; ++i) j->out[c * P + o + i] = acc[c][i] / norm[i];
        }
    }
    return 0;
}

/* image [ci, H, W], guide [cg, H, W] (may be the image), space [ky * kx] (odd sizes),
   scale = -1 / (2 sigma_color^2); out [ci, H, W]. */
int bnerr_bilateral(const float *image, int64_t ci, const float *guide, int64_t cg,
                    const float *space, int64_t ky, int64_t kx, float scale, float *out,
                    int64_t H, int64_t W, int threads) {
    if (H < 1 || W < 1 || ci < 1 || ci > MAX_CHANNELS || cg < 1 || ky < 1 || kx < 1 ||
        ky % 2 == 0 || kx % 2 == 0)
        return 1;
    threads = clamp_threads(threads, H);
    bjob_t jobs[MAX_THREADS];
    for (int i = 0; i < threads; ++i) {
        bjob_t jb = {image, guide, space, out, H, W, ci, cg, ky, kx,
                     H * i / threads, H * (i + 1) / threads, scale};
        jobs[i] = jb;
    }
    run_parallel(bil_rows, (char *)jobs, sizeof(bjob_t), threads);
    return 0;
}
