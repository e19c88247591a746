"""Numba helpers shared by the kernels: the node table and growable node arrays.

A node is an (element, state) pair, keyed ``state * n + element``. When the state
box is small the table is a dense int32 array indexed by the key (one load per
lookup, and successor lookups of one node stay in a few cache lines because the
layout is state-major); otherwise it is an open-addressing hash table with linear
probing, so memory follows the nodes actually created rather than the box.

Kernels only; nothing outside ``solver/`` calls these.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)


@njit(cache=True, inline="always")
def _slot(key, shift):
    return np.int64((np.uint64(key) * _GOLDEN) >> np.uint64(shift))


@njit(cache=True)
def table_new(dense, size_hint, dense_size):
    """Return (tab, keys, vals, shift). ``size_hint`` is the expected node count."""
    if dense:
        tab = np.full(dense_size, -1, dtype=np.int32)
        return tab, np.full(1, -1, dtype=np.int64), np.full(1, -1, dtype=np.int32), 0
    bits = 10
    while (1 << bits) < 2 * size_hint:
        bits += 1
    keys = np.full(1 << bits, -1, dtype=np.int64)
    vals = np.full(1 << bits, -1, dtype=np.int32)
    return np.full(1, -1, dtype=np.int32), keys, vals, 64 - bits


@njit(cache=True, inline="always")
def table_find(dense, tab, keys, vals, shift, key):
    """Node id stored for ``key``, or -1."""
    if dense:
        return np.int64(tab[key])
    mask = len(keys) - 1
    i = _slot(key, shift)
    while True:
        k = keys[i]
        if k == key:
            return np.int64(vals[i])
        if k == -1:
            return np.int64(-1)
        i = (i + 1) & mask


@njit(cache=True)
def _rehash(keys, vals, shift):
    nkeys = np.full(2 * len(keys), -1, dtype=np.int64)
    nvals = np.full(2 * len(keys), -1, dtype=np.int32)
    nshift = shift - 1
    mask = len(nkeys) - 1
    for j in range(len(keys)):
        k = keys[j]
        if k != -1:
            i = _slot(k, nshift)
            while nkeys[i] != -1:
                i = (i + 1) & mask
            nkeys[i] = k
            nvals[i] = vals[j]
    return nkeys, nvals, nshift


@njit(cache=True)
def table_insert(dense, tab, keys, vals, shift, count, key, value):
    """Insert a key known to be absent; ``count`` is the number of keys before it.

    Returns (keys, vals, shift): the hash arrays are replaced when they grow."""
    if dense:
        tab[key] = value
        return keys, vals, shift
    if 2 * (count + 1) > len(keys):
        keys, vals, shift = _rehash(keys, vals, shift)
    mask = len(keys) - 1
    i = _slot(key, shift)
    while keys[i] != -1:
        i = (i + 1) & mask
    keys[i] = key
    vals[i] = value
    return keys, vals, shift


@njit(cache=True)
def grow_i32(a, n):
    b = np.empty(n, dtype=np.int32)
    b[: len(a)] = a
    return b


@njit(cache=True)
def grow_i64(a, n):
    b = np.empty(n, dtype=np.int64)
    b[: len(a)] = a
    return b


@njit(cache=True)
def grow_f64(a, n):
    b = np.empty(n, dtype=np.float64)
    b[: len(a)] = a
    return b


@njit(cache=True, inline="always")
def decode(s, cap, stride, c):
    """Write the resource vector of linear state ``s`` into ``c``."""
    for i in range(len(cap)):
        c[i] = (s // stride[i]) % (cap[i] + 1)


@njit(cache=True, inline="always")
def fits(c, r, f, cap):
    """True when consuming element f's resources from state c stays inside the box."""
    for i in range(len(cap)):
        if c[i] + r[f, i] > cap[i]:
            return False
    return True


@njit(cache=True, inline="always")
def covers(c, r, p):
    """True when state c holds at least element p's own consumption (p can end at c)."""
    for i in range(len(c)):
        if c[i] < r[p, i]:
            return False
    return True


@njit(cache=True, inline="always")
def admissible(c, lo):
    for i in range(len(c)):
        if c[i] < lo[i]:
            return False
    return True
