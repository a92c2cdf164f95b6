/* bnerr's native CPU kernels of the samplers (bnerr.sequences): white noise (bnerr_white),
   per-pixel Owen-Sobol padded by 2D pairs (bnerr_owen_sobol), Cycles' blue-noise patterns,
   which index it (bnerr_cycles), the LDBN lookup into one shared Owen-Sobol sequence
   (bnerr_ldbn), pbrt-v4's ZSobol with its FastOwen value scramble (bnerr_zsobol), the
   temporal Z-order sampler (bnerr_zsobol_t) and OpenQMC's sobolbn (bnerr_openqmc_sobolbn).

   Built by bnerr.native at first use, like permute.c. Each function writes dimensions
   dim .. dim + count - 1 of n lanes into out, a [count, n] float32 buffer (one row per
   dimension), with the same bits as the torch path of its module: integer-only arithmetic in
   unsigned 32- and 64-bit words (wrapping, as torch's int32 and int64 tensors do), and one
   float rounding at the end (the same as torch's). Every host-side constant (the per-pair hash
   keys and scramble seeds, the digit permutation tables) comes in as an argument, computed by
   the Python caller with the module's own functions. Threads split the lanes; each lane is
   independent, so the result does not depend on the thread count. Return codes: 0 success,
   1 bad sizes. */

#include <stdint.h>
#include <pthread.h>

static inline uint32_t lowbias32(uint32_t x) {
    x ^= x >> 16;
    x *= 0x7FEB352Du;
    x ^= x >> 15;
    x *= 0x846CA68Bu;
    return x ^ (x >> 16);
}

static inline uint32_t rev32(uint32_t x) {
    x = __builtin_bswap32(x);
    x = ((x >> 4) & 0x0F0F0F0Fu) | ((x & 0x0F0F0F0Fu) << 4);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    return ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
}

/* Sobol dimension 1 in the reversed domain (P y of bnerr.sequences.tables): four byte tables of
   the XOR of the columns rev32(v_(32-b)) over the set bits b, v the Pascal direction numbers. */
typedef struct { uint32_t t[4][256]; } sobol1_t;

static void sobol1_init(sobol1_t *s) {
    uint32_t v[32], col[32];
    v[0] = 1u << 31;
    for (int k = 1; k < 32; ++k) v[k] = v[k - 1] ^ (v[k - 1] >> 1);
    for (int b = 0; b < 32; ++b) col[b] = rev32(v[31 - b]);
    for (int q = 0; q < 4; ++q)
        for (int x = 0; x < 256; ++x) {
            uint32_t w = 0;
            for (int b = 0; b < 8; ++b)
                if ((x >> b) & 1) w ^= col[8 * q + b];
            s->t[q][x] = w;
        }
}

static inline uint32_t sobol1(const sobol1_t *s, uint32_t y) {
    return s->t[0][y & 255] ^ s->t[1][(y >> 8) & 255] ^ s->t[2][(y >> 16) & 255] ^
           s->t[3][y >> 24];
}

/* The Laine-Karras permutation (Burley 2020, Listing 2). */
static inline uint32_t laine_karras(uint32_t x, uint32_t key) {
    x += key;
    x ^= x * 0x6C50B47Cu;
    x ^= x * 0xB82F1E52u;
    x ^= x * 0xC7AFE638u;
    x ^= x * 0x8D22F6E6u;
    return x;
}

/* pbrt's MixBits. */
static inline uint64_t mix_bits(uint64_t v) {
    v ^= v >> 31;
    v *= 0x7FB5D329728EA185ull;
    v ^= v >> 27;
    v *= 0x81DADEF4BC2DD44Dull;
    return v ^ (v >> 33);
}

/* The Laine-Karras permutation with pbrt's and OpenQMC's constants (a nested scramble in the
   bit-reversed domain; OpenQMC's laineKarrasPermutation). */
static inline uint32_t lk_permute(uint32_t x, uint32_t s) {
    x ^= x * 0x3D20ADEAu;
    x += s;
    x *= (s >> 16) | 1u;
    x ^= x * 0x05526C56u;
    return x ^ (x * 0x53A22864u);
}

/* pbrt's FastOwen randomizer of the reversed Sobol word x with the 32-bit seed s. */
static inline uint32_t fast_owen(uint32_t x, uint32_t s) { return rev32(lk_permute(x, s)); }

/* pbrt's min(float32(v) * 2^-32, 0x1.fffffep-1). */
static inline float word_to_float(uint32_t v) {
    float f = (float)v * 0x1p-32f;
    return f < 0x1.fffffep-1f ? f : 0x1.fffffep-1f;
}

/* rev32(Sobol_c(a)) for pbrt's dims 0 and 1 (52 stored columns; dim 1's columns 32..51 repeat
   columns 0..19). */
static inline uint32_t reversed_sobol(const sobol1_t *s, uint64_t a, int c) {
    uint32_t low = (uint32_t)a;
    if (c == 0) return low;
    return sobol1(s, rev32(low)) ^ sobol1(s, rev32((uint32_t)(a >> 32) & 0xFFFFFu));
}

/* The LDBN sampler's level: its key tiles, texel-major, the frame's toroidal offset and the
   shared sequence (a table of its first words, and its pair hashes for the indices past it). */
typedef struct {
    const int64_t *pixel;    /* per lane (y, x) */
    const int32_t *scramble; /* [T, T, D] 24-bit scrambling keys */
    const int32_t *rank;     /* [T, T, D / 2] ranking keys */
    const int32_t *table;    /* [span, table_dims] the shared words of indices < span */
    int64_t size, dims, oy, ox, span, table_dims;
    const uint32_t *shared;  /* per pair from dim / 2: the shared sequence's 3 pair hashes */
} ldbn_t;

/* OpenQMC's sobolbn: its 256 x 256 tables (keys, ranks; index y * 256 + x), the reversed Sobol
   columns of components 0 and 1 as byte tables ([2][2][256]: component, low/high byte), the
   lanes' pixels and OpenQMC's frame. */
typedef struct {
    const int64_t *pixel;    /* per lane (y, x) */
    const uint32_t *keys;
    const uint8_t *ranks;
    const uint32_t *sobol;
    uint32_t frame;
} oqmc_t;

typedef struct {
    int kind;                /* 0 owen_sobol, 1 zsobol, 2 zsobol_t, 3 Cycles, 4 LDBN, 5 white,
                                6 OpenQMC sobolbn */
    const int64_t *seed;     /* owen_sobol: per-lane seeds (stride seed_stride) */
    const int64_t *index;    /* sample indices */
    int64_t seed_stride, n, lo, hi, dim, count;
    uint64_t key_mask, t;    /* zsobol(_t): the Morton key's bits; zsobol_t: the frame mod F;
                                Cycles: (seed0, first sequence's seed) and (spp, first) */
    const uint32_t *keys;    /* per pair from dim / 2: owen_sobol 3 hashes, zsobol(_t) 2 seeds;
                                white: per dimension from dim, its hash */
    const uint8_t *perm;     /* zsobol: 24 x 4; zsobol_t: 40320 x 8 */
    int log2spp, n_digits;
    uint64_t epoch;
    const sobol1_t *s1;
    float *out;
    const ldbn_t *ldbn;
    const oqmc_t *oqmc;
} sjob_t;

static inline void put(const sjob_t *j, int64_t d, int64_t i, float v) {
    if (d >= j->dim && d < j->dim + j->count) j->out[(d - j->dim) * j->n + i] = v;
}

/* Cycles' blue-noise indexing of lane i: the sequence's seed and index from the pixel's key.
   PURE: seed0, index + key spp; FIRST: sample 0 is index key of the first sequence, sample i
   index (i - 1) + key (spp - 1) of seed0's (all mod 2^32). */
static inline void cycles_lane(const sjob_t *j, int64_t i, uint32_t *seed, uint32_t *index) {
    uint32_t key = (uint32_t)j->seed[i], at = (uint32_t)j->index[i];
    uint32_t spp = (uint32_t)j->t, first = (uint32_t)(j->t >> 32);
    *seed = (uint32_t)j->key_mask;
    if (!first) {
        *index = at + key * spp;
    } else if (at == 0) {
        *seed = (uint32_t)(j->key_mask >> 32);
        *index = key;
    } else {
        *index = (at - 1) + key * (spp - 1);
    }
}

/* The 24-bit words of one Owen-Sobol pair at the reversed index rindex, from the pair's three
   seeded hashes h[r] = lowbias32(seed_hash ^ key of role r). */
static inline void owen_pair(const sobol1_t *s1, uint32_t rindex, const uint32_t h[3],
                             uint32_t w[2]) {
    uint32_t y = laine_karras(rindex, h[2]);
    w[0] = rev32(laine_karras(rev32(y), h[0])) >> 8;
    w[1] = rev32(laine_karras(sobol1(s1, y), h[1])) >> 8;
}

/* The lane's own Owen-Sobol words of pair p (keys: the pair's three host hashes). */
static inline void owen_seeded_pair(const sjob_t *j, uint32_t seed_hash, uint32_t rindex,
                                    int64_t p, uint32_t w[2]) {
    const uint32_t *k = j->keys + 3 * (p - j->dim / 2);
    uint32_t h[3] = {lowbias32(seed_hash ^ k[0]), lowbias32(seed_hash ^ k[1]),
                     lowbias32(seed_hash ^ k[2])};
    owen_pair(j->s1, rindex, h, w);
}

static inline void put_pair(const sjob_t *j, int64_t p, int64_t i, const uint32_t w[2]) {
    put(j, 2 * p, i, (float)w[0] * 0x1p-24f);
    put(j, 2 * p + 1, i, (float)w[1] * 0x1p-24f);
}

static void owen_sobol_lanes(const sjob_t *j) {
    int64_t p0 = j->dim / 2, p1 = (j->dim + j->count - 1) / 2;
    for (int64_t i = j->lo; i < j->hi; ++i) {
        uint32_t seed = (uint32_t)j->seed[i * j->seed_stride], index = (uint32_t)j->index[i];
        if (j->kind == 3) cycles_lane(j, i, &seed, &index);
        uint32_t seed_hash = lowbias32(seed ^ 0xC2B2AE35u), rindex = rev32(index), w[2];
        for (int64_t p = p0; p <= p1; ++p) {
            owen_seeded_pair(j, seed_hash, rindex, p, w);
            put_pair(j, p, i, w);
        }
    }
}

/* a mod m in [0, m) (m > 0) of the wrapping sum a + b, as torch's int64 remainder gives it. */
static inline int64_t wrap_mod(int64_t a, int64_t b, int64_t m) {
    int64_t r = (int64_t)((uint64_t)a + (uint64_t)b) % m;
    return r < 0 ? r + m : r;
}

/* The shared sequence's words of keyed pair p at index at: from the table when it holds them
   (the renderer's indices are below a few hundred, a table of a few KB), else evaluated. */
static inline void shared_pair(const sjob_t *j, uint32_t at, int64_t p, uint32_t w[2]) {
    const ldbn_t *l = j->ldbn;
    if ((int64_t)at < l->span && 2 * p + 1 < l->table_dims) {
        const int32_t *t = l->table + (int64_t)at * l->table_dims + 2 * p;
        w[0] = (uint32_t)t[0];
        w[1] = (uint32_t)t[1];
    } else {
        owen_pair(j->s1, rev32(at), l->shared + 3 * (p - j->dim / 2), w);
    }
}

/* LDBN: keyed pairs (p < D / 2) read the shared sequence at index ^ rank of the lane's texel
   and XOR its scrambling keys; the pairs past them are the lane's own Owen-Sobol. The shared
   sequence's seed is one for every lane, so its pair hashes come in precomputed. */
static void ldbn_lanes(const sjob_t *j) {
    const ldbn_t *l = j->ldbn;
    int64_t p0 = j->dim / 2, p1 = (j->dim + j->count - 1) / 2, keyed = l->dims / 2;
    for (int64_t i = j->lo; i < j->hi; ++i) {
        int64_t texel = wrap_mod(l->pixel[2 * i], l->oy, l->size) * l->size +
                        wrap_mod(l->pixel[2 * i + 1], l->ox, l->size);
        const int32_t *scramble = l->scramble + texel * l->dims, *rank = l->rank + texel * keyed;
        uint32_t index = (uint32_t)j->index[i], w[2];
        uint32_t seed_hash = lowbias32((uint32_t)j->seed[i] ^ 0xC2B2AE35u), rindex = rev32(index);
        for (int64_t p = p0; p <= p1; ++p) {
            if (p < keyed) {
                shared_pair(j, index ^ (uint32_t)rank[p], p, w);
                w[0] ^= (uint32_t)scramble[2 * p];
                w[1] ^= (uint32_t)scramble[2 * p + 1];
            } else {
                owen_seeded_pair(j, seed_hash, rindex, p, w);
            }
            put_pair(j, p, i, w);
        }
    }
}

/* pbrt's SampleIndex (base-4 digit permutation of the Morton index m at salt), in two parts
   whose bits are disjoint: high != 0 gives the digits at or above bit log2spp (they and their
   prefixes depend only on m >> log2spp, the pixel), high == 0 the digits below and the odd bit. */
static inline uint64_t zsobol_digits(const sjob_t *j, uint64_t m, uint64_t salt, int high) {
    int odd = j->log2spp & 1;
    uint64_t out = 0;
    for (int i = j->n_digits - 1; i >= odd; --i) {
        int shift = 2 * i - odd;
        if ((shift >= j->log2spp) != high) continue;
        uint64_t digit = (m >> shift) & 3;
        uint64_t p = (mix_bits((m >> (shift + 2)) ^ salt) >> 24) % 24;
        out |= (uint64_t)j->perm[p * 4 + digit] << shift;
    }
    if (!high && odd) out |= (m & 1) ^ (mix_bits((m >> 1) ^ salt) & 1);
    return out;
}

/* The temporal sampler's scramble in the same two parts: high != 0 the base-8 digit permutation
   above log2spp, high == 0 the binary nested scramble below it. */
static inline uint64_t zsobol_t_digits(const sjob_t *j, uint64_t m, uint64_t salt, int high) {
    uint64_t out = 0;
    if (high) {
        for (int q = j->n_digits - 1; q >= 0; --q) {
            int shift = j->log2spp + 3 * q;
            uint64_t digit = (m >> shift) & 7;
            uint64_t p = (mix_bits((m >> (shift + 3)) ^ salt) >> 24) % 40320;
            out |= (uint64_t)j->perm[p * 8 + digit] << shift;
        }
        return out;
    }
    for (int b = j->log2spp - 1; b >= 0; --b) {
        uint64_t flip = mix_bits((m >> (b + 1)) ^ salt) & 1;
        out |= (((m >> b) & 1) ^ flip) << b;
    }
    return out;
}

static inline uint64_t digits(const sjob_t *j, uint64_t m, uint64_t salt, int high) {
    return j->kind == 1 ? zsobol_digits(j, m, salt, high) : zsobol_t_digits(j, m, salt, high);
}

static inline uint64_t compact2(uint64_t v) {
    v &= 0x5555555555555555ull;
    v = (v | (v >> 1)) & 0x3333333333333333ull;
    v = (v | (v >> 2)) & 0x0F0F0F0F0F0F0F0Full;
    v = (v | (v >> 4)) & 0x00FF00FF00FF00FFull;
    v = (v | (v >> 8)) & 0x0000FFFF0000FFFFull;
    return (v | (v >> 16)) & 0xFFFFFFFFull;
}

static inline uint64_t spread3(uint64_t v) {
    v &= 0x1FFFFF;
    v = (v | (v << 32)) & 0x1F00000000FFFFull;
    v = (v | (v << 16)) & 0x1F0000FF0000FFull;
    v = (v | (v << 8)) & 0x100F00F00F00F00Full;
    v = (v | (v << 4)) & 0x10C30C30C30C30C3ull;
    return (v | (v << 2)) & 0x1249249249249249ull;
}

/* The unscrambled global index of lane i: ZSobol's (key << log2spp) | index, the temporal
   sampler's (Morton3(x, y, t) << log2spp) | index with (x, y) the key's even and odd bits. */
static inline uint64_t base_index(const sjob_t *j, int64_t i) {
    uint64_t key = (uint64_t)j->seed[i] & j->key_mask, index = (uint64_t)j->index[i];
    if (j->kind == 2)
        key = spread3(compact2(key)) | (spread3(compact2(key >> 1)) << 1) | (spread3(j->t) << 2);
    return (key << j->log2spp) | index;
}

/* The renderer's lanes are pixel-major, so consecutive lanes usually share a pixel: the high
   digits of each pair are kept from the previous lane when its pixel part (m >> log2spp) is the
   same (exact reuse, so the result does not depend on the lane order or the thread split). */
#define MEMO_PAIRS 64

static void zsobol_lanes(const sjob_t *j) {
    int64_t p0 = j->dim / 2, p1 = (j->dim + j->count - 1) / 2;
    int memo = p1 - p0 < MEMO_PAIRS, have = 0;
    uint64_t high[MEMO_PAIRS], previous = 0;
    for (int64_t i = j->lo; i < j->hi; ++i) {
        uint64_t m = base_index(j, i), top = m >> j->log2spp;
        int reuse = memo && have && top == previous;
        for (int64_t p = p0; p <= p1; ++p) {
            uint64_t salt = (uint32_t)(2 * p * 0x55555555ull);
            if (j->kind == 2) salt ^= j->epoch;
            uint64_t h = reuse ? high[p - p0] : digits(j, m, salt, 1);
            if (memo) high[p - p0] = h;
            uint64_t a = h | digits(j, m, salt, 0);
            const uint32_t *s = j->keys + 2 * (p - p0);
            put(j, 2 * p, i, word_to_float(fast_owen(reversed_sobol(j->s1, a, 0), s[0])));
            if (2 * p + 1 < j->dim + j->count)
                put(j, 2 * p + 1, i, word_to_float(fast_owen(reversed_sobol(j->s1, a, 1), s[1])));
        }
        previous = top;
        have = 1;
    }
}

/* White noise, a block of lanes at a time: each lane's (seed, index) hash first, then one
   dimension after the other over the block, a loop over contiguous lanes the compiler
   vectorizes (the torch path's order of passes, in cache). */
static void white_lanes(const sjob_t *j) {
    enum { BLOCK = 512 };
    uint32_t prefix[BLOCK];
    for (int64_t i0 = j->lo; i0 < j->hi; i0 += BLOCK) {
        int64_t m = j->hi - i0 < BLOCK ? j->hi - i0 : BLOCK;
        for (int64_t k = 0; k < m; ++k) {
            uint32_t seed = (uint32_t)j->seed[(i0 + k) * j->seed_stride];
            prefix[k] = lowbias32(lowbias32(seed ^ 0x9E3779B9u) ^ (uint32_t)j->index[i0 + k]);
        }
        for (int64_t d = 0; d < j->count; ++d) {
            uint32_t key = j->keys[d];
            float *row = j->out + d * j->n + i0;
            for (int64_t k = 0; k < m; ++k)
                row[k] = (float)(lowbias32(prefix[k] ^ key) >> 8) * 0x1p-24f;
        }
    }
}

/* OpenQMC's integer steps (bnerr.sequences.openqmc): PCG's LCG step and output permutation (its
   Laine-Karras permutation is lk_permute, pbrt's). */
static inline uint32_t pcg_transition(uint32_t s) { return s * 747796405u + 2891336453u; }

static inline uint32_t pcg_output(uint32_t s) {
    s ^= s >> (4 + (s >> 28));
    s *= 277803737u;
    return s ^ (s >> 22);
}

/* uintToFloat: the low byte loses the top byte's bits, then one rounding to float32. */
static inline float oqmc_float(uint32_t w) { return (float)(w & ~(w >> 24)) * 0x1p-32f; }

/* sobolbn: pair p of a lane is components 0 and 1 of newDomain(p) of Sampler(x, y, frame,
   index): the domain's tile shift picks the key and rank, the 16-bit sample id is shuffled by
   the key, and each component is the reversed Sobol column XOR of its top half, scrambled by
   the key rotated by a byte per component. */
static void oqmc_lanes(const sjob_t *j) {
    const oqmc_t *o = j->oqmc;
    int64_t p0 = j->dim / 2, p1 = (j->dim + j->count - 1) / 2;
    for (int64_t i = j->lo; i < j->hi; ++i) {
        uint64_t y = (uint64_t)o->pixel[2 * i], x = (uint64_t)o->pixel[2 * i + 1];
        uint32_t index = (uint32_t)j->index[i], sample = index & 0xFFFFu;
        uint32_t init = 2891336453u + o->frame + (index >> 16);
        for (int64_t p = p0; p <= p1; ++p) {
            uint32_t shift = pcg_output(pcg_transition(init + (uint32_t)p));
            uint64_t at = ((y + ((shift >> 8) & 0xFFu)) & 0xFFu) * 256 + ((x + shift) & 0xFFu);
            uint32_t key = o->keys[at], rank = o->ranks[at];
            uint32_t top = lk_permute(rev32(sample ^ rank), key) >> 16;
            for (int c = 0; c < 2; ++c) {
                const uint32_t *t = o->sobol + 512 * c;
                uint32_t column = t[top & 0xFFu] ^ t[256 + (top >> 8)];
                uint32_t turned = c ? (key >> 8) | (key << 24) : key;
                put(j, 2 * p + c, i, oqmc_float(fast_owen(column, turned)));
            }
        }
    }
}

static void *run_lanes(void *arg) {
    const sjob_t *j = (const sjob_t *)arg;
    if (j->kind == 0 || j->kind == 3) owen_sobol_lanes(j);
    else if (j->kind == 4) ldbn_lanes(j);
    else if (j->kind == 5) white_lanes(j);
    else if (j->kind == 6) oqmc_lanes(j);
    else zsobol_lanes(j);
    return 0;
}

static int run(sjob_t base, int threads) {
    sobol1_t s1;
    sjob_t jobs[64];
    pthread_t ids[64];
    if (base.n < 0 || base.dim < 0 || base.count < 1 || base.n_digits < 0 || base.n_digits > 31 ||
        base.log2spp < 0 || base.log2spp > 62)
        return 1;
    sobol1_init(&s1);
    base.s1 = &s1;
    if (threads < 1) threads = 1;
    if (threads > 64) threads = 64;
    if (threads > base.n) threads = base.n > 0 ? (int)base.n : 1;
    for (int t = 0; t < threads; ++t) {
        jobs[t] = base;
        jobs[t].lo = base.n * t / threads;
        jobs[t].hi = base.n * (t + 1) / threads;
    }
    int started = 0;
    for (int t = 1; t < threads; ++t) {
        if (pthread_create(&ids[t], 0, run_lanes, &jobs[t]) != 0) break;
        started = t;
    }
    for (int t = started + 1; t < threads; ++t) run_lanes(&jobs[t]);
    run_lanes(&jobs[0]);
    for (int t = 1; t <= started; ++t) pthread_join(ids[t], 0);
    return 0;
}

/* White noise: lowbias32(lowbias32(lowbias32(seed ^ 0x9E3779B9) ^ index) ^ keys[d]) >> 8 scaled
   by 2^-24, keys[d] = lowbias32((dim + d) ^ 0x85EBCA6B) for d < count. seed_stride 0 gives
   every lane seed[0]. */
int bnerr_white(const int64_t *seed, int64_t seed_stride, const int64_t *index, int64_t n,
                int64_t dim, int64_t count, const uint32_t *keys, float *out, int threads) {
    sjob_t j = {5, seed, index, seed_stride, n, 0, n, dim, count, 0, 0, keys, 0, 0, 0, 0, 0,
                out, 0, 0};
    return run(j, threads);
}

/* Owen-Sobol padded by 2D pairs; keys: 3 per pair from dim / 2, lowbias32(4 pair + role ^ salt)
   for roles 0, 1, 2. seed_stride 0 gives every lane seed[0]. */
int bnerr_owen_sobol(const int64_t *seed, int64_t seed_stride, const int64_t *index, int64_t n,
                     int64_t dim, int64_t count, const uint32_t *keys, float *out, int threads) {
    sjob_t j = {0, seed, index, seed_stride, n, 0, n, dim, count, 0, 0, keys, 0, 0, 0, 0, 0,
                out, 0, 0};
    return run(j, threads);
}

/* Cycles' PURE (first 0) and FIRST (first 1) patterns over Owen-Sobol: key and index per lane,
   seeds: the global sequence's and the first sample's (low 32 bits); keys as bnerr_owen_sobol. */
int bnerr_cycles(const int64_t *key, const int64_t *index, int64_t n, int64_t dim, int64_t count,
                 uint32_t spp, int first, uint32_t seed0, uint32_t first_seed,
                 const uint32_t *keys, float *out, int threads) {
    uint64_t seeds = seed0 | ((uint64_t)first_seed << 32), mode = spp | ((uint64_t)!!first << 32);
    sjob_t j = {3, key, index, 1, n, 0, n, dim, count, seeds, mode, keys, 0, 0, 0, 0, 0, out, 0, 0};
    return run(j, threads);
}

/* LDBN (bnerr.sequences.ldbn) at one level: lanes (seed, index, pixel (y, x)); geometry
   (T, D, oy, ox, span, table_dims): the tiles' size and dims (D even), the offset and the
   table's shape; scramble [T, T, D] and rank [T, T, D / 2] the level's tiles; table
   [span, table_dims] the shared words of dims 0 .. table_dims - 1 (span 0: none); shared: 3
   hashes per pair from dim / 2 of the shared sequence's seed, lowbias32(lowbias32(seed0 ^
   0xC2B2AE35) ^ key); keys as bnerr_owen_sobol (for the pairs >= D / 2). */
int bnerr_ldbn(const int64_t *seed, const int64_t *index, const int64_t *pixel, int64_t n,
               int64_t dim, int64_t count, const int64_t *geometry, const int32_t *scramble,
               const int32_t *rank, const int32_t *table, const uint32_t *shared,
               const uint32_t *keys, float *out, int threads) {
    const int64_t *g = geometry;
    if (g[0] < 1 || g[1] < 2 || g[1] % 2 || g[4] < 0 || g[5] < 0 || g[5] > g[1]) return 1;
    ldbn_t l = {pixel, scramble, rank, table, g[0], g[1], g[2], g[3], g[4], g[5], shared};
    sjob_t j = {4, seed, index, 1, n, 0, n, dim, count, 0, 0, keys, 0, 0, 0, 0, 0, out, &l, 0};
    return run(j, threads);
}

/* ZSobol with FastOwen: the Morton index is ((key & key_mask) << log2spp) | index per lane;
   seeds: (low32(H), high32(H)) of H = Hash(2 pair + 2, seed), per pair from dim / 2; perm:
   pbrt's 24 x 4. */
int bnerr_zsobol(const int64_t *key, const int64_t *index, int64_t n, int64_t dim, int64_t count,
                 int log2spp, int n_digits, uint64_t key_mask, const uint32_t *seeds,
                 const uint8_t *perm, float *out, int threads) {
    sjob_t j = {1, key, index, 1, n, 0, n, dim, count, key_mask, 0, seeds, perm, log2spp,
                n_digits, 0, 0, out, 0, 0};
    return run(j, threads);
}

/* The temporal Z-order sampler: the index is (Morton3(x, y, t) << log2spp) | index per lane,
   (x, y) the even and odd bits of key & key_mask; epoch is XORed into every salt; perm: the 8!
   permutations of {0..7} in lexicographic order. */
int bnerr_zsobol_t(const int64_t *key, const int64_t *index, int64_t n, int64_t dim,
                   int64_t count, int log2spp, int n_digits, uint64_t key_mask, uint64_t t,
                   uint64_t epoch, const uint32_t *seeds, const uint8_t *perm, float *out,
                   int threads) {
    sjob_t j = {2, key, index, 1, n, 0, n, dim, count, key_mask, t, seeds, perm, log2spp,
                n_digits, epoch, 0, out, 0, 0};
    return run(j, threads);
}

/* OpenQMC's sobolbn (bnerr.sequences.openqmc) for lanes (index, pixel (y, x)), indices in
   [0, 2^31); tables: keys and ranks [256 * 256], sobol [2][2][256] the byte tables of the
   reversed Sobol columns of components 0 and 1 (low byte, then high byte). */
int bnerr_openqmc_sobolbn(const int64_t *index, const int64_t *pixel, int64_t n, int64_t dim,
                          int64_t count, uint32_t frame, const uint32_t *keys,
                          const uint8_t *ranks, const uint32_t *sobol, float *out,
                          int threads) {
    oqmc_t o = {pixel, keys, ranks, sobol, frame};
    sjob_t j = {6, index, index, 1, n, 0, n, dim, count, 0, 0, 0, 0, 0, 0, 0, 0, out, 0, &o};
    return run(j, threads);
}
