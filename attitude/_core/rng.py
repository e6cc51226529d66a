"""Random numbers in compiled code: reproducible streams from integer seeds.

Each noisy sensor owns a stream: a xoshiro256** generator (Blackman & Vigna, "Scrambled linear
pseudorandom number generators", ACM TOMS 47, 2021) whose four 64-bit words live in a float64
slot array as their bit patterns (so a stream is part of the sensor's state, copied, stored and
resumed bit for bit), seeded by SplitMix64 from the sensor's seed as the authors recommend.
Normal deviates by the ziggurat method (Marsaglia & Tsang, "The ziggurat method for
generating random variables", J. Stat. Softw. 5(8), 2000) in the form NumPy's
``Generator.standard_normal`` uses: 256 layers, one 64-bit word per deviate on 99 % of draws
(8 bits choose the layer, 1 the sign, 52 the abscissa), the wedges and the tail (Marsaglia's
exponential method beyond r) on the rest. It replaced the polar method (5x faster: a gyro draws
6 deviates a tick). Integer arithmetic is exact and the tables are fixed numbers, so a seed
gives the same numbers on every machine and in every thread, whatever else runs.

Layout of a stream (RNG_SIZE floats): the four state words (uint64 bits).
"""

from __future__ import annotations

import math

import numpy as np

from orbit._shared_jit import JIT_DISABLED, jit

RNG_SIZE = 4

_M64 = np.uint64(0xFFFFFFFFFFFFFFFF)

#: The ziggurat's tail edge r and layer area v for 256 layers (Marsaglia & Tsang 2000; v =
#: r f(r) + √(π/2) erfc(r/√2) with f(x) = exp(−x²/2), as NumPy's tables).
ZIG_R = 3.6541528853610088
ZIG_INV_R = 1.0 / ZIG_R
ZIG_V = 0.0049286732339746519


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
def seed_stream(st, o, seed):
    """Seed the stream at ``st[o:o+RNG_SIZE]`` from an integer ``seed`` (SplitMix64)."""
    x = np.uint64(seed)
    for i in range(4):
        x, z = splitmix64(x)
        st.view(np.uint64)[o + i] = z


@jit(inline="always")
def _step(s0, s1, s2, s3):
    """(output, new state) of xoshiro256** from the state words."""
    result = _rotl(s1 * np.uint64(5), 7) * np.uint64(9)
    t = s1 << np.uint64(17)
    s2 ^= s0
    s3 ^= s1
    s1 ^= s2
    s0 ^= s3
    s2 ^= t
    s3 = _rotl(s3, 45)
    return result, s0, s1, s2, s3


@jit(inline="always")
def next_u64(st, o):
    """The next 64-bit output of xoshiro256**."""
    v = st.view(np.uint64)  # one view a draw: a view costs ~2 ns (a one-element slice's, 7)
    result, s0, s1, s2, s3 = _step(v[o], v[o + 1], v[o + 2], v[o + 3])
    v[o] = s0
    v[o + 1] = s1
    v[o + 2] = s2
    v[o + 3] = s3
    return result


@jit
def uniform(st, o):
    """A uniform deviate in [0, 1) with 53 random bits."""
    return float(next_u64(st, o) >> np.uint64(11)) * (1.0 / 9007199254740992.0)


def ziggurat_tables(n: int = 256, r: float = ZIG_R, v: float = ZIG_V):
    """The ziggurat's layers for f(x) = exp(−x²/2): ``(k, w, f)`` (n,) each.

    The layer edges x_n−1 = r > ... > x_1 > x_0 = 0 satisfy x_{i−1} = f⁻¹(f(x_i) + v/x_i)
    (every layer has the area v of the base strip, r f(r) plus the tail). Layer i draws x =
    j w_i for a 52-bit j (w_i = x_i / 2⁵²; the base strip w_0 = v / f(r) / 2⁵²) and accepts it
    at once if j < k_i (x under the next layer's edge: k_i = 2⁵² x_{i−1}/x_i; k_0 = 2⁵² r
    f(r)/v); f_i = f(x_i) bound the wedge tests.
    """
    f = lambda x: math.exp(-0.5 * x * x)  # noqa: E731
    x = np.zeros(n)
    x[n - 1] = r
    for i in range(n - 2, 0, -1):
        x[i] = math.sqrt(-2.0 * math.log(f(x[i + 1]) + v / x[i + 1]))
    scale = 2.0**52
    k = np.zeros(n, np.uint64)
    k[1:] = np.round(x[:-1] / x[1:] * scale).astype(np.uint64)
    k[0] = np.uint64(round(r * f(r) / v * scale))
    w = x / scale
    w[0] = v / f(r) / scale
    fx = np.exp(-0.5 * x * x)
    return k, w, fx


_ZK, _ZW, _ZF = ziggurat_tables()  # read by the kernels as compile-time constants


@jit(inline="always")
def _layer(r):
    """The ziggurat's draw from one word: (layer index, 52-bit abscissa j, x, accepted at
    once)."""
    idx = int(r & np.uint64(0xFF))
    r = r >> np.uint64(8)
    j = (r >> np.uint64(1)) & np.uint64(0x000FFFFFFFFFFFFF)
    x = float(np.int64(j)) * _ZW[idx]  # j < 2⁵²: the signed conversion is one instruction
    if r & np.uint64(1):
        x = -x
    return idx, j, x, j < _ZK[idx]


@jit(inline="always")
def _layer_draw(st, o):
    """One draw of the ziggurat from the stream: (layer index, j, x, accepted at once)."""
    return _layer(next_u64(st, o))


@jit
def _normal_rest(st, o, idx, j, x):
    """The ziggurat past a draw outside its layer's rectangle (1 % of draws): the tail or
    the wedge, then new draws until one is accepted."""
    while True:
        if idx == 0:  # the tail beyond r (Marsaglia 1964): x = r + e₁/r while 2 e₂ > (e₁/r)²
            while True:
                xx = -ZIG_INV_R * math.log1p(-uniform(st, o))
                yy = -math.log1p(-uniform(st, o))
                if yy + yy > xx * xx:
                    return -(ZIG_R + xx) if (j >> np.uint64(8)) & np.uint64(1) else ZIG_R + xx
        elif (_ZF[idx - 1] - _ZF[idx]) * uniform(st, o) + _ZF[idx] < math.exp(-0.5 * x * x):
            return x  # under the density in the layer's wedge
        idx, j, x, inside = _layer_draw(st, o)
        if inside:
            return x


@jit(inline="always")
def normal(st, o):
    """A standard normal deviate (the ziggurat: see the module docstring). The rectangle's
    draw is inlined where it is called; the rest is a call."""
    idx, j, x, inside = _layer_draw(st, o)
    if inside:
        return x  # inside the layer's rectangle: 99 % of draws
    return _normal_rest(st, o, idx, j, x)


@jit(inline="always")
def load(st, o):
    """The stream's state words, to draw several deviates in registers
    (:func:`normal_held`); :func:`store` puts them back."""
    v = st.view(np.uint64)
    return v[o], v[o + 1], v[o + 2], v[o + 3]


@jit(inline="always")
def store(st, o, s0, s1, s2, s3):
    """Put the state words of :func:`load` back into the stream."""
    v = st.view(np.uint64)
    v[o] = s0
    v[o + 1] = s1
    v[o + 2] = s2
    v[o + 3] = s3


@jit(inline="always")
def normal_held(st, o, s0, s1, s2, s3):
    """:func:`normal` on state words held in registers (from :func:`load`): ``(x, s0, s1, s2,
    s3)``. The same deviates as :func:`normal`, in the same order: a draw outside its layer's
    rectangle (1 %) puts the words back, finishes in :func:`_normal_rest` on the stream and
    reloads them. A sensor drawing several deviates a tick keeps the state out of memory
    between them (the gyro's measurement with its six: 69 → 46 ns, measured)."""
    r, s0, s1, s2, s3 = _step(s0, s1, s2, s3)
    idx, j, x, inside = _layer(r)
    if not inside:
        store(st, o, s0, s1, s2, s3)
        x = _normal_rest(st, o, idx, j, x)
        s0, s1, s2, s3 = load(st, o)
    return x, s0, s1, s2, s3


@jit
def normals_held_loop(st, o, out):
    """``out[i]`` by :func:`normal_held` (tests: the same deviates as :func:`normals_loop`)."""
    s0, s1, s2, s3 = load(st, o)
    for i in range(out.shape[0]):
        x, s0, s1, s2, s3 = normal_held(st, o, s0, s1, s2, s3)
        out[i] = x
    store(st, o, s0, s1, s2, s3)


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
    _step = _wrapping(_step)
