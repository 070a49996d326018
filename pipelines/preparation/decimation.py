"""The working resolution: quadric decimation of a mesh above the vertex budget.

A scan of a million vertices carries far more detail than the conformal map, the
registration and the frames need, and each of them costs more than linearly in the
vertex count. Above :attr:`PrepareOptions.vertex_budget` the preparation step
decimates the mesh with Garland and Heckbert's quadric error metric (edge collapses
to the quadric-optimal point, refusing collapses that flip a triangle), as the
`fast-simplification <https://github.com/pyvista/fast-simplification>`_ package
implements it (Sven Forstmann's Fast-Quadric-Mesh-Simplification). The output of
every pipeline is then at the decimated resolution.

The library is run in steps of at most :data:`MAX_RUN_REDUCTION` (4x) each. In one run
of a large reduction it stalls and then decimates carelessly: its collapses are those
whose quadric error is below a threshold that grows with each of its 100 iterations
(``1e-9 (i + 3)^7``), and on coplanar faces (every vertex inside a triangle of a
subdivided mesh) an edge's 3x3 quadric is singular, its determinant rounding noise
rather than exactly 0, so the library's "optimal" point is a random point of the plane
and the collapse is refused as a flip. On the ICT face subdivided 4 times (1.78M
vertices, 3.56M faces, target 100k) a single run had 1.19M faces left at iteration 10
and 283k after its 100, by then taking any collapse that flipped nothing whatever its
error (threshold 8.7e4 in cm^2); the re-run reached the target, but the face's vertices
were up to 1.4 % of the diagonal from the decimated surface (2.7e-4 at the 90th
percentile, 1e-5 after three subdivisions) and the pair morphed at 25.7x the clean pair's
error (``bench_scan_inputs.py --variants subdivision_1m``). In steps of 4x (3.56M ->
890k -> 222k -> 100k faces): 2.6e-4 at the 99th percentile, 4e-5 at the 90th, 1.60x.

The default budget, 50,000 (:data:`~conformorph.pipelines.preparation.options.DEFAULT_VERTEX_BUDGET`),
from ``benchmarks/bench_scan_scale.py --budgets 15000,25000,50000,100000,0 --sizes
68k,270k`` (the choi pairs; frames' L2 error against the truth, relative to the
diagonal, the largest of t = 0.25, 0.5, 0.75; wall and CPU seconds at load 1.8-2.0 on 2
cores, December 2026):

=========  ==========================  ==========================
budget     68k pair                    273k pair
=========  ==========================  ==========================
15,000     FoldedMapError (1 fold)     7.1e-3, 31 s, CPU 34 s (*)
25,000     4.0e-3, 9.9 s, CPU 15 s     3.6e-3, 18.4 s, CPU 29 s
50,000     3.8e-3, 14.4 s, CPU 23 s    3.7e-3, 23.5 s, CPU 39 s
100,000    (none: the pair as read)    3.5e-3, 41 s, CPU 55 s (*)
none       3.6e-3, 13.5 s, CPU 21 s    (not run)
=========  ==========================  ==========================

(*) at load 3.3-3.7. Peak memory 0.4-0.6 GB (68k), 0.8 GB (273k; 1.0 GB at 100k).
From 25,000 up the error is flat (within 10 % of the full resolution's); at 15,000 it
doubles or the registration folds. 25,000 costs about a third less CPU than 50,000, but
sits within 2x of where the failures start, on two pairs of one kind only; 50,000 keeps
twice that margin for some 9 s more CPU at 273k, so it stays the default. (At 68k,
decimating to 50,000 saves nothing: 23 CPU-s against 21 for the mesh as read.)

How output vertices relate to input ones: every collapse merges one vertex into
another (``i1`` into ``i0``); an output vertex is an input vertex no collapse removed,
moved to the quadric-optimal point of everything merged into it. Output vertices
keep the input's order (the library compacts survivors in increasing order).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any

import numpy as np

from conformorph.geometry._typing import FloatArray, IntArray
from conformorph.geometry.mesh_errors import MeshError

#: the collapse aggressiveness handed to the library (its default; 5..8 is its
#: advice: higher is faster and coarser)
AGGRESSIVENESS = 7.0

#: fast-simplification keeps the mesh being decimated in one global C++ object (load,
#: simplify, then read points, faces and collapses back in separate calls): two threads
#: decimating at once (``conformorph morph`` prepares its keys on threads) read each
#: other's results. Measured: the second key's collapse record came back empty.
_LIBRARY_LOCK = threading.Lock()

#: the decimation is run again on its output while that has more than this many times
#: the target faces (and the last run removed at least 5 % of the vertices), at most
#: MAX_PASSES runs in all
SHORT_OF_TARGET = 1.25
MAX_PASSES = 6

#: one run of the library is given the target faces / MAX_RUN_REDUCTION (the final
#: target when that is within SHORT_OF_TARGET of it): see the module's docstring
MAX_RUN_REDUCTION = 4.0

#: a decimated triangle of at most this fraction of the mean area is merged away
#: (:func:`weld_zero_area`; its shortest edge, at most some 5 % of a mean edge). The
#: validation refuses 1e-12 (``ZERO_AREA_RTOL``); 1e-8, the value before, left
#: triangles of 2e-5 of the mean on the 273k choi pair decimated to 15,000 vertices,
#: whose vertex areas (3e-5 of the mean) made the non-rigid ICP's bi-Laplacian
#: ``L A^-1 L`` miss its solve's residual test (SingularSystemError; iterative
#: refinement did not converge either). At 1e-3: 89 vertices welded, the smallest
#: vertex area 1.5e-3 of the mean, and the pair morphs
WELD_AREA_RTOL = 1e-3

#: a decimated triangle whose shortest edge is at most this fraction of its longest
#: (a needle: an angle under about 1°) has that edge merged (:func:`weld_zero_area`)
NEEDLE_RATIO = 0.02


@dataclass(frozen=True)
class Decimation:
    """A decimated mesh and how its vertices relate to the input's.

    Attributes
    ----------
    V : (n2, 3) float64
    F : (m2, 3) int64
        The decimated mesh.
    source : (n2,) int64
        Input row of every output vertex: the input vertex it is (no collapse
        removed it), moved to the quadric-optimal point of the vertices merged
        into it.
    merged_into : (n,) int64
        For every input vertex, the input row of the surviving vertex it was
        merged into by the collapses (itself if it survived); -1 for a vertex
        no face used, or merged into one that lost all its faces.
    report : dict
        ``method``, ``library`` (name and version), ``vertex_budget``,
        ``target_faces``, ``input`` and ``output`` counts and
        ``max_displacement``: the largest distance from an output vertex to its
        source input vertex, relative to the bounding-box diagonal.
    """

    V: FloatArray
    F: IntArray
    source: IntArray
    merged_into: IntArray
    report: dict[str, Any]


def collapse_roots(n: int, collapses: IntArray) -> IntArray:
    """The vertex each vertex ends in after a sequence of edge collapses.

    Parameters
    ----------
    n : int
        Vertex count.
    collapses : (k, 2) int64
        ``collapses[i] = (i0, i1)``: the i-th collapse merged ``i1`` into ``i0``.
        A merged vertex never collapses again.

    Returns
    -------
    (n,) int64
        For each vertex, the vertex no collapse removed that it was merged into,
        directly or through a chain (itself if no collapse removed it).

    Raises
    ------
    ValueError
        An index outside ``0..n-1``, or a vertex removed twice.

    Examples
    --------
    >>> collapse_roots(4, np.array([[0, 1], [2, 0]])).tolist()
    [2, 2, 2, 3]
    """
    c = np.asarray(collapses, dtype=np.int64).reshape(-1, 2)
    if c.size and (c.min() < 0 or c.max() >= n):
        raise ValueError(f"collapse indices must be in 0..{n - 1}")
    # a count per vertex: np.unique of a 1M-collapse record took 0.7 s (numpy 2), this 5 ms
    if c.size and np.bincount(c[:, 1], minlength=n).max() > 1:
        raise ValueError("a vertex is removed by more than one collapse")
    parent = np.arange(n, dtype=np.int64)
    parent[c[:, 1]] = c[:, 0]
    while True:  # pointer jumping: log2(longest chain) passes
        nxt = parent[parent]
        if np.array_equal(nxt, parent):
            return parent
        parent = nxt


def decimate_to_budget(V: FloatArray, F: IntArray, vertex_budget: int) -> Decimation:
    """Decimate a mesh to about ``vertex_budget`` vertices by quadric edge collapse.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
        A triangle mesh without unreferenced vertices (the element clean-up's output).
    vertex_budget : int
        Vertices aimed at (at least 100): the target face count is twice it, which
        for a disk gives ``budget + boundary/2`` vertices less the boundary the
        collapses shorten (measured: 50,068 for a budget of 50,000 at 1.09M).

    Returns
    -------
    Decimation

    Raises
    ------
    ValueError
        ``vertex_budget`` below 100 or not below ``n``.
    MeshError
        The library returned vertices that do not match its collapse record.

    Notes
    -----
    Border vertices collapse only along the border (the library's default), so a
    disk's boundary stays its boundary.
    """
    import fast_simplification  # a compiled wheel: imported only when decimating

    n = int(V.shape[0])
    if not 100 <= int(vertex_budget) < n:
        raise ValueError(f"vertex_budget must be in 100..{n - 1}, got {vertex_budget}")
    target = min(2 * int(vertex_budget), int(F.shape[0]) - 1)
    P, G, collapses, passes = _simplify_passes(fast_simplification, V, F, target)
    roots = collapse_roots(n, collapses)
    # the faces left are the input's with every corner replaced by its root, less those
    # whose corners merged (the library deletes exactly these); a survivor all of whose
    # faces went that way is no output vertex (measured: 1 of 50,135 at 1.09M)
    R = roots[F]
    alive = (R[:, 0] != R[:, 1]) & (R[:, 1] != R[:, 2]) & (R[:, 0] != R[:, 2])
    referenced = np.zeros(n, dtype=bool)
    referenced[R[alive].ravel()] = True
    source = np.flatnonzero(referenced)
    if source.size != P.shape[0]:
        raise MeshError(
            f"decimation returned {P.shape[0]} vertices but its collapse record leaves "
            f"{source.size}"
        )
    used = np.zeros(n, dtype=bool)
    used[F.ravel()] = True
    roots[~used | ~referenced[roots]] = -1
    P, G, source, new_index, welded = weld_zero_area(
        np.asarray(P, dtype=np.float64), np.asarray(G, dtype=np.int64), source
    )
    if welded:  # every input vertex follows its survivor into the weld
        ok = roots >= 0
        moved_to = new_index[np.searchsorted(referenced.nonzero()[0], roots[ok])]
        roots[ok] = np.where(moved_to >= 0, source[moved_to], -1)
    diag = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) or 1.0
    moved = np.linalg.norm(P - V[source], axis=1)
    report = {
        "method": "quadric edge collapse (Garland-Heckbert), border kept on the border",
        "library": f"fast-simplification {fast_simplification.__version__}",
        "vertex_budget": int(vertex_budget),
        "target_faces": target,
        "input": {"vertices": n, "faces": int(F.shape[0])},
        "output": {"vertices": int(P.shape[0]), "faces": int(G.shape[0])},
        "max_displacement": float(moved.max(initial=0.0) / diag),
        "welded_vertices": welded,
        "passes": passes,
    }
    return Decimation(P, G, source, roots, report)


def _simplify_passes(
    library: Any, V: FloatArray, F: IntArray, target: int
) -> tuple[FloatArray, IntArray, IntArray, int]:
    """The library's decimation in steps of at most :data:`MAX_RUN_REDUCTION`, run
    again on its own output while it stops short.

    Its 100 iterations sometimes end far above the target: measured on the ICT face
    subdivided 3 times with random faces split at their centroid (1M vertices), 423,177
    vertices for a target of 100,000 faces, in one run. A new run on the output starts
    afresh (its quadrics from the faces it is given). Returns ``(P, G, collapses in
    input rows, passes)``; ``passes`` counts the runs.
    """
    src = np.arange(V.shape[0], dtype=np.int64)
    P, G = np.ascontiguousarray(V, dtype=np.float64), np.ascontiguousarray(F, dtype=np.int64)
    records: list[IntArray] = []
    passes = 0
    while passes < MAX_PASSES:
        passes += 1
        n_before, G_before = P.shape[0], G
        run_target = int(G.shape[0] / MAX_RUN_REDUCTION)
        if run_target < SHORT_OF_TARGET * target:  # the last run: to the target itself
            run_target = target
        with _LIBRARY_LOCK:
            P, G, c = library.simplify(
                P, G, target_count=run_target, agg=AGGRESSIVENESS, return_collapses=True
            )
        c = np.asarray(c, dtype=np.int64).reshape(-1, 2)
        records.append(src[c])
        if G.shape[0] <= SHORT_OF_TARGET * target or P.shape[0] > 0.95 * n_before:
            break
        # the next run's input rows: this run's output vertices, found as in
        # decimate_to_budget (the survivors its remaining faces use, in order)
        R = collapse_roots(n_before, c)[G_before]
        alive = (R[:, 0] != R[:, 1]) & (R[:, 1] != R[:, 2]) & (R[:, 0] != R[:, 2])
        used = np.zeros(n_before, dtype=bool)
        used[R[alive].ravel()] = True
        kept = np.flatnonzero(used)
        if kept.size != P.shape[0]:
            raise MeshError(
                f"decimation returned {P.shape[0]} vertices but its collapse record leaves "
                f"{kept.size}"
            )
        src = src[kept]
        P, G = np.ascontiguousarray(P, dtype=np.float64), np.ascontiguousarray(G, np.int64)
    return P, G, np.concatenate(records), passes


def weld_zero_area(
    P: FloatArray,
    G: IntArray,
    source: IntArray,
    *,
    rtol: float = WELD_AREA_RTOL,
    needle_ratio: float = NEEDLE_RATIO,
) -> tuple[FloatArray, IntArray, IntArray, IntArray, int]:
    """Merge the shortest edge of every needle or (near) zero-area triangle a decimation left.

    Parameters
    ----------
    P : (n2, 3) float64
    G : (m2, 3) int64
        The decimated mesh.
    source : (n2,) int64
        Input row of every vertex.
    rtol : float, keyword-only
        A triangle whose area is at most ``rtol`` times the mean is merged away.
    needle_ratio : float, keyword-only
        So is one whose shortest edge is at most this fraction of its longest.

    Returns
    -------
    P, G, source
        The mesh without such triangles (each group of vertices joined by a shortest
        edge becomes its lowest-numbered vertex; faces left with a repeated corner,
        duplicate faces and unused vertices dropped; order kept).
    new_index : (n2,) int64
        The new row of every vertex of ``P`` (its group's), -1 for one no face uses.
    welded : int
        Vertices merged into another.

    Notes
    -----
    Quadric collapses on piecewise-flat input (a subdivided mesh) send several
    vertices to the point where three planes meet: measured 26 triangles of
    about 1e-20 of the mean area among 100,000 at 1.09M → 50k vertices, which
    the disk validation refuses; and needles on any input (4,391 triangles with an
    angle under 1° on the smooth deformed 1.09M face), whose disk maps folded
    the morph's registration. Up to 5 passes.
    """
    from scipy.sparse import coo_array
    from scipy.sparse.csgraph import connected_components

    from conformorph.geometry import clean_mesh_elements

    new_index = np.arange(P.shape[0], dtype=np.int64)
    welded = 0
    for _ in range(5):
        T = P[G]
        A = np.linalg.norm(np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]), axis=1)
        lengths = np.linalg.norm(T[:, [1, 2, 0]] - T, axis=2)  # edge j: corner j -> j+1
        needle = lengths.min(axis=1) <= needle_ratio * lengths.max(axis=1)
        bad = np.flatnonzero((A <= rtol * A.mean()) | needle)
        if bad.size == 0:
            break
        B = G[bad]
        j = np.argmin(lengths[bad], axis=1)
        u, v = B[np.arange(bad.size), j], B[np.arange(bad.size), (j + 1) % 3]
        n2 = P.shape[0]
        graph = coo_array((np.ones(u.size), (u, v)), shape=(n2, n2))
        _, label = connected_components(graph, directed=False)
        lowest = np.full(label.max() + 1, n2, dtype=np.int64)
        np.minimum.at(lowest, label, np.arange(n2))
        r = lowest[label]
        welded += int((r != np.arange(n2)).sum())
        c = clean_mesh_elements(P, r[G])
        renum = np.full(n2, -1, dtype=np.int64)
        renum[c.kept] = np.arange(c.kept.size)
        new_index = np.where(new_index >= 0, renum[r[np.maximum(new_index, 0)]], -1)
        P, G, source = c.V, c.F, source[c.kept]
    return P, G, source, new_index, welded


def working_resolution_step(
    V: FloatArray,
    F: IntArray,
    src: IntArray,
    n_in: int,
    vertex_budget: int | None,
    rep: dict[str, Any],
) -> tuple[FloatArray, IntArray, IntArray, IntArray | None]:
    """The preparation's decimation step: nothing at or below the budget.

    Parameters
    ----------
    V : (n1, 3) float64
    F : (m1, 3) int64
        The cleaned mesh.
    src : (n1,) int64
        Input row of every vertex of ``V``.
    n_in : int
        The input's vertex count.
    vertex_budget : int or None
        Decimate when ``n1`` exceeds it; None never decimates.
    rep : dict
        The preparation report: ``rep["decimation"]`` is set (None when the
        mesh was within the budget).

    Returns
    -------
    V, F, src
        The mesh at the working resolution and the input row of every vertex.
    merged_into : (n_in,) int64 or None
        Input row of the surviving vertex each input vertex was merged into (-1
        for one the clean-up dropped); None without decimation.
    """
    if vertex_budget is None or V.shape[0] <= vertex_budget:
        rep["decimation"] = None
        return V, F, src, None
    d = decimate_to_budget(V, F, vertex_budget)
    merged = np.full(n_in, -1, dtype=np.int64)
    ok = d.merged_into >= 0
    merged[src[ok]] = src[d.merged_into[ok]]
    rep["decimation"] = d.report
    return d.V, d.F, src[d.source], merged
