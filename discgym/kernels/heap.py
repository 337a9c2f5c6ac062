"""The event queues: a binary min-heap of events keyed by time in one (capacity, 5) float
array (the time-stepped integrator's contacts within a substep), and an indexed min-heap of
one key per disc (the event-driven integrator's next events).

An event row of the first is (t, i, j, stamp_i, stamp_j): a contact of disc i with disc j
(j >= 0) or with the wall (j = -1) at time t. Stamps are the discs' trajectory counters when
the event was predicted: an event whose discs have changed since is stale and skipped. Ties in
t are broken by (i, j), so the processing order is fully deterministic. (Indices and stamps
are exact in float64 up to 2^53.)

Pushing never reallocates: callers :func:`reserve` room for all the pushes a phase can make
before they loop: a loop that reassigns an array (``H = push(H, ...)``) makes numba
reference-count it on every iteration, executed or not. A push into a full heap raises (never
overflows silently).
"""

from typing import NamedTuple

import numpy as np
from numba import njit

from .jit import kernel
from .structs import FLOAT


class IndexedHeap(NamedTuple):
    """A min-heap of one key per disc: key (C,) float64 the keys in heap order, disc (C,)
    int32 the disc in each slot, slot (C,) int32 the slot of each disc. A disc without an
    event holds key inf, so the heap never grows or shrinks within a run."""

    key: np.ndarray
    disc: np.ndarray
    slot: np.ndarray


@njit(cache=True, inline="always")
def heap_set(heap, d, key):
    """Set disc d's key and restore the heap order (O(log C))."""
    hk, hd, hpos = heap.key, heap.disc, heap.slot
    p = hpos[d]
    size = hk.shape[0]
    if key < hk[p]:
        while p > 0:
            q = (p - 1) >> 1
            kq = hk[q]
            if kq <= key:
                break
            hk[p] = kq
            e = hd[q]
            hd[p] = e
            hpos[e] = p
            p = q
    else:
        while True:
            a = 2 * p + 1
            if a >= size:
                break
            ka = hk[a]
            b = a + 1
            if b < size:
                kb = hk[b]
                if kb < ka:
                    a = b
                    ka = kb
            if key <= ka:
                break
            hk[p] = ka
            e = hd[a]
            hd[p] = e
            hpos[e] = p
            p = a
    hk[p] = key
    hd[p] = d
    hpos[d] = p


@njit(cache=True, inline="always")
def new_heap(capacity):
    return np.empty((max(capacity, 16), 5), dtype=FLOAT)


@njit(cache=True, inline="always")
def reserve(H, size, extra):
    """The heap itself if it has room for ``extra`` more events, else a larger copy."""
    need = size + extra
    if need <= H.shape[0]:
        return H
    G = np.empty((max(need, 2 * H.shape[0]), 5), dtype=FLOAT)
    for i in range(size):  # (a loop: numba's slice assignment compiles a formatted error)
        for k in range(5):
            G[i, k] = H[i, k]
    return G


@njit(cache=True, inline="always")
def push(H, size, t, i, j, si, sj):
    """Push an event (room must have been reserved); returns the new size."""
    # (the row's fields as floats and the size as int64 here, at each call site: one
    # compiled _push whatever the integer types of the callers, and none for literal
    # arguments such as j = -1)
    return _push(H, np.int64(size), t, float(i), float(j), float(si), float(sj))


@kernel
def _push(H, size, t, fi, fj, si, sj):
    if size >= H.shape[0]:
        raise IndexError("event heap full: room was not reserved (a bug in the caller)")
    k = size
    while k > 0:  # sift up: move parents down until the slot fits
        p = (k - 1) >> 1
        tp = H[p, 0]
        if tp < t or (tp == t and (H[p, 1] < fi or (H[p, 1] == fi and H[p, 2] <= fj))):
            break
        H[k, 0] = H[p, 0]
        H[k, 1] = H[p, 1]
        H[k, 2] = H[p, 2]
        H[k, 3] = H[p, 3]
        H[k, 4] = H[p, 4]
        k = p
    H[k, 0] = t
    H[k, 1] = fi
    H[k, 2] = fj
    H[k, 3] = si
    H[k, 4] = sj
    return size + 1


@kernel
def pop(H, size):
    """Remove the earliest event; returns (t, i, j, si, sj, new_size). Needs size > 0."""
    t = H[0, 0]
    i = int(H[0, 1])
    j = int(H[0, 2])
    si = int(H[0, 3])
    sj = int(H[0, 4])
    size -= 1
    if size > 0:
        # sift the last row down from the root
        lt = H[size, 0]
        li = H[size, 1]
        lj = H[size, 2]
        k = 0
        while True:
            a = 2 * k + 1
            if a >= size:
                break
            b = a + 1
            if b < size and (H[b, 0] < H[a, 0] or (H[b, 0] == H[a, 0] and (
                    H[b, 1] < H[a, 1] or (H[b, 1] == H[a, 1] and H[b, 2] < H[a, 2])))):
                a = b
            if lt < H[a, 0] or (lt == H[a, 0] and (li < H[a, 1] or (
                    li == H[a, 1] and lj <= H[a, 2]))):
                break
            H[k, 0] = H[a, 0]
            H[k, 1] = H[a, 1]
            H[k, 2] = H[a, 2]
            H[k, 3] = H[a, 3]
            H[k, 4] = H[a, 4]
            k = a
        if k != size:
            H[k, 0] = lt
            H[k, 1] = li
            H[k, 2] = lj
            H[k, 3] = H[size, 3]
            H[k, 4] = H[size, 4]
    return t, i, j, si, sj, size
