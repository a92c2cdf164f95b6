/* bnerr's native CPU kernels for the seed permutation (docs/METHODS.md, section 4): the block
   sorting pass (bnerr_sort_pass: optional groups and block-grid offset) and the retargeting
   pass (bnerr_retarget).

   Built by bnerr.native at first use with the system C compiler into a shared library loaded
   with ctypes; no Python or torch headers. Every constant (the luminance weights, the block size,
   the tile size) comes in as an argument. Integer-only except the optional luminance, which is
   computed in float32 in torch's operation order; build with -ffp-contract=off so that no fused
   multiply-add changes its rounding. Return codes: 0 success, 1 bad sizes, 2 malformed sort plan,
   3 retarget fields that are not inverse permutations. */

#include <stdint.h>
#include <string.h>
#include <pthread.h>
#if defined(__SSE2__)
#include <immintrin.h>
#endif

/* The vector width of the sorting pass: one block per lane, BNERR_LANES lanes of int32 (16 with
   AVX-512, 8 with AVX2, else 4), chosen at build time so that a vector fits one register; a build
   may force another width with -DBNERR_LANES=4, 8 or 16 (through $CC), which changes the speed
   only, never the result. The retargeting pass's gather likewise uses AVX-512 or AVX2 where the
   build has them (GATHER_V below). A host with AVX-512 builds and tests the AVX2 code with
   CC="cc -mno-avx512f" (that flag wins over -march=native), the scalar code with -mno-avx2. */
#ifndef BNERR_LANES
#if defined(__AVX512F__)
#define BNERR_LANES 16
#elif defined(__AVX2__)
#define BNERR_LANES 8
#else
#define BNERR_LANES 4
#endif
#endif
#if BNERR_LANES != 4 && BNERR_LANES != 8 && BNERR_LANES != 16
#error "BNERR_LANES must be 4, 8 or 16"
#endif
#define NL BNERR_LANES
typedef int32_t vec __attribute__((vector_size(4 * NL)));

/* Ordered 32-bit key of a float's bits: signed comparison of keys orders the floats, with
   -0 == +0, every NaN equal to one canonical NaN above +inf. Branch-free, so that loops of it
   vectorize. No key is INT32_MIN (the smallest is -inf's, 0x807fffff). */
static inline int32_t okey(int32_t b) {
    b = (b & 0x7fffffff) > 0x7f800000 ? 0x7fc00000 : b;
    b = b == (int32_t)0x80000000 ? 0 : b;
    return b ^ ((b >> 31) & 0x7fffffff);
}

typedef struct {
    const float *v0, *v1, *v2;  /* luminance channels, or v0 = values and v1 = NULL */
    float w0, w1, w2;
    const int64_t *seeds;
    const uint8_t *order;       /* [nblocks, B*B]: padded-local position (a*B+b) by mask rank */
    const int64_t *groups;      /* [H, W] group labels, or NULL: one group per block */
    int64_t *out;
    int64_t H, W, oy, ox, by0, by1;
    int err;                    /* set when the plan holds a position outside its block */
} job_t;

static inline int32_t load_bits(const job_t *j, int64_t idx) {
    float f;
    if (j->v1) {
        /* Same order as torch: (w0*r + w1*g) + w2*b, each step rounded to float32. */
        float a = j->w0 * j->v0[idx];
        float b = j->w1 * j->v1[idx];
        float c = j->w2 * j->v2[idx];
        f = (a + b) + c;
    } else {
        f = j->v0[idx];
    }
    int32_t bits;
    memcpy(&bits, &f, 4);
    return bits;
}

/* Grouped ranks of one block: the pixel with the k-th smallest (group, key, position) moves to
   the position with the k-th smallest (group, mask rank). Groups compare by a local id (the index
   of the group's first pixel in the block), so that both composites pack into one int64 and each
   rank is one count of comparisons; any order of the groups gives the same moves, since each
   group's pixels take each other's places only. */
static void block_groups(job_t *j, const int B, const uint8_t *ord, int m, const int64_t *key,
                         const int64_t *grp, const int *pos, const int64_t *src, int64_t y0,
                         int64_t x0) {
    int slot[64], at[64];
    int64_t vk[64], mk[64];
    for (int i = 0; i < 64; ++i) slot[i] = -1;
    for (int r = 0; r < m; ++r) slot[ord[r] & 63] = r;
    for (int i = 0; i < m; ++i) {
        int gid = i;
        for (int k = 0; k < i; ++k)
            if (grp[k] == grp[i]) { gid = k; break; }
        if (slot[pos[i]] < 0) { j->err = 1; return; }
        /* key = okey * 64 + position, okey a signed 32-bit value: 38 bits with its sign. */
        vk[i] = ((int64_t)gid << 40) + key[i] + ((int64_t)1 << 38);
        mk[i] = (int64_t)gid * 64 + slot[pos[i]];
    }
    for (int i = 0; i < m; ++i) {
        int c = 0;
        for (int k = 0; k < m; ++k) c += mk[k] < mk[i];
        at[c] = pos[i];
    }
    for (int i = 0; i < m; ++i) {
        int c = 0;
        for (int k = 0; k < m; ++k) c += vk[k] < vk[i];
        const int p = at[c];
        j->out[(y0 + p / B) * j->W + x0 + p % B] = src[i];
    }
}

/* One block, any size (partial blocks at every border when the grid is offset), with or without
   groups. Block (by, bx) covers rows by*B - oy .. and columns bx*B - ox .., clipped to the image. */
static void block_scalar(job_t *j, const int B, int64_t by, int64_t bx, int64_t nbx) {
    const int n = B * B;
    const int64_t y0 = by * B - j->oy, x0 = bx * B - j->ox;
    const int a0 = y0 < 0 ? (int)-y0 : 0, b0 = x0 < 0 ? (int)-x0 : 0;
    const int a1 = (int)(j->H - y0 < B ? j->H - y0 : B);
    const int b1 = (int)(j->W - x0 < B ? j->W - x0 : B);
    int64_t key[64], grp[64], src[64];
    int pos[64];
    int m = 0;
    for (int a = a0; a < a1; ++a)
        for (int b = b0; b < b1; ++b) {
            const int64_t idx = (y0 + a) * j->W + x0 + b;
            key[m] = (int64_t)okey(load_bits(j, idx)) * 64 + (a * B + b);
            grp[m] = j->groups ? j->groups[idx] : 0;
            src[m] = j->seeds[idx];
            pos[m] = a * B + b;
            ++m;
        }
    const uint8_t *ord = j->order + (by * nbx + bx) * n;
    for (int r = 0; r < m; ++r) {
        const int p = ord[r];
        if (p >= n || p / B < a0 || p / B >= a1 || p % B < b0 || p % B >= b1) { j->err = 1; return; }
    }
    if (j->groups) { block_groups(j, B, ord, m, key, grp, pos, src, y0, x0); return; }
    for (int i = 0; i < m; ++i) {
        int r = 0;
        for (int k = 0; k < m; ++k) r += key[k] < key[i];
        const int p = ord[r];
        j->out[(y0 + p / B) * j->W + x0 + p % B] = src[i];
    }
}

/* The keys of the m pixels idx .. idx + m - 1 of one row, elementwise (the loop vectorizes). */
static inline __attribute__((always_inline))
void key_run(const job_t *j, int64_t idx, int m, int32_t *restrict dst) {
    if (j->v1) {
        const float *r = j->v0 + idx, *g = j->v1 + idx, *b = j->v2 + idx;
        const float w0 = j->w0, w1 = j->w1, w2 = j->w2;
        for (int i = 0; i < m; ++i) {
            const float a = w0 * r[i], c = w1 * g[i], e = w2 * b[i];
            const float f = (a + c) + e;
            int32_t bits;
            memcpy(&bits, &f, 4);
            dst[i] = okey(bits);
        }
    } else {
        const float *v = j->v0 + idx;
        for (int i = 0; i < m; ++i) {
            int32_t bits;
            memcpy(&bits, v + i, 4);
            dst[i] = okey(bits);
        }
    }
}

/* In-lane 4 x 4 transposes of 32-bit elements (each 128-bit quarter on its own, as unpcklps /
   unpcklpd do), where the compiler has __builtin_shufflevector; else a scalar transpose. */
#if defined(__has_builtin)
#if __has_builtin(__builtin_shufflevector) && !defined(BNERR_NO_SHUFFLE)
#define BNERR_SHUFFLE 1
#endif
#endif
#ifdef BNERR_SHUFFLE
#define SV __builtin_shufflevector
#if NL == 4
#define LO32(a, b) SV(a, b, 0, 4, 1, 5)
#define HI32(a, b) SV(a, b, 2, 6, 3, 7)
#define LO64(a, b) SV(a, b, 0, 1, 4, 5)
#define HI64(a, b) SV(a, b, 2, 3, 6, 7)
#elif NL == 8
#define LO32(a, b) SV(a, b, 0, 8, 1, 9, 4, 12, 5, 13)
#define HI32(a, b) SV(a, b, 2, 10, 3, 11, 6, 14, 7, 15)
#define LO64(a, b) SV(a, b, 0, 1, 8, 9, 4, 5, 12, 13)
#define HI64(a, b) SV(a, b, 2, 3, 10, 11, 6, 7, 14, 15)
#else
#define LO32(a, b) SV(a, b, 0, 16, 1, 17, 4, 20, 5, 21, 8, 24, 9, 25, 12, 28, 13, 29)
#define HI32(a, b) SV(a, b, 2, 18, 3, 19, 6, 22, 7, 23, 10, 26, 11, 27, 14, 30, 15, 31)
#define LO64(a, b) SV(a, b, 0, 1, 16, 17, 4, 5, 20, 21, 8, 9, 24, 25, 12, 13, 28, 29)
#define HI64(a, b) SV(a, b, 2, 3, 18, 19, 6, 7, 22, 23, 10, 11, 26, 27, 14, 15, 30, 31)
#endif
#endif

/* keys[a][l*B + b] (row a of NL blocks side by side) to k[a*B + b], one block per lane. Returns
   the lane of each block: with B = 4 the in-lane transposes leave block (l % 4) * NL/4 + l / 4
   in lane l; otherwise block l is in lane l. */
static inline __attribute__((always_inline))
void to_lanes(const int B, int32_t keys[][8 * NL], vec *k, int *lane_of) {
#ifdef BNERR_SHUFFLE
    if (B == 4) {
        for (int a = 0; a < 4; ++a) {
            vec r[4];
            memcpy(r, keys[a], sizeof r);
            const vec t0 = LO32(r[0], r[1]), t1 = HI32(r[0], r[1]);
            const vec t2 = LO32(r[2], r[3]), t3 = HI32(r[2], r[3]);
            k[a * 4 + 0] = LO64(t0, t2);
            k[a * 4 + 1] = HI64(t0, t2);
            k[a * 4 + 2] = LO64(t1, t3);
            k[a * 4 + 3] = HI64(t1, t3);
        }
        for (int bl = 0; bl < NL; ++bl) lane_of[bl] = (bl % (NL / 4)) * 4 + bl / (NL / 4);
        return;
    }
#endif
    for (int a = 0; a < B; ++a)
        for (int b = 0; b < B; ++b) {
            int32_t t[NL] __attribute__((aligned(4 * NL)));
            for (int l = 0; l < NL; ++l) t[l] = keys[a][l * B + b];
            memcpy(&k[a * B + b], t, sizeof t);
        }
    for (int bl = 0; bl < NL; ++bl) lane_of[bl] = bl;
}

/* rank[i][l] = #{q: k_q < k_i} + #{q < i: k_q == k_i} in each lane: stable by position. Each
   rank on its own (one accumulator live, the keys in registers): for q < i, [k_q <= k_i] =
   1 + (k_q > k_i) as -1 or 0 (the 1s summed up front as i); for q > i, [k_q < k_i] = -(k_i > k_q). */
static inline __attribute__((always_inline))
void ranks(const int n, const vec *k, int32_t rank[][NL]) {
#pragma GCC unroll 64
    for (int i = 0; i < n; ++i) {
        vec c = (vec){0} + i;
#pragma GCC unroll 64
        for (int q = 0; q < i; ++q) c += k[q] > k[i];
#pragma GCC unroll 64
        for (int q = i + 1; q < n; ++q) c -= k[i] > k[q];
        memcpy(rank[i], &c, sizeof c);
    }
}

/* dst[0 .. m-1] = src[0 .. m-1], with non-temporal (streaming) stores where dst is aligned for
   them: the output is written once and not read again here, so it need not be read into the
   cache first. The caller issues the store fence (rows_done). */
static inline __attribute__((always_inline))
void put_row(int64_t *restrict dst, const int64_t *restrict src, int m) {
#if defined(__AVX512F__)
    if (((uintptr_t)dst & 63) == 0 && m % 8 == 0) {
        for (int i = 0; i < m; i += 8) _mm512_stream_si512((void *)(dst + i), _mm512_loadu_si512(src + i));
        return;
    }
#elif defined(__AVX__)
    if (((uintptr_t)dst & 31) == 0 && m % 4 == 0) {
        for (int i = 0; i < m; i += 4)
            _mm256_stream_si256((__m256i *)(dst + i), _mm256_loadu_si256((const __m256i *)(src + i)));
        return;
    }
#elif defined(__SSE2__)
    if (((uintptr_t)dst & 15) == 0 && m % 2 == 0) {
        for (int i = 0; i < m; i += 2)
            _mm_stream_si128((__m128i *)(dst + i), _mm_loadu_si128((const __m128i *)(src + i)));
        return;
    }
#endif
    memcpy(dst, src, (size_t)m * 8);
}

static inline void rows_done(void) {
#if defined(__SSE2__)
    _mm_sfence();
#endif
}

/* The ranks of the keys of one step: `count` full blocks side by side from pixel (y0, xs), one
   block per lane (lane_of[block]); the lanes of missing blocks get zero keys. */
static inline __attribute__((always_inline))
void step_ranks(const job_t *j, const int B, int64_t y0, int64_t xs, int count,
                int32_t rank[][NL], int *lane_of) {
    int32_t keys[8][8 * NL] __attribute__((aligned(64)));
    for (int a = 0; a < B; ++a) {
        key_run(j, (y0 + a) * j->W + xs, count * B, keys[a]);
        for (int i = count * B; i < NL * B; ++i) keys[a][i] = 0;
    }
    vec k[64];
    to_lanes(B, keys, k, lane_of);
    ranks(B * B, k, rank);
}

/* Write a staged step (B rows of count * B seeds, NL * B apart) row by row into out. */
static inline __attribute__((always_inline))
void flush(job_t *j, const int B, const int64_t *staged, int64_t y0, int64_t xs, int count) {
    for (int a = 0; a < B; ++a) put_row(j->out + (y0 + a) * j->W + xs, staged + a * NL * B, count * B);
}

/* Where each position of a step's plan lies in the staged rows: at[bl * n + k] = row * NL * B +
   bl * B + column of the k-th position in mask order of the step's block bl (below NL * n, so
   uint16). Returns the largest position of the plan (>= n: malformed, at then unused). */
static inline __attribute__((always_inline))
int stage_slots(const int B, const uint8_t *ord, int count, uint16_t *at) {
    const int n = B * B;
    uint8_t worst = 0;
    /* One flat loop over narrow integers, so that it vectorizes (B is a constant: / and % are
       multiplies and shifts). */
    for (int i = 0; i < count * n; ++i) {
        const uint16_t p = ord[i];
        worst = ord[i] > worst ? ord[i] : worst;
        at[i] = (uint16_t)((p / B) * (NL * B) + (uint16_t)(i / n) * B + p % B);
    }
    return worst;
}

/* Full blocks bx in [bx_first, bx_last) of one block row, NL blocks per step, one block per SIMD
   lane. Each step's moved seeds are scattered straight into their places in the step's B output
   rows, staged in one of two buffers, and written out during the next step, so that the staging
   stores have left the store queue before the row loads read them. B is a compile-time constant
   after inlining, so the loops below unroll. */
static inline __attribute__((always_inline))
void row_vector(job_t *j, const int B, int64_t by, int64_t bx_first, int64_t bx_last, int64_t nbx) {
    const int n = B * B;
    const int64_t y0 = by * B - j->oy, W = j->W;
    int64_t staged[2][64 * NL] __attribute__((aligned(64)));
    int64_t last_xs = 0;
    int last_count = 0, step = 0;
    for (int64_t bx0 = bx_first; bx0 < bx_last; bx0 += NL, step ^= 1) {
        const int count = bx_last - bx0 < NL ? (int)(bx_last - bx0) : NL;
        const int64_t xs = bx0 * B - j->ox;
        uint16_t at[64 * NL];
        if (stage_slots(B, j->order + (by * nbx + bx0) * n, count, at) >= n) { j->err = 1; return; }
        int32_t rank[64][NL] __attribute__((aligned(64)));
        int lane_of[NL];
        step_ranks(j, B, y0, xs, count, rank, lane_of);
        for (int bl = 0; bl < count; ++bl) {
            const int l = lane_of[bl];
            const uint16_t *slot = at + bl * n;
            const int64_t *src = j->seeds + y0 * W + xs + bl * B;
            int64_t *to = staged[step];
            /* Pixel (a, b) of rank k moves to the k-th position in mask order: read in pixel
               order (B seeds at a time from each row), scattered into the staged rows. */
            for (int a = 0; a < B; ++a)
                for (int b = 0; b < B; ++b) to[slot[rank[a * B + b][l]]] = src[a * W + b];
        }
        if (last_count) flush(j, B, staged[step ^ 1], y0, last_xs, last_count);
        last_xs = xs;
        last_count = count;
    }
    if (last_count) flush(j, B, staged[step ^ 1], y0, last_xs, last_count);
}

static inline __attribute__((always_inline)) void rows(job_t *j, const int B) {
    const int64_t nbx = (j->W + j->ox + B - 1) / B;
    const int64_t bx_first = j->ox > 0, bx_last = (j->W + j->ox) / B;
    for (int64_t by = j->by0; by < j->by1; ++by) {
        const int64_t y0 = by * B - j->oy;
        const int full = !j->groups && y0 >= 0 && y0 + B <= j->H && bx_last > bx_first;
        if (!full) {
            for (int64_t bx = 0; bx < nbx; ++bx) block_scalar(j, B, by, bx, nbx);
            continue;
        }
        row_vector(j, B, by, bx_first, bx_last, nbx);
        /* The partial blocks at the left and right ends, if any. */
        for (int64_t bx = 0; bx < bx_first; ++bx) block_scalar(j, B, by, bx, nbx);
        for (int64_t bx = bx_last; bx < nbx; ++bx) block_scalar(j, B, by, bx, nbx);
    }
    rows_done();
}

static void rows2(job_t *j) { rows(j, 2); }
static void rows3(job_t *j) { rows(j, 3); }
static void rows4(job_t *j) { rows(j, 4); }
static void rows5(job_t *j) { rows(j, 5); }
static void rows6(job_t *j) { rows(j, 6); }
static void rows7(job_t *j) { rows(j, 7); }
static void rows8(job_t *j) { rows(j, 8); }

typedef struct { job_t job; int B; } task_t;

static void *run_task(void *arg) {
    task_t *t = (task_t *)arg;
    switch (t->B) {
        case 2: rows2(&t->job); break;
        case 3: rows3(&t->job); break;
        case 4: rows4(&t->job); break;
        case 5: rows5(&t->job); break;
        case 6: rows6(&t->job); break;
        case 7: rows7(&t->job); break;
        default: rows8(&t->job); break;
    }
    return 0;
}

/* Run fn on tasks[0 .. n-1] (stride bytes apart), tasks 1.. on new threads, task 0 on this one;
   a task whose thread cannot be created runs here. */
static void run_parallel(void *(*fn)(void *), char *tasks, size_t stride, int n) {
    pthread_t ids[64];
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
    if (threads > 64) threads = 64;
    if (threads > rows) threads = (int)rows;
    return threads;
}

/* Returns 0 on success, 2 if the plan was malformed (nothing written out of bounds), 1 on bad
   sizes. The block grid starts at (-oy, -ox): block (by, bx) covers rows by*B - oy .. and columns
   bx*B - ox ..; groups (NULL: none) restrict each block's sort to pixels with equal labels.
   Threads split the block rows; blocks are independent, so the result does not depend on the
   thread count. */
int bnerr_sort_pass(const float *v0, const float *v1, const float *v2, float w0, float w1, float w2,
                    const int64_t *seeds, const uint8_t *order, const int64_t *groups, int64_t *out,
                    int64_t H, int64_t W, int B, int64_t oy, int64_t ox, int threads) {
    if (B < 2 || B > 8 || H < 1 || W < 1 || oy < 0 || oy >= B || ox < 0 || ox >= B) return 1;
    const int64_t nby = (H + oy + B - 1) / B;
    threads = clamp_threads(threads, nby);
    task_t tasks[64];
    for (int i = 0; i < threads; ++i) {
        job_t jb = {v0, v1, v2, w0, w1, w2, seeds, order, groups, out, H, W, oy, ox,
                    nby * i / threads, nby * (i + 1) / threads, 0};
        tasks[i].job = jb;
        tasks[i].B = B;
    }
    run_parallel(run_task, (char *)tasks, sizeof(task_t), threads);
    for (int i = 0; i < threads; ++i)
        if (tasks[i].job.err) return 2;
    return 0;
}

/* The retargeting pass. Interior (parallel over rows): out[p] = seeds[p + d(q)],
   q = ((y + oy) mod T, (x + ox) mod T), for every target whose source is on screen. Border
   (one thread, only the band of width `reach` along the border, while the other threads start on
   the rows): the targets whose source is off screen take the sources that no target claims, both
   in row-major order. A source s is claimed iff its preimage s + e(u), u = tile coordinate of s,
   e = the inverse field, is on screen. The two parts write disjoint targets. */
typedef struct {
    const int64_t *seeds;
    const int32_t *d;           /* [2, T, T]: dy then dx */
    int64_t *out;
    int64_t H, W, T, oy, ox, reach;
    int64_t *next_row;          /* shared by the threads: the first row none has taken yet */
    const int32_t *inv;         /* the inverse field if this thread pairs the border, else NULL */
    int err;                    /* pair_border's return code */
} rjob_t;

/* Row y, columns x0 .. x1 - 1, each source checked against the screen. */
static void gather_checked(const rjob_t *j, int64_t y, int64_t x0, int64_t x1) {
    const int64_t H = j->H, W = j->W, T = j->T;
    const int64_t qy = (y + j->oy) % T;
    const int32_t *dy = j->d + qy * T, *dx = j->d + T * T + qy * T;
    int64_t qx = (x0 + j->ox) % T;
    for (int64_t x = x0; x < x1; ++x) {
        const int64_t sy = y + dy[qx], sx = x + dx[qx];
        if (sy >= 0 && sy < H && sx >= 0 && sx < W) j->out[y * W + x] = j->seeds[sy * W + sx];
        if (++qx == T) qx = 0;
    }
}

/* Longest tile side whose row of flat offsets fits the stack; larger tiles take the checked loop
   everywhere. */
#define RETARGET_MAX_T 512

/* The vector width of the interior gather, in int64 seeds: 8 with AVX-512, 4 with AVX2, else 1
   (scalar). GATHER_PAD: the entries the extended offset table holds past its period. */
#if defined(__AVX512F__)
#define GATHER_V 8
#elif defined(__AVX2__)
#define GATHER_V 4
#else
#define GATHER_V 1
#endif
#define GATHER_PAD 8

/* The interior of one row: o[x] = s[x + ext[(x + ox) mod T]] for x in [x0, x1), where ext[t] is
   the flat offset dy * W + dx of tile column t mod T, for t in [0, T + GATHER_PAD) (the extension
   lets a vector read GATHER_V consecutive offsets from any t < T without wrapping). The loop walks
   t alongside x and wraps it once per vector, not once per pixel. Vector stores are non-temporal
   (the output is not read again here; rows_done fences them), aligned by a scalar head; `next`
   is prefetched one cache line per vector (see retarget_row). */
static inline void gather_row(const int64_t *restrict s, int64_t *restrict o, const int64_t *ext,
                              int64_t T, int64_t t, int64_t x0, int64_t x1, const int64_t *next) {
    int64_t x = x0;
#if GATHER_V > 1
    for (; x < x1 && ((uintptr_t)(o + x) & (8 * GATHER_V - 1)); ++x) {
        o[x] = s[x + ext[t]];
        if (++t == T) t = 0;
    }
#if GATHER_V == 8
    const __m512i iota = _mm512_set_epi64(7, 6, 5, 4, 3, 2, 1, 0);
    for (; x + 8 <= x1; x += 8) {
        __builtin_prefetch(next + x + 64);
        const __m512i idx = _mm512_add_epi64(_mm512_loadu_si512(ext + t), iota);
        _mm512_stream_si512((void *)(o + x), _mm512_i64gather_epi64(idx, s + x, 8));
        t += 8;
        while (t >= T) t -= T;  /* once at most when T >= 8 */
    }
#else
    const __m256i iota = _mm256_set_epi64x(3, 2, 1, 0);
    for (; x + 4 <= x1; x += 4) {
        if ((x & 7) == 0) __builtin_prefetch(next + x + 64);
        const __m256i idx = _mm256_add_epi64(_mm256_loadu_si256((const __m256i *)(ext + t)), iota);
        const __m256i v = _mm256_i64gather_epi64((const long long *)(s + x), idx, 8);
        _mm256_stream_si256((__m256i *)(o + x), v);
        t += 4;
        while (t >= T) t -= T;  /* once at most when T >= 4 */
    }
#endif
#endif
    for (; x < x1; ++x) {
        if ((x & 7) == 0) __builtin_prefetch(next + x + 64);
        o[x] = s[x + ext[t]];
        if (++t == T) t = 0;
    }
}

/* Row y. Away from the border (reach pixels: no displacement is longer), every source is on
   screen, so the interior of a row is a plain gather through the flat offsets dy * W + dx of its
   tile row (gather_row; ext: room for RETARGET_MAX_T + GATHER_PAD of them). */
static void retarget_row(const rjob_t *j, int64_t y, int64_t *ext) {
    const int64_t H = j->H, W = j->W, T = j->T, r = j->reach;
    if (y < r || y >= H - r || W <= 2 * r || T > RETARGET_MAX_T) {
        gather_checked(j, y, 0, W);
        return;
    }
    const int64_t qy = (y + j->oy) % T;
    const int32_t *dy = j->d + qy * T, *dx = j->d + T * T + qy * T;
    for (int64_t t = 0; t < T; ++t) ext[t] = dy[t] * W + dx[t];
    for (int64_t t = T; t < T + GATHER_PAD; ++t) ext[t] = ext[t - T];
    gather_checked(j, y, 0, r);
    /* The row that first comes into reach at the next row: its lines are read sparsely at first
       (by the pixels displaced the most), which hardware prefetchers miss. */
    const int64_t *next = y + r + 1 < H ? j->seeds + (y + r + 1) * W : j->seeds + y * W;
    gather_row(j->seeds + y * W, j->out + y * W, ext, T, (r + j->ox) % T, r, W - r, next);
    gather_checked(j, y, W - r, W);
}

/* A row-major walk over the border band of width r (the pixels within r of the border: whole
   rows in the top and bottom r rows, else the first and last r columns), listing each pixel whose
   partner through the field f is off screen: with f = d, the targets whose source is off screen;
   with f = the inverse field, the sources that no target claims. */
typedef struct {
    const int32_t *f;           /* [2, T, T]: dy then dx */
    int64_t H, W, T, oy, ox, r;
    int64_t y, x;               /* the next pixel to examine; y == H when the band is done */
} walk_t;

/* Most pixels one walk_fill examines (so it appends at most as many). */
#define WALK_STEP 256

/* Examine the next at most WALK_STEP pixels of the walk (one row piece or a part of one) and
   append the flat positions of its stops to buf; returns how many. Branch-free inside the piece:
   about a quarter of the band's pixels are stops, in no pattern a branch predictor could learn. */
static int walk_fill(walk_t *w, int64_t *buf) {
    const int64_t H = w->H, W = w->W, T = w->T, r = w->r, y = w->y;
    if (y >= H) return 0;
    const int whole = y < r || y >= H - r || W - r <= r;
    if (!whole && w->x >= r && w->x < W - r) w->x = W - r;
    int64_t end = whole || w->x >= W - r ? W : r;
    if (end > w->x + WALK_STEP) end = w->x + WALK_STEP;
    const int64_t qy = (y + w->oy) % T;
    const int32_t *fy = w->f + qy * T, *fx = w->f + T * T + qy * T;
    int64_t q = (w->x + w->ox) % T;
    int n = 0;
    for (int64_t x = w->x; x < end; ++x) {
        const int64_t sy = y + fy[q], sx = x + fx[q];
        if (++q == T) q = 0;
        buf[n] = y * W + x;
        n += ((uint64_t)sy >= (uint64_t)H) | ((uint64_t)sx >= (uint64_t)W);  /* off screen */
    }
    w->x = end;
    if (end == W) {
        ++w->y;
        w->x = 0;
    }
    return n;
}

/* The border pairs: the k-th target whose source is off screen takes the k-th source that no
   target claims (both row-major). The two walks run in chunks, through two small queues on the
   stack: lost targets (fewer than 2 * WALK_STEP at a time) and unclaimed sources not yet paired
   (fewer than 3 * WALK_STEP). Returns 3 if the sources run out first (not inverse fields). */
static int pair_border(const rjob_t *j, const int32_t *inv) {
    walk_t lost = {j->d, j->H, j->W, j->T, j->oy, j->ox, j->reach, 0, 0};
    walk_t unclaimed = {inv, j->H, j->W, j->T, j->oy, j->ox, j->reach, 0, 0};
    int64_t targets[2 * WALK_STEP], sources[3 * WALK_STEP];
    int nt = 0, ns = 0;
    while (lost.y < j->H) {
        while (nt < WALK_STEP && lost.y < j->H) nt += walk_fill(&lost, targets + nt);
        while (ns < nt && unclaimed.y < j->H) ns += walk_fill(&unclaimed, sources + ns);
        if (ns < nt) return 3;
        for (int i = 0; i < nt; ++i) j->out[targets[i]] = j->seeds[sources[i]];
        memmove(sources, sources + nt, (size_t)(ns - nt) * sizeof *sources);
        ns -= nt;
        nt = 0;
    }
    return 0;
}

/* Rows a thread takes at a time: enough that the rows a chunk reads beyond its own (reach above
   and below) stay a small part, few enough that the thread that pairs the border catches up. */
#define RETARGET_CHUNK 64

/* One thread: the border pairs first if it is the one that pairs them, then chunks of rows taken
   from the shared counter until none is left (so that the thread that paired the border takes
   fewer rows; the result does not depend on who takes which). */
static void *retarget_task(void *arg) {
    rjob_t *j = (rjob_t *)arg;
    int64_t ext[RETARGET_MAX_T + GATHER_PAD];
    if (j->inv) j->err = pair_border(j, j->inv);
    for (;;) {
        const int64_t y0 = __atomic_fetch_add(j->next_row, RETARGET_CHUNK, __ATOMIC_RELAXED);
        if (y0 >= j->H) break;
        const int64_t y1 = y0 + RETARGET_CHUNK < j->H ? y0 + RETARGET_CHUNK : j->H;
        for (int64_t y = y0; y < y1; ++y) retarget_row(j, y, ext);
    }
    rows_done();
    return 0;
}

/* Returns 0 on success, 1 on bad sizes, 3 if the fields are not inverse permutations. */
int bnerr_retarget(const int64_t *seeds, const int32_t *d, const int32_t *inv, int64_t *out,
                   int64_t H, int64_t W, int64_t T, int64_t oy, int64_t ox, int64_t reach,
                   int threads) {
    if (H < 1 || W < 1 || T < 1 || oy < 0 || oy >= T || ox < 0 || ox >= T || reach < 0) return 1;
    threads = clamp_threads(threads, H);
    int64_t next_row = 0;
    rjob_t jobs[64];
    for (int i = 0; i < threads; ++i) {
        /* The caller's thread (task 0, started last) pairs the border. */
        const int32_t *border = i == 0 && reach > 0 ? inv : NULL;
        rjob_t jb = {seeds, d, out, H, W, T, oy, ox, reach, &next_row, border, 0};
        jobs[i] = jb;
    }
    run_parallel(retarget_task, (char *)jobs, sizeof(rjob_t), threads);
    return jobs[0].err;
}
