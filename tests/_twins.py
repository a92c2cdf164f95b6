"""Slow, obviously correct twins shared by several test modules (not a test module itself)."""

M32 = (1 << 32) - 1


def lowbias32(x: int) -> int:
    """Wellons' lowbias32 on a Python int's low 32 bits, written from its published listing."""
    x &= M32
    x ^= x >> 16
    x = (x * 0x7FEB352D) & M32
    x ^= x >> 15
    x = (x * 0x846CA68B) & M32
    return x ^ (x >> 16)


M64 = (1 << 64) - 1


def mix_bits(v: int) -> int:
    """pbrt-v4's ``MixBits`` on a 64-bit word."""
    v ^= v >> 31
    v = (v * 0x7FB5D329728EA185) & M64
    v ^= v >> 27
    v = (v * 0x81DADEF4BC2DD44D) & M64
    return v ^ (v >> 33)


def pbrt_hash(e: int, seed: int) -> int:
    """pbrt-v4's ``Hash(e, seed)`` of two 32-bit words: MurmurHash64A over their 8 bytes."""
    m = 0xC6A4A7935BD1E995
    k = ((seed & M32) << 32) | (e & M32)
    k = (k * m) & M64
    k ^= k >> 47
    k = (k * m) & M64
    h = (0 ^ (8 * m)) & M64
    h = ((h ^ k) * m) & M64
    h ^= h >> 47
    h = (h * m) & M64
    return h ^ (h >> 47)
