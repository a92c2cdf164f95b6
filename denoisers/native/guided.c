/* The guided filter of denoisers.filters.guided_filter on the CPU, float32.
 *
 * Inputs: albedo, normal and color, 3 planes [H, W] each; the guide is albedo, normal and the
 * luminance of color / scale (scale: the frame's mean color, given). Every window mean is a
 * separable box sum over replicated borders: a vertical sum of the 2r + 1 rows (recomputed for
 * each row: no running sums that drift), then a horizontal sum of 2r + 1 columns, times
 * 1 / (2r + 1)^2. Per pixel the 7 x 7 ridge system is solved by Cholesky for the 3 color
 * channels; the 24 coefficient planes are box-averaged the same way and combined with the guide.
 * The operations are the torch path's, in its order, without fused multiply-adds (the build uses
 * -ffp-contract=off); they differ from torch's own kernels by a few float32 roundings.
 *
 * Layout: each thread takes a band of output rows and walks it tile by tile (TILE columns plus
 * halos), two rows at a time (their windows share 2r rows, read once). Per tile it keeps in its
 * caches a ring of the last 2r + 2 input rows with their 59 window channels (guide, color, the 28
 * guide products and the 21 guide-color products), the window means of two rows, and a ring of
 * the last 2r + 2 rows of coefficients. Every value is computed by the same operations whatever
 * band it falls in and whether it is computed alone or paired, so the result does not depend on
 * the thread count.
 *
 * Fireflies: the caller filters a frame with a value above 1e18 in float64 instead (its square
 * overflows float32). The kernel looks for such values as it reads the inputs and then returns 2,
 * with the rule of the torch path's check: a tensor that holds a NaN does not count.
 */
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#if defined(__AVX__) || defined(__SSE__)
#include <immintrin.h>
#endif

#define NG 7                        /* guide channels: albedo, normal, luminance */
#define NC 3                        /* color channels */
#define NB (NG + NC)                /* base channels: the guide, then color */
#define NII 28                      /* guide products i <= j, row by row */
#define NIP (NG * NC)               /* guide-color products, i * 3 + c */
#define NP (NII + NIP)              /* products */
#define NSTAT (NB + NP)             /* window channels */
#define NCOEF (NIP + NC)            /* a (i * 3 + c), then b */
#define TILE 256
#define LANES 8
#define MAX_THREADS 64
#define BANDS_PER_THREAD 4 /* bands of rows per thread, handed out as threads come free */
#define BIG 1e18f
/* Index of the guide product (i, j), i <= j, in the row-by-row upper triangle. */
#define TRI(i, j) ((i) * NG - (i) * ((i) - 1) / 2 + (j) - (i))

typedef float v8 __attribute__((vector_size(32)));
typedef float v8u __attribute__((vector_size(32), aligned(4)));
typedef int32_t v8i __attribute__((vector_size(32)));

static inline v8 load(const float *p) { return *(const v8u *)p; }
static inline void store(float *p, v8 v) { *(v8u *)p = v; }
static inline v8 splat(float x) { return (v8){x, x, x, x, x, x, x, x}; }

/* 1 / sqrt(x) for x > 0 to about 2 ulp: the hardware estimate and one Newton step (a division
 * and a square root cost about ten times as much; torch's own rsqrt is not exact either). */
static inline v8 inv_sqrt(v8 x) {
#if defined(__AVX__)
    v8 y = (v8)_mm256_rsqrt_ps((__m256)x);
    return y * (splat(1.5f) - (splat(0.5f) * x) * (y * y));
#elif defined(__SSE__)
    __m128 lo = _mm_sqrt_ps(_mm_loadu_ps((const float *)&x));
    __m128 hi = _mm_sqrt_ps(_mm_loadu_ps((const float *)&x + 4));
    v8 root;
    _mm_storeu_ps((float *)&root, lo);
    _mm_storeu_ps((float *)&root + 4, hi);
    return splat(1.0f) / root;
#else
    v8 r;
    for (int l = 0; l < LANES; l++) r[l] = 1.0f / sqrtf(x[l]);
    return r;
#endif
}

/* max(x, lo) that keeps NaN, as torch's clamp_min. */
static inline v8 clamp_min(v8 x, v8 lo) {
    v8i below = x < lo;
    return (v8)(((v8i)lo & below) | ((v8i)x & ~below));
}

typedef struct {
    const float *in[9]; /* albedo, normal, color planes */
    float *out;
    int64_t h, w, r, k, slots;
    float eps, floor, inv_kk, scale, weight[3];
} Job;

typedef struct {
    float *ring, *vp, *mean, *coef_ring, *cp, *coef;
    const float **rows; /* the k + 1 rows of two vertical sums */
    int64_t rw, vw, cw, pw, tw;
    v8i big[3], nan[3]; /* per input tensor: saw a value above BIG, saw a NaN */
} Buffers;

static int64_t round8(int64_t n) { return (n + LANES - 1) / LANES * LANES; }
static int64_t clamp64(int64_t v, int64_t lo, int64_t hi) { return v < lo ? lo : v > hi ? hi : v; }
static int64_t min64(int64_t a, int64_t b) { return a < b ? a : b; }
static int64_t max64(int64_t a, int64_t b) { return a > b ? a : b; }

/* Ring slot of input row q's columns [lo, lo + n): the 59 window channels, 8 columns at a time
 * (the last chunk through a zero-padded copy, so nothing past the planes is read). */
static void fill_row(const Job *job, Buffers *buf, int64_t q, int64_t lo, int64_t n) {
    float *dst = buf->ring + (q % job->slots) * NSTAT * buf->rw;
    const v8 big = splat(BIG);
    const v8i magnitude_bits = {INT32_MAX, INT32_MAX, INT32_MAX, INT32_MAX,
                                INT32_MAX, INT32_MAX, INT32_MAX, INT32_MAX};
    for (int64_t x = 0; x < n; x += LANES) {
        v8 in[9], base[NB];
        for (int p = 0; p < 9; p++) {
            const float *src = job->in[p] + q * job->w + lo + x;
            if (x + LANES <= n) {
                in[p] = load(src);
            } else {
                float pad[LANES] = {0};
                memcpy(pad, src, (size_t)(n - x) * sizeof(float));
                in[p] = load(pad);
            }
            buf->big[p / 3] |= (v8)((v8i)in[p] & magnitude_bits) > big;
            buf->nan[p / 3] |= in[p] != in[p];
        }
        for (int c = 0; c < 6; c++) base[c] = in[c];
        for (int c = 0; c < NC; c++) base[NG + c] = in[6 + c];
        /* The luminance of color / scale, rounded as bnerr.color.luminance of it. */
        const v8 scale = splat(job->scale);
        v8 red = in[6] / scale, green = in[7] / scale, blue = in[8] / scale;
        base[6] = (red * splat(job->weight[0]) + green * splat(job->weight[1])) +
                  blue * splat(job->weight[2]);
        for (int c = 0; c < NB; c++) store(dst + c * buf->rw + x, base[c]);
#pragma GCC unroll 8
        for (int i = 0; i < NG; i++) {
#pragma GCC unroll 8
            for (int j = i; j < NG; j++)
                store(dst + (NB + TRI(i, j)) * buf->rw + x, base[i] * base[j]);
#pragma GCC unroll 8
            for (int c = 0; c < NC; c++)
                store(dst + (NB + NII + i * NC + c) * buf->rw + x, base[i] * base[NG + c]);
        }
    }
}

/* dst[x] = rows[0][x] + rows[1][x] + ... + rows[k - 1][x] (in that order), x < n8 (n8 % 8 == 0);
 * with `pair`, also next[x] = rows[1][x] + ... + rows[k][x] (the window one row down), from the
 * same loads. */
static inline __attribute__((always_inline)) void vertical_k(const float *const *rows, int64_t k,
                                                             int64_t n8, float *dst, float *next,
                                                             int pair) {
    for (int64_t x = 0; x < n8; x += LANES) {
        v8 b = load(rows[1] + x), a = load(rows[0] + x) + b;
        for (int64_t d = 2; d < k; d++) {
            v8 v = load(rows[d] + x);
            a = a + v;
            if (pair) b = b + v;
        }
        store(dst + x, a);
        if (pair) store(next + x, b + load(rows[k] + x));
    }
}

/* vertical_k for one row (next == NULL) or two, unrolled for the radii 1 to 3. */
static void vertical(const float *const *rows, int64_t k, int64_t n8, float *dst, float *next) {
#define VERTICAL(K)                                                                               \
    (next ? vertical_k(rows, K, n8, dst, next, 1) : vertical_k(rows, K, n8, dst, NULL, 0))
    switch (k) {
    case 3: VERTICAL(3); break;
    case 5: VERTICAL(5); break;
    case 7: VERTICAL(7); break;
    default: VERTICAL(k);
    }
#undef VERTICAL
}

/* Replicate the border: buf[p] holds column first + p for p in [0, n); positions whose column is
 * left of 0 (right of w - 1) get column 0's (w - 1's) value, which is already in buf. */
static void replicate(float *buf, int64_t first, int64_t n, int64_t w) {
    for (int64_t p = 0; p < n && first + p < 0; p++) buf[p] = buf[-first];
    for (int64_t p = w - first; p < n; p++) buf[p] = buf[w - 1 - first];
}

/* dst[x] = (src[x] + src[x + 1] + ... + src[x + k - 1]) * inv_kk, x < n8 (n8 % 8 == 0). */
static inline __attribute__((always_inline)) void horizontal_k(const float *src, int64_t n8,
                                                               int64_t k, float inv_kk,
                                                               float *dst) {
    const v8 scale = splat(inv_kk);
    for (int64_t x = 0; x < n8; x += LANES) {
        v8 acc = load(src + x);
        for (int64_t d = 1; d < k; d++) acc = acc + load(src + x + d);
        store(dst + x, acc * scale);
    }
}

/* horizontal_k, with the loop over columns unrolled for the radii 1 to 3. */
static void horizontal(const float *src, int64_t n8, int64_t k, float inv_kk, float *dst) {
    switch (k) {
    case 3: horizontal_k(src, n8, 3, inv_kk, dst); break;
    case 5: horizontal_k(src, n8, 5, inv_kk, dst); break;
    case 7: horizontal_k(src, n8, 7, inv_kk, dst); break;
    default: horizontal_k(src, n8, k, inv_kk, dst);
    }
}

/* Cholesky solve of the ridge system for 8 pixels: means (stride ms) -> a, b (stride cs). */
static void solve8(const Job *job, const float *m, int64_t ms, float *coef, int64_t cs) {
    v8 mi[NG], mp[NC], low[NG][NG], inv[NG], x[NG][NC], var[NII];
    const v8 eps = splat(job->eps), floor = splat(job->floor);
    #pragma GCC unroll 8
    for (int i = 0; i < NG; i++) mi[i] = load(m + i * ms);
    #pragma GCC unroll 8
    for (int c = 0; c < NC; c++) mp[c] = load(m + (NG + c) * ms);
    #pragma GCC unroll 8
    for (int i = 0; i < NG; i++)
        #pragma GCC unroll 8
        for (int j = i; j < NG; j++) {
            var[TRI(i, j)] = load(m + (NB + TRI(i, j)) * ms) - mi[i] * mi[j];
            if (i == j) var[TRI(i, j)] = var[TRI(i, j)] + eps;
        }
    #pragma GCC unroll 8
    for (int j = 0; j < NG; j++) {
        v8 pivot = var[TRI(j, j)];
        #pragma GCC unroll 8
        for (int q = 0; q < j; q++) pivot = pivot - low[j][q] * low[j][q];
        inv[j] = inv_sqrt(clamp_min(pivot, floor));
        #pragma GCC unroll 8
        for (int i = j + 1; i < NG; i++) {
            v8 entry = var[TRI(j, i)];
            #pragma GCC unroll 8
            for (int q = 0; q < j; q++) entry = entry - low[i][q] * low[j][q];
            low[i][j] = entry * inv[j];
        }
    }
    #pragma GCC unroll 8
    for (int i = 0; i < NG; i++)
        #pragma GCC unroll 8
        for (int c = 0; c < NC; c++) {
            v8 v = load(m + (NB + NII + i * NC + c) * ms) - mi[i] * mp[c];
            #pragma GCC unroll 8
            for (int q = 0; q < i; q++) v = v - low[i][q] * x[q][c];
            x[i][c] = v * inv[i];
        }
    #pragma GCC unroll 8
    for (int i = NG - 1; i >= 0; i--)
        #pragma GCC unroll 8
        for (int c = 0; c < NC; c++) {
            v8 v = x[i][c];
            #pragma GCC unroll 8
            for (int q = i + 1; q < NG; q++) v = v - low[q][i] * x[q][c];
            x[i][c] = v * inv[i];
            store(coef + (i * NC + c) * cs, x[i][c]);
        }
    #pragma GCC unroll 8
    for (int c = 0; c < NC; c++) {
        v8 sum = splat(0.0f);
        #pragma GCC unroll 8
        for (int i = 0; i < NG; i++) sum = sum + x[i][c] * mi[i];
        store(coef + (NIP + c) * cs, mp[c] - sum);
    }
}

/* The columns of a tile: output [x0, x1), coefficients [ca, cb), inputs [lo, hi). */
typedef struct {
    int64_t x0, x1, ca, cb, lo, hi;
} Tile;

/* Coefficient rows c and, with `pair`, c + 1 at the tile's columns [ca, cb), into their ring. */
static void coefficient_rows(const Job *job, Buffers *buf, const Tile *tile, int64_t c, int pair) {
    const int64_t r = job->r, first = tile->ca - r, n = tile->cb - tile->ca;
    const float **rows = buf->rows;
    float *vp[2] = {buf->vp, buf->vp + buf->vw};
    for (int s = 0; s < NSTAT; s++) {
        for (int64_t d = 0; d < job->k + pair; d++) {
            int64_t q = clamp64(c - r + d, 0, job->h - 1);
            rows[d] = buf->ring + ((q % job->slots) * NSTAT + s) * buf->rw;
        }
        int64_t offset = tile->lo - first;
        vertical(rows, job->k, round8(tile->hi - tile->lo), vp[0] + offset,
                 pair ? vp[1] + offset : NULL);
        for (int j = 0; j <= pair; j++) {
            replicate(vp[j], first, n + 2 * r, job->w);
            horizontal(vp[j], round8(n), job->k, job->inv_kk,
                       buf->mean + (j * NSTAT + s) * buf->cw);
        }
    }
    for (int j = 0; j <= pair; j++) {
        float *slot = buf->coef_ring + ((c + j) % job->slots) * NCOEF * buf->cw;
        const float *mean = buf->mean + j * NSTAT * buf->cw;
        for (int64_t x = 0; x < n; x += LANES) solve8(job, mean + x, buf->cw, slot + x, buf->cw);
    }
}

/* Output row y at the tile's columns [x0, x1) from its box-averaged coefficients `coef`. */
static void combine(const Job *job, const Buffers *buf, const Tile *tile, int64_t y,
                    const float *coef) {
    const int64_t n = tile->x1 - tile->x0;
    const float *guide = buf->ring + (y % job->slots) * NSTAT * buf->rw + (tile->x0 - tile->lo);
    for (int c = 0; c < NC; c++) {
        float *out = job->out + (c * job->h + y) * job->w + tile->x0;
        for (int64_t x = 0; x < n; x += LANES) {
            v8 sum = splat(0.0f);
            for (int i = 0; i < NG; i++)
                sum = sum + load(coef + (i * NC + c) * buf->tw + x) * load(guide + i * buf->rw + x);
            sum = sum + load(coef + (NIP + c) * buf->tw + x);
            if (x + LANES <= n) {
                store(out + x, sum);
            } else {
                float last[LANES];
                store(last, sum);
                memcpy(out + x, last, (size_t)(n - x) * sizeof(float));
            }
        }
    }
}

/* Output rows y and, with `pair`, y + 1: box means of the coefficients, times the guide. */
static void output_rows(const Job *job, Buffers *buf, const Tile *tile, int64_t y, int pair) {
    const int64_t r = job->r, first = tile->x0 - r, n = tile->x1 - tile->x0;
    const float **rows = buf->rows;
    float *cp[2] = {buf->cp, buf->cp + buf->pw};
    for (int ch = 0; ch < NCOEF; ch++) {
        for (int64_t d = 0; d < job->k + pair; d++) {
            int64_t q = clamp64(y - r + d, 0, job->h - 1);
            rows[d] = buf->coef_ring + ((q % job->slots) * NCOEF + ch) * buf->cw;
        }
        int64_t offset = tile->ca - first;
        vertical(rows, job->k, round8(tile->cb - tile->ca), cp[0] + offset,
                 pair ? cp[1] + offset : NULL);
        for (int j = 0; j <= pair; j++) {
            replicate(cp[j], first, n + 2 * r, job->w);
            horizontal(cp[j], round8(n), job->k, job->inv_kk,
                       buf->coef + (j * NCOEF + ch) * buf->tw);
        }
    }
    for (int j = 0; j <= pair; j++) combine(job, buf, tile, y + j, buf->coef + j * NCOEF * buf->tw);
}

static void *alloc(int64_t floats) {
    void *p = NULL;
    if (posix_memalign(&p, 64, (size_t)floats * sizeof(float)) != 0) return NULL;
    memset(p, 0, (size_t)floats * sizeof(float));
    return p;
}

static int make_buffers(const Job *job, Buffers *buf) {
    const int64_t r = job->r;
    memset(buf, 0, sizeof *buf);
    buf->rw = round8(min64(job->w, TILE + 4 * r));
    buf->cw = round8(min64(job->w, TILE + 2 * r));
    buf->tw = round8(TILE);
    buf->vw = round8(2 * r) + buf->rw + buf->cw;
    buf->pw = round8(2 * r) + buf->cw + buf->tw;
    buf->rows = malloc((size_t)(job->k + 1) * sizeof *buf->rows);
    buf->ring = alloc(job->slots * NSTAT * buf->rw);
    buf->vp = alloc(2 * buf->vw);
    buf->mean = alloc(2 * NSTAT * buf->cw);
    buf->coef_ring = alloc(job->slots * NCOEF * buf->cw);
    buf->cp = alloc(2 * buf->pw);
    buf->coef = alloc(2 * NCOEF * buf->tw);
    return buf->ring && buf->vp && buf->mean && buf->coef_ring && buf->cp && buf->coef &&
           buf->rows;
}

static void free_buffers(Buffers *buf) {
    free(buf->ring), free(buf->vp), free(buf->mean);
    free(buf->coef_ring), free(buf->cp), free(buf->coef), free(buf->rows);
}

/* Rows [y0, y1) at one tile's columns, two at a time: input rows enter the ring as coefficient
 * rows need them, coefficient rows (two at a time where both are due) as output rows need them. */
static void run_tile(const Job *job, Buffers *buf, int64_t y0, int64_t y1, const Tile *tile) {
    const int64_t r = job->r, h = job->h;
    int64_t next_in = max64(0, y0 - 2 * r), next_c = max64(0, y0 - r);
    for (int64_t y = y0; y < y1; y += 2) {
        int pair_out = y + 1 < y1;
        int64_t last_c = min64(h - 1, y + pair_out + r);
        while (next_c <= last_c) {
            int pair = next_c + 1 <= last_c;
            for (; next_in <= min64(h - 1, next_c + pair + r); next_in++)
                fill_row(job, buf, next_in, tile->lo, tile->hi - tile->lo);
            coefficient_rows(job, buf, tile, next_c, pair);
            next_c += 1 + pair;
        }
        output_rows(job, buf, tile, y, pair_out);
    }
}

/* Rows [y0, y1), tile by tile. */
static void run_band(const Job *job, Buffers *buf, int64_t y0, int64_t y1) {
    const int64_t r = job->r, w = job->w;
    for (int64_t x0 = 0; x0 < w; x0 += TILE) {
        Tile tile = {x0, min64(w, x0 + TILE), max64(0, x0 - r), min64(w, x0 + TILE + r),
                     max64(0, x0 - 2 * r), min64(w, x0 + TILE + 2 * r)};
        run_tile(job, buf, y0, y1, &tile);
    }
}

/* A thread: takes the next band of rows until none is left (a thread the machine runs less
 * often does fewer). */
typedef struct {
    const Job *job;
    int64_t *next, bands; /* the next band to take (shared), the number of bands */
    int status, big[3], nan[3];
} Worker;

static void *run_worker(void *arg) {
    Worker *me = arg;
    const Job *job = me->job;
    Buffers buf;
    me->status = make_buffers(job, &buf) ? 0 : 1;
    while (me->status == 0) {
        int64_t b = __atomic_fetch_add(me->next, 1, __ATOMIC_RELAXED);
        if (b >= me->bands) break;
        run_band(job, &buf, job->h * b / me->bands, job->h * (b + 1) / me->bands);
    }
    for (int p = 0; p < 3; p++)
        for (int l = 0; l < LANES; l++) {
            me->big[p] |= buf.big[p][l] != 0;
            me->nan[p] |= buf.nan[p][l] != 0;
        }
    free_buffers(&buf);
    return NULL;
}

/* Returns 0 on success, 1 when the sizes are refused or a buffer could not be allocated, 2 when
 * an input holds a value above 1e18 (the caller filters in float64; out is then undefined). */
int bnerr_guided(const float *albedo, const float *normal, const float *color, float *out,
                 int64_t h, int64_t w, int64_t radius, float eps, float floor, float inv_kk,
                 float scale, float w0, float w1, float w2, int threads) {
    if (h <= 0 || w <= 0 || radius < 1 || radius > (int64_t)1 << 20) return 1;
    Job job = {.out = out, .h = h, .w = w, .r = radius, .k = 2 * radius + 1, .eps = eps,
               .floor = floor, .inv_kk = inv_kk, .scale = scale, .weight = {w0, w1, w2}};
    job.slots = min64(job.k + 1, h); /* the rows of two windows, one row apart */
    for (int c = 0; c < 3; c++) {
        job.in[c] = albedo + c * h * w;
        job.in[3 + c] = normal + c * h * w;
        job.in[6 + c] = color + c * h * w;
    }
    threads = (int)min64(min64(threads < 1 ? 1 : threads, MAX_THREADS), h);
    int64_t next = 0, bands = threads > 1 ? min64(h, BANDS_PER_THREAD * threads) : 1;
    Worker workers[MAX_THREADS];
    pthread_t ids[MAX_THREADS];
    int started[MAX_THREADS] = {0};
    for (int t = 0; t < threads; t++) workers[t] = (Worker){&job, &next, bands, 0, {0}, {0}};
    for (int t = 1; t < threads; t++)
        started[t] = pthread_create(&ids[t], NULL, run_worker, &workers[t]) == 0;
    run_worker(&workers[0]);
    int status = 0, big[3] = {0}, nan[3] = {0};
    for (int t = 0; t < threads; t++) {
        if (started[t]) pthread_join(ids[t], NULL);
        status |= workers[t].status;
        for (int p = 0; p < 3; p++) big[p] |= workers[t].big[p], nan[p] |= workers[t].nan[p];
    }
    if (status) return 1;
    for (int p = 0; p < 3; p++)
        if (big[p] && !nan[p]) return 2;
    return 0;
}
