"""Where a carried loop goes: the taut-rope prediction the scripted gestures plan with.

Carrying one point of the bowel drags its neighbours along. On each side of the carried point
the rope is pulled taut back to the first point whose length of rope to it reaches the straight
distance to where it is carried (from there on, the rope has slack enough and stays); the points
in between lie on that straight leg, at their share of its length. The prediction is horizontal
(x, y): coverage of the posterior wall is.

A carry the tissue would pull back is refused (None): one that needs more rope than there is to
a pinned end (the rope would stretch), or one that takes a point farther from its mesentery
root than the shortest mesentery reaches (the tether would stretch). Measured on clear_area,
before this refusal the grasped point itself was what came back over the target after most
releases that failed.
"""

from __future__ import annotations

import numpy as np

from viscera.numerics import norm, norms
from viscera.tasks.base import cells_under_tube


def carried(axis: np.ndarray, index: int, drop, roots: np.ndarray | None = None,
            reach: float = np.inf) -> np.ndarray | None:
    """The axis points (m, (n, 2), x y) after axis point `index` of `axis` (m, (n, 3), in order
    along the bowel, its ends pinned) is carried to `drop` (m, x y) and laid there; None if the
    carry would stretch the bowel to an end, or take a moved point farther than `reach` (m) from
    its mesentery root `roots` (m, (n, 3), one per axis point) and farther than it already is.
    The rope's length is the sum of the chords between axis points: observe the axis densely
    enough (the tasks' 100 points are 3 cm apart) or the prediction sees less rope than there is."""
    drop = np.asarray(drop, dtype=float)
    points = axis[:, :2].copy()
    points[index] = drop
    segment = norms(np.diff(axis, axis=0))  # m of rope between neighbours
    count = len(axis)
    for step in (-1, 1):
        lengths, chain, k = [0.0], [index], index
        while 0 <= k + step < count:
            k += step
            lengths.append(lengths[-1] + segment[min(k, k - step)])
            chain.append(k)
            if lengths[-1] >= norm(drop - axis[k, :2]):
                break
        else:  # the rope ran out at the bowel's pinned end without slack
            if lengths[-1] < norm(drop - axis[chain[-1], :2]):
                return None
        anchor, total = axis[chain[-1], :2], lengths[-1]
        for length, k in zip(lengths[1:-1], chain[1:-1]):
            points[k] = drop + (length / total) * (anchor - drop)
    if roots is not None and np.isfinite(reach):
        before = norms(axis - roots)
        after = norms(np.column_stack([points, axis[:, 2]]) - roots)
        if np.any(after > np.maximum(before, reach) + 1e-9):
            return None
    return points


def covered(points: np.ndarray, cells: np.ndarray, radius: float, refine: int = 4) -> np.ndarray:
    """Which `cells` (m, (m, 2)) a tube of `radius` (m) along `points` (m, (n, 2), in order)
    lies over; the polyline is sampled `refine` times per segment."""
    fractions = np.arange(refine) / refine
    fine = np.concatenate([points[:-1] + f * (points[1:] - points[:-1]) for f in fractions] + [points[-1:]])
    return cells_under_tube(cells, fine, radius)  # as the task's reward counts it


def clearance(points: np.ndarray, centre, half) -> float:
    """The least horizontal distance (m) from `points` (m, (n, 2)) to the rectangle of `centre`
    and half sizes `half` (m); 0 for a point inside it, infinite for no points."""
    if not len(points):
        return float("inf")
    outside = np.maximum(np.abs(points - np.asarray(centre)) - np.asarray(half), 0.0)
    return float(np.min(norms(outside)))


def mesentery_roots(root_line: np.ndarray, count: int) -> np.ndarray:
    """Where each of `count` evenly spaced axis points is tethered (m, (count, 3)): the same
    fraction along the mesentery's root line (m, (2, 3): from, to) as along the bowel."""
    fractions = np.linspace(0.0, 1.0, count)[:, None]
    return root_line[0] + fractions * (root_line[1] - root_line[0])


def resampled(axis: np.ndarray, count: int) -> np.ndarray:
    """`axis` (m, (n, 3), in order) resampled to `count` points evenly spaced along its length."""
    arc = np.concatenate([[0.0], np.cumsum(norms(np.diff(axis, axis=0)))])
    s = np.linspace(0.0, arc[-1], count)
    return np.column_stack([np.interp(s, arc, axis[:, c]) for c in range(axis.shape[1])])
