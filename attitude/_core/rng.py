"""Random numbers in compiled code: reproducible streams from integer seeds.

Each noisy sensor owns a stream: a xoshiro256** generator (Blackman & Vigna, "Scrambled linear
pseudorandom number generators", ACM TOMS 47, 2021) whose four 64-bit words live in a float64
slot array as their bit patterns (so a stream is part of the sensor's state, copied, stored and
resumed bit for bit), seeded by SplitMix64 from the sensor's seed as the authors recommend.
Normal deviates by the polar method of Marsaglia (two uniforms per pair, the second kept).
Integer arithmetic is exact, so a seed gives the same numbers on every machine and in every
thread, whatever else runs.

Layout of a stream (RNG_SIZE floats): the four state words (uint64 bits), a cached normal
deviate and a flag saying it is valid.
"""

from __future__ import annotations

import math

import numpy as np

from orbit._shared_jit import JIT_DISABLED, jit

RNG_SIZE = 6
_CACHE = 4
_HAS = 5

_M64 = np.uint64(0xFFFFFFFFFFFFFFFF)


@jit(inline="always")
def _rotl(x, k):
    return (x << np.uint64(k)) | (x >> np.uint64(64 - k))


@jit
def splitmix64(x):
    """(next state, output) of SplitMix64 (Steele, Lea & Flood 2014)."""
    x = x + np.uint64(0x9E3779B97F4A7C15)
    z = x
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x, z ^ (z >> np.uint64(31))


@jit
def _load(st, o, i):
    return st[o + i : o + i + 1].view(np.uint64)[0]


@jit
def _store(st, o, i, v):
    st[o + i : o + i + 1].view(np.uint64)[0] = v


@jit
def seed_stream(st, o, seed):
    """Seed the stream at ``st[o:o+RNG_SIZE]`` from an integer ``seed`` (SplitMix64)."""
    x = np.uint64(seed)
    for i in range(4):
        x, z = splitmix64(x)
        _store(st, o, i, z)
    st[o + _CACHE] = 0.0
    st[o + _HAS] = 0.0


@jit
def next_u64(st, o):
    """The next 64-bit output of xoshiro256**."""
    s0 = _load(st, o, 0)
    s1 = _load(st, o, 1)
    s2 = _load(st, o, 2)
    s3 = _load(st, o, 3)
    result = _rotl(s1 * np.uint64(5), 7) * np.uint64(9)
    t = s1 << np.uint64(17)
    s2 ^= s0
    s3 ^= s1
    s1 ^= s2
    s0 ^= s3
    s2 ^= t
    s3 = _rotl(s3, 45)
    _store(st, o, 0, s0)
    _store(st, o, 1, s1)
    _store(st, o, 2, s2)
    _store(st, o, 3, s3)
    return result


@jit
def uniform(st, o):
    """A uniform deviate in [0, 1) with 53 random bits."""
    return float(next_u64(st, o) >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@jit
def normal(st, o):
    """A standard normal deviate (Marsaglia's polar method; pairs, the second cached)."""
    if st[o + _HAS] != 0.0:
        st[o + _HAS] = 0.0
        return st[o + _CACHE]
    while True:
        u = 2.0 * uniform(st, o) - 1.0
        v = 2.0 * uniform(st, o) - 1.0
        s = u * u + v * v
        if 0.0 < s < 1.0:
            break
    f = math.sqrt(-2.0 * math.log(s) / s)
    st[o + _CACHE] = v * f
    st[o + _HAS] = 1.0
    return u * f


@jit
def normals_loop(st, o, out):
    """``out[i] = normal(st, o)`` (for tests of the generator's statistics)."""
    for i in range(out.shape[0]):
        out[i] = normal(st, o)


def _wrapping(f):
    """``f`` with numpy's overflow warning off: the generators want 64-bit products and sums
    to wrap around, which compiled code does silently and plain numpy scalars warn about."""

    def wrapped(*args):
        with np.errstate(over="ignore"):
            return f(*args)

    wrapped.__doc__ = f.__doc__
    return wrapped


if JIT_DISABLED:  # ATTITUDE_DISABLE_JIT=1: the same numbers, without a warning per draw
    splitmix64 = _wrapping(splitmix64)
    next_u64 = _wrapping(next_u64)
