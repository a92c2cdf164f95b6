/* The guided filter of denoisers.filters.guided_filter on the CPU, float32.
 *
 * Guide: 7 planes (albedo, normal, luminance), input: 3 color planes, all [H, W]. Every window
 * mean is a separable box sum over replicated borders: a vertical sum of 2r + 1 rows (each term
 * recomputed from the inputs, no running sums that drift), then a horizontal sum of 2r + 1
 * columns, times 1 / (2r + 1)^2. Per pixel the 7 x 7 ridge system is solved by Cholesky for the 3
 * color channels; the 24 coefficient planes are box-averaged the same way and combined with the
 * guide. The operations are the torch path's, in its order, without fused multiply-adds (the
 * build uses -ffp-contract=off); they differ from torch's kernels by a few float32 roundings.
 *
 * Layout: each thread takes a band of output rows and walks it tile by tile (TILE columns plus
 * halos), keeping the window statistics of one row and a ring of the last 2r + 1 coefficient rows
 * in its caches. Each value is computed by the same operations whatever the band, so the result
 * does not depend on the thread count.
 */
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#if defined(__AVX__)
#include <immintrin.h>
#endif

#define NG 7                       /* guide channels */
#define NC 3                       /* color channels */
#define NII 28                     /* guide products i <= j, row by row */
#define NIP (NG * NC)              /* guide-color products, i * 3 + c */
#define NSTAT (NG + NC + NII + NIP) /* window means: guide, color, products */
#define NCOEF (NIP + NC)           /* a (i * 3 + c), then b */
#define TILE 256
#define LANES 8
#define MAX_THREADS 64

typedef float v8 __attribute__((vector_size(32)));
typedef float v8u __attribute__((vector_size(32), aligned(4)));
typedef int32_t v8i __attribute__((vector_size(32)));

static inline v8 load(const float *p) { return *(const v8u *)p; }
static inline void store(float *p, v8 v) { *(v8u *)p = v; }
static inline v8 splat(float x) { return (v8){x, x, x, x, x, x, x, x}; }

static inline v8 vsqrt(v8 x) {
#if defined(__AVX__)
    return (v8)_mm256_sqrt_ps((__m256)x);
#else
    v8 r;
    for (int l = 0; l < LANES; l++) r[l] = sqrtf(x[l]);
    return r;
#endif
}

/* max(x, lo) that keeps NaN, as torch's clamp_min. */
static inline v8 clamp_min(v8 x, v8 lo) {
    v8i below = x < lo;
    return (v8)(((v8i)lo & below) | ((v8i)x & ~below));
}

typedef struct {
    const float *in[NG + NC]; /* guide planes, then color planes */
    float *out;
    int64_t h, w, r, k, slots;
    float eps, floor, inv_kk;
    int pair_a[NSTAT], pair_b[NSTAT]; /* a statistic is in[a] (b < 0) or in[a] * in[b] */
    int tri[NG][NG];                  /* slot of (i, j) among the 28 guide products */
} Job;

typedef struct {
    float *vp, *mean, *ring, *cp, *coef;
    int64_t vw, cw, pw, tw;
} Buffers;

static int64_t round8(int64_t n) { return (n + LANES - 1) / LANES * LANES; }
static int64_t clamp64(int64_t v, int64_t lo, int64_t hi) { return v < lo ? lo : v > hi ? hi : v; }

static void init_job(Job *job) {
    int s = 0;
    for (int i = 0; i < NG + NC; i++, s++) job->pair_a[s] = i, job->pair_b[s] = -1;
    for (int i = 0; i < NG; i++)
        for (int j = i; j < NG; j++, s++) {
            job->tri[i][j] = job->tri[j][i] = s - NG - NC;
            job->pair_a[s] = i, job->pair_b[s] = j;
        }
    for (int i = 0; i < NG; i++)
        for (int c = 0; c < NC; c++, s++) job->pair_a[s] = i, job->pair_b[s] = NG + c;
}

/* dst[x - lo] = sum over the window's rows (top to bottom, clamped) of the statistic s at
 * column x, for x in [lo, hi). */
static void vertical(const Job *job, int s, int64_t row, int64_t lo, int64_t hi, float *dst) {
    const float *a = job->in[job->pair_a[s]];
    const float *b = job->pair_b[s] < 0 ? NULL : job->in[job->pair_b[s]];
    const int64_t w = job->w, n = hi - lo;
    for (int64_t d = 0; d < job->k; d++) {
        int64_t y = clamp64(row - job->r + d, 0, job->h - 1);
        const float *pa = a + y * w + lo, *pb = b ? b + y * w + lo : NULL;
        int64_t x = 0;
        if (d == 0 && pb) {
            for (; x + LANES <= n; x += LANES) store(dst + x, load(pa + x) * load(pb + x));
            for (; x < n; x++) dst[x] = pa[x] * pb[x];
        } else if (d == 0) {
            memcpy(dst, pa, (size_t)n * sizeof(float));
        } else if (pb) {
            for (; x + LANES <= n; x += LANES)
                store(dst + x, load(dst + x) + load(pa + x) * load(pb + x));
            for (; x < n; x++) dst[x] = dst[x] + pa[x] * pb[x];
        } else {
            for (; x + LANES <= n; x += LANES) store(dst + x, load(dst + x) + load(pa + x));
            for (; x < n; x++) dst[x] = dst[x] + pa[x];
        }
    }
}

/* Replicate the border: buf[p] holds column first + p for p in [0, n); positions whose column is
 * left of 0 (right of w - 1) get column 0's (w - 1's) value, which is already in buf. */
static void replicate(float *buf, int64_t first, int64_t n, int64_t w) {
    for (int64_t p = 0; p < n && first + p < 0; p++) buf[p] = buf[-first];
    for (int64_t p = w - first; p < n; p++) buf[p] = buf[w - 1 - first];
}

/* dst[x] = (src[x] + src[x + 1] + ... + src[x + k - 1]) * inv_kk, x in [0, n8) (n8 % 8 == 0). */
static void horizontal(const float *src, int64_t n8, int64_t k, float inv_kk, float *dst) {
    v8 scale = splat(inv_kk);
    for (int64_t x = 0; x < n8; x += LANES) {
        v8 acc = load(src + x);
        for (int64_t d = 1; d < k; d++) acc = acc + load(src + x + d);
        store(dst + x, acc * scale);
    }
}

/* Cholesky solve of the ridge system for 8 pixels: means (stride ms) -> a, b (stride cs). */
static void solve8(const Job *job, const float *m, int64_t ms, float *coef, int64_t cs) {
    v8 mi[NG], mp[NC], low[NG][NG], inv[NG], x[NG][NC], var[NII];
    const v8 eps = splat(job->eps), floor = splat(job->floor);
    for (int i = 0; i < NG; i++) mi[i] = load(m + i * ms);
    for (int c = 0; c < NC; c++) mp[c] = load(m + (NG + c) * ms);
    for (int i = 0; i < NG; i++)
        for (int j = i; j < NG; j++) {
            int t = job->tri[i][j];
            var[t] = load(m + (NG + NC + t) * ms) - mi[i] * mi[j];
            if (i == j) var[t] = var[t] + eps;
        }
    for (int j = 0; j < NG; j++) {
        v8 pivot = var[job->tri[j][j]];
        for (int q = 0; q < j; q++) pivot = pivot - low[j][q] * low[j][q];
        inv[j] = splat(1.0f) / vsqrt(clamp_min(pivot, floor));
        for (int i = j + 1; i < NG; i++) {
            v8 entry = var[job->tri[i][j]];
            for (int q = 0; q < j; q++) entry = entry - low[i][q] * low[j][q];
            low[i][j] = entry * inv[j];
        }
    }
    for (int i = 0; i < NG; i++)
        for (int c = 0; c < NC; c++) {
            v8 v = load(m + (NG + NC + NII + i * NC + c) * ms) - mi[i] * mp[c];
            for (int q = 0; q < i; q++) v = v - low[i][q] * x[q][c];
            x[i][c] = v * inv[i];
        }
    for (int i = NG - 1; i >= 0; i--)
        for (int c = 0; c < NC; c++) {
            v8 v = x[i][c];
            for (int q = i + 1; q < NG; q++) v = v - low[q][i] * x[q][c];
            x[i][c] = v * inv[i];
            store(coef + (i * NC + c) * cs, x[i][c]);
        }
    for (int c = 0; c < NC; c++) {
        v8 sum = splat(0.0f);
        for (int i = 0; i < NG; i++) sum = sum + x[i][c] * mi[i];
        store(coef + (NIP + c) * cs, mp[c] - sum);
    }
}

/* The coefficients of row `row` at columns [ca, cb) into ring slot row % slots. */
static void coefficient_row(const Job *job, Buffers *buf, int64_t row, int64_t ca, int64_t cb) {
    const int64_t r = job->r, first = ca - r, n = cb - ca;
    const int64_t lo = first < 0 ? 0 : first, hi = cb + r > job->w ? job->w : cb + r;
    for (int s = 0; s < NSTAT; s++) {
        float *vp = buf->vp + s * buf->vw;
        vertical(job, s, row, lo, hi, vp + (lo - first));
        replicate(vp, first, n + 2 * r, job->w);
        horizontal(vp, round8(n), job->k, job->inv_kk, buf->mean + s * buf->cw);
    }
    float *slot = buf->ring + (row % job->slots) * NCOEF * buf->cw;
    for (int64_t x = 0; x < n; x += LANES)
        solve8(job, buf->mean + x, buf->cw, slot + x, buf->cw);
}

/* Output row y at columns [x0, x1), from the ring that holds coefficient columns [ca, cb). */
static void output_row(const Job *job, Buffers *buf, int64_t y, int64_t x0, int64_t x1,
                       int64_t ca, int64_t cb) {
    const int64_t r = job->r, first = x0 - r, n = x1 - x0, nc = cb - ca, w = job->w;
    const int64_t ring_row = NCOEF * buf->cw;
    for (int ch = 0; ch < NCOEF; ch++) {
        float *cp = buf->cp + ch * buf->pw, *dst = cp + (ca - first);
        for (int64_t d = 0; d < job->k; d++) {
            int64_t row = clamp64(y - r + d, 0, job->h - 1);
            const float *src = buf->ring + (row % job->slots) * ring_row + ch * buf->cw;
            int64_t x = 0;
            if (d == 0) {
                memcpy(dst, src, (size_t)nc * sizeof(float));
                continue;
            }
            for (; x + LANES <= nc; x += LANES) store(dst + x, load(dst + x) + load(src + x));
            for (; x < nc; x++) dst[x] = dst[x] + src[x];
        }
        replicate(cp, first, n + 2 * r, w);
        horizontal(cp, round8(n), job->k, job->inv_kk, buf->coef + ch * buf->tw);
    }
    for (int c = 0; c < NC; c++) {
        float *out = job->out + (c * job->h + y) * w + x0;
        for (int64_t x = 0; x < n; x++) {
            float sum = 0.0f;
            for (int i = 0; i < NG; i++)
                sum = sum + buf->coef[(i * NC + c) * buf->tw + x] * job->in[i][y * w + x0 + x];
            out[x] = sum + buf->coef[(NIP + c) * buf->tw + x];
        }
    }
}

static void *alloc(int64_t floats) {
    void *p = NULL;
    if (posix_memalign(&p, 64, (size_t)floats * sizeof(float)) != 0) return NULL;
    memset(p, 0, (size_t)floats * sizeof(float));
    return p;
}

static int make_buffers(const Job *job, Buffers *buf) {
    const int64_t r = job->r;
    buf->cw = round8(TILE + 2 * r);
    buf->vw = round8(buf->cw + 2 * r);
    buf->tw = round8(TILE);
    buf->pw = round8(buf->tw + 2 * r);
    buf->vp = alloc(NSTAT * buf->vw);
    buf->mean = alloc(NSTAT * buf->cw);
    buf->ring = alloc(job->slots * NCOEF * buf->cw);
    buf->cp = alloc(NCOEF * buf->pw);
    buf->coef = alloc(NCOEF * buf->tw);
    return buf->vp && buf->mean && buf->ring && buf->cp && buf->coef;
}

static void free_buffers(Buffers *buf) {
    free(buf->vp), free(buf->mean), free(buf->ring), free(buf->cp), free(buf->coef);
}

typedef struct {
    const Job *job;
    int64_t y0, y1;
    int status;
} Band;

static void *run_band(void *arg) {
    Band *band = arg;
    const Job *job = band->job;
    Buffers buf;
    if (!make_buffers(job, &buf)) {
        free_buffers(&buf);
        band->status = 1;
        return NULL;
    }
    for (int64_t x0 = 0; x0 < job->w; x0 += TILE) {
        int64_t x1 = x0 + TILE < job->w ? x0 + TILE : job->w;
        int64_t ca = x0 - job->r < 0 ? 0 : x0 - job->r;
        int64_t cb = x1 + job->r > job->w ? job->w : x1 + job->r;
        int64_t next = band->y0 - job->r < 0 ? 0 : band->y0 - job->r;
        for (int64_t y = band->y0; y < band->y1; y++) {
            int64_t last = y + job->r < job->h ? y + job->r : job->h - 1;
            for (; next <= last; next++) coefficient_row(job, &buf, next, ca, cb);
            output_row(job, &buf, y, x0, x1, ca, cb);
        }
    }
    free_buffers(&buf);
    band->status = 0;
    return NULL;
}

/* Returns 0 on success, 1 when a buffer could not be allocated or the sizes are refused. */
int bnerr_guided(const float *albedo, const float *normal, const float *lum, const float *color,
                 float *out, int64_t h, int64_t w, int64_t radius, float eps, float floor,
                 float inv_kk, int threads) {
    if (h <= 0 || w <= 0 || radius < 1 || radius > (int64_t)1 << 20) return 1;
    Job job = {.out = out, .h = h, .w = w, .r = radius, .k = 2 * radius + 1,
               .eps = eps, .floor = floor, .inv_kk = inv_kk};
    job.slots = job.k < h ? job.k : h;
    for (int c = 0; c < 3; c++) {
        job.in[c] = albedo + c * h * w;
        job.in[3 + c] = normal + c * h * w;
        job.in[NG + c] = color + c * h * w;
    }
    job.in[6] = lum;
    init_job(&job);
    if (threads < 1) threads = 1;
    if (threads > MAX_THREADS) threads = MAX_THREADS;
    if (threads > h) threads = (int)h;
    Band bands[MAX_THREADS];
    pthread_t ids[MAX_THREADS];
    int started[MAX_THREADS] = {0};
    for (int t = 0; t < threads; t++)
        bands[t] = (Band){&job, h * t / threads, h * (t + 1) / threads, 1};
    for (int t = 1; t < threads; t++)
        started[t] = pthread_create(&ids[t], NULL, run_band, &bands[t]) == 0;
    run_band(&bands[0]);
    int status = bands[0].status;
    for (int t = 1; t < threads; t++) {
        if (started[t]) pthread_join(ids[t], NULL);
        else run_band(&bands[t]);
        status |= bands[t].status;
    }
    return status;
}
