/* A small path tracer in plain C driven by bnerr's seed protocol (docs/RENDERER_PROTOCOL.md).

   Not bnerr's tracer: its own scene (a sphere on a floor under one rectangular light, like
   bnerr's `direct`), its own camera and its own use of the sampler's dimensions. What it shares
   with bnerr is only what the protocol carries:

   - the per-pixel seeds of the seed file (`--seeds`), each seeding the pixel's Owen-scrambled
     Sobol sequence padded by 2D pairs, ported bit for bit from bnerr.sequences.owen_sobol (the
     same seed means the same sample values as in bnerr's sampler);
   - with `--sampler ldbn`, the LDBN keys of the C header `bnerr export --ldbn screen --format h`
     writes (`--ldbn FILE.h`, read at run time), its slice (`--ldbn-slice`) and the frame's
     toroidal offset (`--ldbn-offset-y`, `--ldbn-offset-x`), looked up as bnerr.sequences.ldbn.

   Each path takes 8 dimensions: (0, 1) the pixel position, (2, 3) a point on the light at the
   first hit, (4, 5) the cosine-weighted bounce direction, (6, 7) a point on the light at the
   second hit: direct lighting plus one bounce, next-event estimation only (a bounce that hits
   the light adds nothing: the light is counted once, through its sample).

   Output: a single-part scanline OpenEXR file, uncompressed, FLOAT channels R G B and the
   first-hit buffers albedo.{R,G,B}, normal.{X,Y,Z}, depth.Z and object_id.Y (of sample 0).
   A seed file with K > 1 images renders K frames into the folder `--out` as 0.exr .. K-1.exr.

   Layout mode (`--layout DIR`, docs/EVAL.md): the a-priori methods need no loop, so the tracer
   also renders a whole frame folder for `bnerr eval` by itself: DIR/manifest.toml, a static
   reference (DIR/reference/0000.exr, `--reference-spp`, seeds no method uses), white's frames of
   the held-out seed set DIR/white/tune/ the denoisers are tuned on, and per seed set s and
   frame t the noisy frames DIR/white/s/tttt.exr (a fresh hashed seed per pixel) and, with
   `--ldbn FILE.h`, DIR/ldbn/s/tttt.exr (the exported keys' slice for `--spp`, at a toroidal
   offset hashed from s and t), each frame's render time in its `bnerr_timings` attribute.

   Build: cc -O2 -o tracer tracer.c -lm.
   Test hook: `--dump-samples FILE` writes the sampler's values float32 [K, H, W, spp, 8] instead
   of rendering, so a test can compare them with bnerr's own sampler. */

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#define DIMS 8
#define SHIPPED_SEED0 18u /* bnerr.ldbn.keys.SHIPPED_SEED0: the shared sequence of the keys */

/* ------------------------------------------------------------------------------------------ */
/* Owen-scrambled Sobol padded by 2D pairs (bnerr.sequences.owen_sobol, samplers.c)           */

static uint32_t lowbias32(uint32_t x) {
    x ^= x >> 16;
    x *= 0x7FEB352Du;
    x ^= x >> 15;
    x *= 0x846CA68Bu;
    return x ^ (x >> 16);
}

static uint32_t rev32(uint32_t x) {
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0F0F0F0Fu) | ((x & 0x0F0F0F0Fu) << 4);
    x = ((x >> 8) & 0x00FF00FFu) | ((x & 0x00FF00FFu) << 8);
    return (x >> 16) | (x << 16);
}

/* Sobol dimension 1 (Pascal matrix) in the reversed domain: the XOR of the columns
   rev32(v_(32-b)) over the set bits b of y, tabled byte by byte. */
static uint32_t sobol1_table[4][256];

static void sobol1_init(void) {
    uint32_t v[32], col[32];
    v[0] = 1u << 31;
    for (int k = 1; k < 32; ++k) v[k] = v[k - 1] ^ (v[k - 1] >> 1);
    for (int b = 0; b < 32; ++b) col[b] = rev32(v[31 - b]);
    for (int q = 0; q < 4; ++q)
        for (int x = 0; x < 256; ++x) {
            uint32_t w = 0;
            for (int b = 0; b < 8; ++b)
                if ((x >> b) & 1) w ^= col[8 * q + b];
            sobol1_table[q][x] = w;
        }
}

static uint32_t sobol1(uint32_t y) {
    return sobol1_table[0][y & 255] ^ sobol1_table[1][(y >> 8) & 255] ^
           sobol1_table[2][(y >> 16) & 255] ^ sobol1_table[3][y >> 24];
}

static uint32_t laine_karras(uint32_t x, uint32_t key) {
    x += key;
    x ^= x * 0x6C50B47Cu;
    x ^= x * 0xB82F1E52u;
    x ^= x * 0xC7AFE638u;
    x ^= x * 0x8D22F6E6u;
    return x;
}

/* The 24-bit words of pair p of the sequence seeded by seed, at sample index. */
static void owen_pair(uint32_t seed, uint32_t index, uint32_t p, uint32_t w[2]) {
    uint32_t seed_hash = lowbias32(seed ^ 0xC2B2AE35u), h[3];
    for (uint32_t role = 0; role < 3; ++role)
        h[role] = lowbias32(seed_hash ^ lowbias32((4u * p + role) ^ 0x27D4EB2Fu));
    uint32_t y = laine_karras(rev32(index), h[2]);
    w[0] = rev32(laine_karras(rev32(y), h[0])) >> 8;
    w[1] = rev32(laine_karras(sobol1(y), h[1])) >> 8;
}

/* ------------------------------------------------------------------------------------------ */
/* LDBN keys from the header of `bnerr export --format h`                                     */

typedef struct {
    uint32_t *data; /* [S][T][T][C]: D scrambling keys, then D / 2 ranking keys */
    long slices, size, channels, dims;
} ldbn_t;

static long header_define(const char *text, const char *suffix) {
    const char *at = text;
    while ((at = strstr(at, "#define ")) != NULL) {
        at += 8;
        const char *end = strchr(at, ' ');
        size_t n = strlen(suffix);
        if (end && (size_t)(end - at) > n && strncmp(end - n, suffix, n) == 0)
            return strtol(end, NULL, 10);
    }
    return -1;
}

static int ldbn_load(const char *path, ldbn_t *k) {
    FILE *f = fopen(path, "rb");
    if (!f) { fprintf(stderr, "tracer: cannot open the LDBN header %s\n", path); return 1; }
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *text = malloc((size_t)n + 1);
    if (!text || fread(text, 1, (size_t)n, f) != (size_t)n) { fclose(f); return 1; }
    fclose(f);
    text[n] = 0;
    k->slices = header_define(text, "_SLICES");
    k->size = header_define(text, "_SIZE");
    k->channels = header_define(text, "_CHANNELS");
    char *at = strchr(text, '{');
    if (k->slices < 1 || k->size < 1 || k->channels < 3 || k->channels % 3 || !at) {
        fprintf(stderr, "tracer: %s: expected a header of bnerr export --ldbn --format h\n", path);
        return 1;
    }
    k->dims = k->channels / 3 * 2;
    long count = k->slices * k->size * k->size * k->channels;
    k->data = malloc(sizeof(uint32_t) * (size_t)count);
    for (long i = 0; i < count; ++i) {
        char *end;
        k->data[i] = (uint32_t)strtoul(at + 1, &end, 10);
        if (end == at + 1) { fprintf(stderr, "tracer: %s: short key array\n", path); return 1; }
        at = end + (*end == 'u'); /* past the 'u' suffix, at the comma */
    }
    free(text);
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* The sampler of one pixel                                                                   */

typedef struct {
    const ldbn_t *ldbn; /* NULL: the pixel's own Owen-Sobol */
    long slice, oy, ox;
} sampler_t;

/* Dimensions 0 .. DIMS - 1 of sample index of the pixel (y, x) with seed. */
static void sample(const sampler_t *s, uint32_t seed, long y, long x, uint32_t index,
                   float out[DIMS]) {
    for (uint32_t p = 0; p < DIMS / 2; ++p) {
        uint32_t w[2];
        if (s->ldbn && (long)p < s->ldbn->dims / 2) {
            const ldbn_t *k = s->ldbn;
            long ty = ((y + s->oy) % k->size + k->size) % k->size;
            long tx = ((x + s->ox) % k->size + k->size) % k->size;
            const uint32_t *texel = k->data + ((s->slice * k->size + ty) * k->size + tx) * k->channels;
            owen_pair(SHIPPED_SEED0, index ^ texel[k->dims + p], p, w);
            w[0] ^= texel[2 * p];
            w[1] ^= texel[2 * p + 1];
        } else {
            owen_pair(seed, index, p, w);
        }
        out[2 * p] = (float)w[0] * 0x1p-24f;
        out[2 * p + 1] = (float)w[1] * 0x1p-24f;
    }
}

/* ------------------------------------------------------------------------------------------ */
/* The scene                                                                                   */

typedef struct { double x, y, z; } vec;
static vec v3(double x, double y, double z) { vec v = {x, y, z}; return v; }
static vec add(vec a, vec b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static vec sub(vec a, vec b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static vec mul(vec a, double s) { return v3(a.x * s, a.y * s, a.z * s); }
static vec prod(vec a, vec b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
static double dot(vec a, vec b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static vec cross(vec a, vec b) {
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static vec norm(vec a) { return mul(a, 1.0 / sqrt(dot(a, a))); }

enum { SPHERE = 0, FLOOR = 1, LIGHT = 2 };
static const vec SPHERE_C = {0.0, 1.0, 0.0};
static const double SPHERE_R = 1.0, FLOOR_HALF = 5.0, LIGHT_HALF = 0.75;
static const vec LIGHT_C = {1.5, 4.0, 1.0};
static const vec LIGHT_LE = {16.0, 15.0, 13.0};
static const vec ALBEDO[3] = {{0.8, 0.35, 0.2}, {0.7, 0.7, 0.7}, {0.8, 0.8, 0.8}};

typedef struct { double t; int id; vec p, n; } hit_t;

/* The nearest hit of the ray o + t d (t in (eps, tmax)); id -1 when none. */
static hit_t intersect(vec o, vec d, double tmax) {
    hit_t h = {tmax, -1, {0, 0, 0}, {0, 0, 0}};
    vec oc = sub(o, SPHERE_C);
    double b = dot(oc, d), c = dot(oc, oc) - SPHERE_R * SPHERE_R, disc = b * b - c;
    if (disc > 0) {
        double r = sqrt(disc), t = -b - r;
        if (t < 1e-6) t = -b + r;
        if (t > 1e-6 && t < h.t) { h.t = t; h.id = SPHERE; }
    }
    if (fabs(d.y) > 1e-12) {
        double t = -o.y / d.y; /* the floor y = 0 */
        vec p = add(o, mul(d, t));
        if (t > 1e-6 && t < h.t && fabs(p.x) <= FLOOR_HALF && fabs(p.z) <= FLOOR_HALF) {
            h.t = t; h.id = FLOOR;
        }
        t = (LIGHT_C.y - o.y) / d.y; /* the light, facing down */
        p = add(o, mul(d, t));
        if (t > 1e-6 && t < h.t && fabs(p.x - LIGHT_C.x) <= LIGHT_HALF &&
            fabs(p.z - LIGHT_C.z) <= LIGHT_HALF) {
            h.t = t; h.id = LIGHT;
        }
    }
    if (h.id >= 0) {
        h.p = add(o, mul(d, h.t));
        h.n = h.id == SPHERE ? norm(sub(h.p, SPHERE_C)) : v3(0, h.id == FLOOR ? 1 : -1, 0);
    }
    return h;
}

/* Next-event estimation at the diffuse point (p, n) of albedo a with the light point u. */
static vec direct(vec p, vec n, vec a, double u0, double u1) {
    vec q = v3(LIGHT_C.x + (2 * u0 - 1) * LIGHT_HALF, LIGHT_C.y, LIGHT_C.z + (2 * u1 - 1) * LIGHT_HALF);
    vec to = sub(q, p);
    double dist2 = dot(to, to), dist = sqrt(dist2);
    vec w = mul(to, 1.0 / dist);
    double cos_p = dot(n, w), cos_l = w.y; /* the light's normal is -y: cos = -(-w.y) */
    if (cos_p <= 0 || cos_l <= 0) return v3(0, 0, 0);
    hit_t block = intersect(add(p, mul(n, 1e-5)), w, dist * (1 - 1e-6));
    if (block.id >= 0 && block.id != LIGHT) return v3(0, 0, 0);
    double area = 4 * LIGHT_HALF * LIGHT_HALF;
    return mul(prod(a, LIGHT_LE), cos_p * cos_l * area / (M_PI * dist2));
}

/* A cosine-weighted direction about n. */
static vec bounce(vec n, double u0, double u1) {
    double r = sqrt(u0), phi = 2 * M_PI * u1;
    vec t = fabs(n.x) > 0.5 ? v3(0, 1, 0) : v3(1, 0, 0);
    vec b1 = norm(cross(t, n)), b2 = cross(n, b1);
    return norm(add(add(mul(b1, r * cos(phi)), mul(b2, r * sin(phi))), mul(n, sqrt(1 - u0))));
}

typedef struct { vec eye, forward, right, up; double scale; } camera_t;

static camera_t camera(long width, long height) {
    camera_t c;
    c.eye = v3(6.0 * sin(20 * M_PI / 180), 3.0, 6.0 * cos(20 * M_PI / 180));
    c.forward = norm(sub(v3(0, 0.8, 0), c.eye));
    c.right = norm(cross(c.forward, v3(0, 1, 0)));
    c.up = cross(c.right, c.forward);
    c.scale = tan(20 * M_PI / 180) / (0.5 * (double)width); /* fov 40 along x */
    (void)height;
    return c;
}

/* One path through pixel (y, x) with the samples u; first-hit buffers into aux when not NULL. */
static vec radiance(const camera_t *c, long y, long x, long w, long h, const float u[DIMS],
                    float *aux) {
    double sx = ((double)x + u[0] - 0.5 * (double)w) * c->scale;
    double sy = (0.5 * (double)h - (double)y - u[1]) * c->scale;
    vec d = norm(add(c->forward, add(mul(c->right, sx), mul(c->up, sy))));
    hit_t hit = intersect(c->eye, d, 1e30);
    if (aux) {
        vec a = hit.id >= 0 ? ALBEDO[hit.id] : v3(0, 0, 0);
        float values[8] = {(float)a.x, (float)a.y, (float)a.z, (float)hit.n.x, (float)hit.n.y,
                           (float)hit.n.z, hit.id >= 0 ? (float)hit.t : 0.0f, (float)hit.id};
        memcpy(aux, values, sizeof values);
    }
    if (hit.id < 0) return v3(0, 0, 0);
    if (hit.id == LIGHT) return LIGHT_LE;
    vec a = ALBEDO[hit.id];
    vec out = direct(hit.p, hit.n, a, u[2], u[3]);
    vec wi = bounce(hit.n, u[4], u[5]);
    hit_t next = intersect(add(hit.p, mul(hit.n, 1e-5)), wi, 1e30);
    if (next.id == SPHERE || next.id == FLOOR)
        out = add(out, prod(a, direct(next.p, next.n, ALBEDO[next.id], u[6], u[7])));
    return out;
}

/* ------------------------------------------------------------------------------------------ */
/* Minimal OpenEXR writer: single part, scanline, NO_COMPRESSION, FLOAT channels               */

static void put_attr(FILE *f, const char *name, const char *type, int size, const void *value) {
    fwrite(name, 1, strlen(name) + 1, f);
    fwrite(type, 1, strlen(type) + 1, f);
    int32_t s = size;
    fwrite(&s, 4, 1, f);
    fwrite(value, 1, (size_t)size, f);
}

/* planes[c] is channel names[c], [h][w] floats; names sorted as strcmp sorts them; timings
   (JSON, or NULL for none) goes into the string attribute bnerr_timings. */
static int write_exr(const char *path, long w, long h, int n, const char *const *names,
                     float *const *planes, const char *timings) {
    FILE *f = fopen(path, "wb");
    if (!f) { fprintf(stderr, "tracer: cannot write %s\n", path); return 1; }
    const uint8_t magic[8] = {0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0};
    fwrite(magic, 1, 8, f);
    char chlist[1024];
    int len = 0;
    for (int c = 0; c < n; ++c) {
        int32_t fields[4] = {2 /* FLOAT */, 0 /* pLinear + reserved */, 1, 1};
        len += (int)strlen(names[c]) + 1;
        memcpy(chlist + len - strlen(names[c]) - 1, names[c], strlen(names[c]) + 1);
        memcpy(chlist + len, fields, 16);
        len += 16;
    }
    chlist[len++] = 0;
    put_attr(f, "channels", "chlist", len, chlist);
    uint8_t none = 0;
    put_attr(f, "compression", "compression", 1, &none);
    int32_t box[4] = {0, 0, (int32_t)w - 1, (int32_t)h - 1};
    put_attr(f, "dataWindow", "box2i", 16, box);
    put_attr(f, "displayWindow", "box2i", 16, box);
    put_attr(f, "lineOrder", "lineOrder", 1, &none);
    float one = 1.0f, center[2] = {0, 0};
    put_attr(f, "pixelAspectRatio", "float", 4, &one);
    put_attr(f, "screenWindowCenter", "v2f", 8, center);
    put_attr(f, "screenWindowWidth", "float", 4, &one);
    if (timings) put_attr(f, "bnerr_timings", "string", (int)strlen(timings), timings);
    fputc(0, f);
    uint64_t offset = (uint64_t)ftell(f) + 8 * (uint64_t)h;
    int32_t block = (int32_t)(4 * w * n);
    for (long y = 0; y < h; ++y, offset += 8 + (uint64_t)block) fwrite(&offset, 8, 1, f);
    for (long y = 0; y < h; ++y) {
        int32_t line = (int32_t)y;
        fwrite(&line, 4, 1, f);
        fwrite(&block, 4, 1, f);
        for (int c = 0; c < n; ++c) fwrite(planes[c] + y * w, 4, (size_t)w, f);
    }
    return fclose(f) != 0;
}

/* ------------------------------------------------------------------------------------------ */
/* The seed file and the frame                                                                 */

typedef struct { uint32_t width, height, count; uint32_t *seeds; } seeds_t;

static int read_seeds(const char *path, seeds_t *s) {
    FILE *f = fopen(path, "rb");
    uint32_t head[6];
    if (!f || fread(head, 4, 6, f) != 6 || memcmp(head, "BNSD", 4) != 0 || head[1] != 1 ||
        head[5] != 1) {
        fprintf(stderr, "tracer: %s: expected a seed file (BNSD, version 1, uint32)\n", path);
        return 1;
    }
    s->width = head[2];
    s->height = head[3];
    s->count = head[4];
    size_t n = (size_t)s->width * s->height * s->count;
    s->seeds = malloc(4 * n);
    int bad = fread(s->seeds, 4, n, f) != n;
    fclose(f);
    if (bad) fprintf(stderr, "tracer: %s: expected %zu seeds, got fewer\n", path, n);
    return bad;
}

static const char *const NAMES[11] = {"B", "G", "R", "albedo.B", "albedo.G", "albedo.R",
                                      "depth.Z", "normal.X", "normal.Y", "normal.Z",
                                      "object_id.Y"};
/* where each of radiance()'s aux values goes among NAMES */
static const int AUX_PLANE[8] = {5, 4, 3, 7, 8, 9, 6, 10};

static double now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return 1e3 * (double)ts.tv_sec + 1e-6 * (double)ts.tv_nsec;
}

/* Image k of s at spp into path; timed: its render time in the bnerr_timings attribute. */
static int render(const seeds_t *s, long k, long spp, const sampler_t *smp, const char *path,
                  int timed) {
    long w = s->width, h = s->height, n = w * h;
    double start = now_ms();
    float *data = calloc((size_t)(11 * n), sizeof(float)), *planes[11], u[DIMS], aux[8];
    for (int c = 0; c < 11; ++c) planes[c] = data + c * n;
    camera_t cam = camera(w, h);
    for (long y = 0; y < h; ++y)
        for (long x = 0; x < w; ++x) {
            uint32_t seed = s->seeds[k * n + y * w + x];
            vec sum = v3(0, 0, 0);
            for (long i = 0; i < spp; ++i) {
                sample(smp, seed, y, x, (uint32_t)i, u);
                sum = add(sum, radiance(&cam, y, x, w, h, u, i == 0 ? aux : NULL));
            }
            long at = y * w + x;
            planes[2][at] = (float)(sum.x / spp);
            planes[1][at] = (float)(sum.y / spp);
            planes[0][at] = (float)(sum.z / spp);
            for (int a = 0; a < 8; ++a) planes[AUX_PLANE[a]][at] = aux[a];
        }
    char timings[64];
    snprintf(timings, sizeof timings, "{\"render\": %.3f}", now_ms() - start);
    int bad = write_exr(path, w, h, 11, NAMES, planes, timed ? timings : NULL);
    free(data);
    return bad;
}

static int dump_samples(const seeds_t *s, long spp, const sampler_t *smp, const char *path) {
    FILE *f = fopen(path, "wb");
    if (!f) return 1;
    float u[DIMS];
    for (long k = 0; k < (long)s->count; ++k)
        for (long y = 0; y < (long)s->height; ++y)
            for (long x = 0; x < (long)s->width; ++x)
                for (long i = 0; i < spp; ++i) {
                    uint32_t seed = s->seeds[(k * s->height + y) * s->width + x];
                    sample(smp, seed, y, x, (uint32_t)i, u);
                    fwrite(u, 4, DIMS, f);
                }
    return fclose(f) != 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Layout mode: a frame folder for `bnerr eval` (docs/EVAL.md)                                 */

typedef struct {
    const char *dir;
    long width, height, spp, seed_sets, frames, reference_spp;
    const ldbn_t *ldbn; /* NULL: white only */
} layout_t;

enum { STREAM_REFERENCE = 1, STREAM_WHITE = 2, STREAM_LDBN = 3 };

/* A hash of (stream, seed set, frame, i): independent 32-bit words per argument tuple. */
static uint32_t hash4(uint32_t stream, uint32_t set, uint32_t frame, uint32_t i) {
    return lowbias32(i ^ lowbias32(frame ^ lowbias32(set ^ lowbias32(stream * 0x9E3779B9u))));
}

/* mkdir DIR/a/b (a, b may be NULL), each level; 0 when it exists afterwards. */
static int make_dirs(const char *dir, const char *a, const char *b) {
    char path[4096];
    const char *parts[3] = {dir, a, b};
    size_t len = 0;
    for (int i = 0; i < 3 && parts[i]; ++i) {
        int n = snprintf(path + len, sizeof path - len, "%s%s", i ? "/" : "", parts[i]);
        if (n < 0 || (size_t)n >= sizeof path - len) return 1;
        len += (size_t)n;
        if (mkdir(path, 0777) != 0 && errno != EEXIST) {
            fprintf(stderr, "tracer: cannot create the folder %s\n", path);
            return 1;
        }
    }
    return 0;
}

static int write_layout_manifest(const layout_t *L) {
    char path[4096];
    snprintf(path, sizeof path, "%s/manifest.toml", L->dir);
    FILE *f = fopen(path, "w");
    if (!f) { fprintf(stderr, "tracer: cannot write %s\n", path); return 1; }
    fprintf(f, "# written by examples/native/tracer --layout (docs/EVAL.md)\n");
    fprintf(f, "scene = \"native\"\nspp = %ld\nresolution = [%ld, %ld]\n", L->spp, L->width,
            L->height);
    fprintf(f, "methods = [\"white\"%s]\nseed_sets = [", L->ldbn ? ", \"ldbn\"" : "");
    for (long s = 0; s < L->seed_sets; ++s) fprintf(f, "%s\"%ld\"", s ? ", " : "", s);
    fprintf(f, "]\nframes = %ld\nstatic = true\nreference_spp = %ld\ndimensions = %d\n", L->frames,
            L->reference_spp, DIMS);
    fprintf(f, "buffers = [\"albedo\", \"normal\", \"depth\", \"object_id\"]\n");
    fprintf(f, "tuning_seed_set = \"tune\"\n");
    return fclose(f) != 0;
}

/* Frame t of seed set s of a method (stream) into DIR/method/folder/tttt.exr. */
static int render_layout_frame(const layout_t *L, const char *method, uint32_t stream, long s,
                               const char *folder, long t, seeds_t *seeds) {
    long n = L->width * L->height;
    for (long i = 0; i < n; ++i) seeds->seeds[i] = hash4(stream, (uint32_t)s, (uint32_t)t, (uint32_t)i);
    sampler_t smp = {NULL, 0, 0, 0};
    if (stream == STREAM_LDBN) {
        long level = 0;
        while ((1L << level) < L->spp) ++level; /* the smallest tile for spp samples */
        smp.ldbn = L->ldbn;
        smp.slice = level;
        smp.oy = hash4(stream, (uint32_t)s, (uint32_t)t, 0xFFFFFFFFu) % (uint32_t)L->ldbn->size;
        smp.ox = hash4(stream, (uint32_t)s, (uint32_t)t, 0xFFFFFFFEu) % (uint32_t)L->ldbn->size;
    }
    char path[4096];
    if (make_dirs(L->dir, method, folder)) return 1;
    snprintf(path, sizeof path, "%s/%s/%s/%04ld.exr", L->dir, method, folder, t);
    return render(seeds, 0, L->spp, &smp, path, 1);
}

static int render_layout(const layout_t *L) {
    long n = L->width * L->height, level = 0;
    while ((1L << level) < L->spp) ++level;
    if (L->ldbn && level >= L->ldbn->slices) {
        fprintf(stderr, "tracer: --spp %ld: the LDBN header has tiles for at most %ld spp\n",
                L->spp, 1L << (L->ldbn->slices - 1));
        return 2;
    }
    seeds_t seeds = {(uint32_t)L->width, (uint32_t)L->height, 1, malloc(4 * (size_t)n)};
    int bad = !seeds.seeds || make_dirs(L->dir, "reference", NULL) || write_layout_manifest(L);
    if (!bad) { /* the reference: its own seeds, reference_spp samples */
        char path[4096];
        sampler_t smp = {NULL, 0, 0, 0};
        for (long i = 0; i < n; ++i) seeds.seeds[i] = hash4(STREAM_REFERENCE, 0, 0, (uint32_t)i);
        snprintf(path, sizeof path, "%s/reference/0000.exr", L->dir);
        bad = render(&seeds, 0, L->reference_spp, &smp, path, 1);
    }
    char name[32];
    for (long t = 0; t < L->frames && !bad; ++t) /* white's held-out tuning seed set */
        bad = render_layout_frame(L, "white", STREAM_WHITE, L->seed_sets, "tune", t, &seeds);
    for (long s = 0; s < L->seed_sets && !bad; ++s)
        for (long t = 0; t < L->frames && !bad; ++t) {
            snprintf(name, sizeof name, "%ld", s);
            bad = render_layout_frame(L, "white", STREAM_WHITE, s, name, t, &seeds);
            if (!bad && L->ldbn)
                bad = render_layout_frame(L, "ldbn", STREAM_LDBN, s, name, t, &seeds);
        }
    free(seeds.seeds);
    return bad;
}

static const char *USAGE =
    "usage: tracer --seeds FILE --spp N --out PATH [--sampler owen_sobol|ldbn] [--ldbn FILE.h\n"
    "              --ldbn-slice S --ldbn-offset-y OY --ldbn-offset-x OX] [--dump-samples FILE]\n"
    "       tracer --layout DIR --width W --height H --spp N --seed-sets S --frames F\n"
    "              --reference-spp R [--ldbn FILE.h]\n";

int main(int argc, char **argv) {
    const char *seeds_path = NULL, *out = NULL, *sampler = "owen_sobol", *header = NULL;
    const char *dump = NULL, *dir = NULL;
    long spp = 0, slice = 0, oy = 0, ox = 0, width = 0, height = 0, sets = 0, frames = 0;
    long reference_spp = 0;
    for (int i = 1; i + 1 < argc; i += 2) {
        const char *key = argv[i], *value = argv[i + 1];
        if (!strcmp(key, "--seeds")) seeds_path = value;
        else if (!strcmp(key, "--spp")) spp = strtol(value, NULL, 10);
        else if (!strcmp(key, "--out")) out = value;
        else if (!strcmp(key, "--sampler")) sampler = value;
        else if (!strcmp(key, "--ldbn")) header = value;
        else if (!strcmp(key, "--ldbn-slice")) slice = strtol(value, NULL, 10);
        else if (!strcmp(key, "--ldbn-offset-y")) oy = strtol(value, NULL, 10);
        else if (!strcmp(key, "--ldbn-offset-x")) ox = strtol(value, NULL, 10);
        else if (!strcmp(key, "--dump-samples")) dump = value;
        else if (!strcmp(key, "--layout")) dir = value;
        else if (!strcmp(key, "--width")) width = strtol(value, NULL, 10);
        else if (!strcmp(key, "--height")) height = strtol(value, NULL, 10);
        else if (!strcmp(key, "--seed-sets")) sets = strtol(value, NULL, 10);
        else if (!strcmp(key, "--frames")) frames = strtol(value, NULL, 10);
        else if (!strcmp(key, "--reference-spp")) reference_spp = strtol(value, NULL, 10);
        else { fprintf(stderr, "tracer: unknown option %s\n%s", key, USAGE); return 2; }
    }
    sobol1_init();
    ldbn_t keys;
    if (dir) {
        if (argc % 2 == 0 || width < 1 || height < 1 || width * height > (1L << 26) || spp < 1 ||
            sets < 1 || frames < 1 || reference_spp < 1) {
            fprintf(stderr, "%s", USAGE);
            return 2;
        }
        if (header && ldbn_load(header, &keys)) return 2;
        layout_t layout = {dir, width, height, spp, sets, frames, reference_spp,
                           header ? &keys : NULL};
        return render_layout(&layout);
    }
    if (argc % 2 == 0 || !seeds_path || spp < 1 || (!out && !dump)) {
        fprintf(stderr, "%s", USAGE);
        return 2;
    }
    seeds_t seeds;
    if (read_seeds(seeds_path, &seeds)) return 1;
    sampler_t smp = {NULL, slice, oy, ox};
    if (!strcmp(sampler, "ldbn")) {
        if (!header || ldbn_load(header, &keys)) {
            fprintf(stderr, "tracer: --sampler ldbn needs --ldbn FILE.h (bnerr export)\n");
            return 2;
        }
        if (slice < 0 || slice >= keys.slices) {
            fprintf(stderr, "tracer: --ldbn-slice %ld: the header has %ld\n", slice, keys.slices);
            return 2;
        }
        smp.ldbn = &keys;
    } else if (strcmp(sampler, "owen_sobol") != 0) {
        fprintf(stderr, "tracer: --sampler %s: expected owen_sobol or ldbn\n", sampler);
        return 2;
    }
    if (dump) return dump_samples(&seeds, spp, &smp, dump);
    if (seeds.count == 1) return render(&seeds, 0, spp, &smp, out, 0);
    char path[4096];
    for (long k = 0; k < (long)seeds.count; ++k) {
        snprintf(path, sizeof path, "%s/%ld.exr", out, k);
        if (render(&seeds, k, spp, &smp, path, 0)) return 1;
    }
    return 0;
}
