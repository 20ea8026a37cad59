"""Automatic chain detection ([MicroCAM] §6.1.2): join pieces whose ends meet.

DXF drawings and many SVGs arrive as loose pieces — lines, arcs, short paths
— in no particular order. Cutting them as they come makes the head jump
back and forth and leaves closed outlines as several open cuts. [MicroCAM]
joins entities whose end points coincide into open or closed chains by
comparing every end with every chain end, recursively — O(n²).

Here the close pairs of ends are found by a k-d tree (scipy's ``cKDTree``; a
few thousand ends are compared all at once instead, without importing scipy), ends within ``tol_mm``
are merged into nodes (union–find over the close pairs), and the pieces
become edges of a graph on those nodes. Walking the graph from every node
that is not of degree 2 gives the open chains; what is left are loops, the
closed chains. A node where three or more pieces meet ends the chains
through it. Everything is O(n log n).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from labkit.errors import GeometryError
from labkit.geometry._grid import close_pairs
from labkit.geometry.path import Path

__all__ = ["join_chains", "end_nodes"]


def end_nodes(paths: Sequence[Path], tol_mm: float) -> np.ndarray:
    """Node id of every path end: array (n, 2) of [start node, end node].

    Ends closer than ``tol_mm`` (transitively) share a node.
    """
    if not tol_mm >= 0:
        raise GeometryError(f"tol_mm must be >= 0 mm, got {tol_mm!r}")
    n = len(paths)
    ends = np.empty((2 * n, 2))
    for i, p in enumerate(paths):
        ends[2 * i] = p.start
        ends[2 * i + 1] = p.end
    parent = np.arange(2 * n)

    def find(a):
        root = a
        while parent[root] != root:
            root = parent[root]
        while parent[a] != root:
            parent[a], a = root, parent[a]
        return root

    if n and tol_mm > 0:
        for a, b in close_pairs(ends, tol_mm):
            ra, rb = find(a), find(b)
            if ra != rb:
                parent[max(ra, rb)] = min(ra, rb)
    elif n:
        # exact coincidence only: group equal coordinates
        _, first = np.unique(ends, axis=0, return_inverse=True)
        return first.reshape(n, 2)
    roots = np.array([find(a) for a in range(2 * n)])
    _, ids = np.unique(roots, return_inverse=True)
    return ids.reshape(n, 2)


def _join(pieces: list[tuple[Path, bool]], closed: bool) -> Path:
    """Concatenate pieces (path, reversed?) into one path, snapping shared ends."""
    verts, cents, sweeps = [], [], []
    dev = 0.0
    for k, (p, rev) in enumerate(pieces):
        q = p.reversed() if rev else p
        v = q.vertices if k == 0 else q.vertices[1:]
        verts.append(v)
        cents.append(q.centres)
        sweeps.append(q.sweeps)
        dev = max(dev, q.deviation_mm)
    v = np.vstack(verts)
    if closed:
        v[-1] = v[0]
    first = pieces[0][0]
    return first.with_geometry(v, np.vstack(cents), np.concatenate(sweeps), closed=closed,
                               deviation_mm=dev)


def join_chains(paths: Sequence[Path], tol_mm: float = 1e-3, *, by_layer=True) -> list[Path]:
    """Join pieces whose ends meet within ``tol_mm`` into chains ([MicroCAM] §6.1.2).

    Parameters
    ----------
    paths : sequence of Path
        Pieces in any order and direction. Already-closed paths pass through.
    tol_mm : float
        Ends closer than this are the same point, mm.
    by_layer : bool
        Join only pieces of the same layer.

    Returns
    -------
    list of Path
        Open chains first (each from a free end or a branch point), then the
        closed loops. A chain keeps the layer and colours of its first piece.

    Examples
    --------
    Four loose sides of a square, two of them backwards, become one closed chain:

    >>> sides = [Path([(0, 0), (10, 0)]), Path([(10, 10), (10, 0)]),
    ...          Path([(0, 10), (10, 10)]), Path([(0, 0), (0, 10)])]
    >>> chains = join_chains(sides)
    >>> len(chains), chains[0].closed, chains[0].n_segments, chains[0].length_mm
    (1, True, 4, 40.0)
    """
    if by_layer:
        out: list[Path] = []
        layers: dict[str, list[Path]] = {}
        for p in paths:
            layers.setdefault(p.layer, []).append(p)
        for group in layers.values():
            out += join_chains(group, tol_mm, by_layer=False)
        return out
    done = [p for p in paths if p.closed]
    loose = [p for p in paths if not p.closed]
    if not loose:
        return done
    nodes = end_nodes(loose, tol_mm)
    n_nodes = int(nodes.max()) + 1
    # adjacency: for each node the list of (piece, end) incident to it
    inc_piece = np.concatenate([np.arange(len(loose)), np.arange(len(loose))])
    inc_end = np.concatenate([np.zeros(len(loose), int), np.ones(len(loose), int)])
    inc_node = np.concatenate([nodes[:, 0], nodes[:, 1]])
    order = np.argsort(inc_node, kind="stable")
    bounds = np.searchsorted(inc_node[order], np.arange(n_nodes + 1))
    degree = np.diff(bounds)
    used = np.zeros(len(loose), bool)

    def walk(node, piece, from_end):
        chain = []
        closed = False
        start_node = node
        while True:
            used[piece] = True
            rev = from_end == 1                  # entered at its end: run it backwards
            chain.append((loose[piece], rev))
            node = nodes[piece, 0 if rev else 1]
            if node == start_node and degree[node] == 2:
                closed = True
                break
            if degree[node] != 2:
                break
            nxt = None
            for slot in order[bounds[node]:bounds[node + 1]]:
                if not used[inc_piece[slot]]:
                    nxt = slot
                    break
            if nxt is None:
                break
            piece, from_end = inc_piece[nxt], inc_end[nxt]
        return _join(chain, closed)

    chains = []
    for node in np.flatnonzero(degree != 2):       # open chains start at free ends and branches
        for slot in order[bounds[node]:bounds[node + 1]]:
            if not used[inc_piece[slot]]:
                chains.append(walk(node, inc_piece[slot], inc_end[slot]))
    for piece in range(len(loose)):                 # what is left are loops
        if not used[piece]:
            chains.append(walk(nodes[piece, 0], piece, 0))
    return chains + done
