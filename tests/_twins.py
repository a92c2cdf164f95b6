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
