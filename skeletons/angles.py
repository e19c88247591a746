"""Matching skeleton corners to the corner angles a part library has.

Takes plain (angle, convex) pairs so this package stays independent of part
libraries: the pipeline passes the angles of the library's corner parts. A corner
matches the nearest available angle of the same convexity within ``tol`` degrees;
bends (nearly straight vertices) need no corner part.
"""

from __future__ import annotations

from collections.abc import Iterable

from citysynth.skeletons.errors import SkeletonError
from citysynth.skeletons.model import Skeleton

ANGLE_TOL = 7.5  # degrees


def match_corner_angles(skeleton: Skeleton, available: Iterable[tuple[float, bool]],
                        tol: float = ANGLE_TOL) -> dict[int, tuple[float, bool]]:
    """Key point id -> the library corner (angle, convex) it takes; raises
    SkeletonError naming the first corner with no match and listing what exists."""
    avail = sorted({(float(a), bool(c)) for a, c in available})
    out: dict[int, tuple[float, bool]] = {}
    for k in skeleton.keypoints:
        if k.kind != "corner":
            continue
        assert k.angle is not None, "a corner carries its angle"
        angle = k.angle
        same = [a for a in avail if a[1] == k.convex]
        best = min(same, key=lambda a: abs(a[0] - angle), default=None)
        if best is None or abs(best[0] - angle) > tol:
            kind = "convex" if k.convex else "concave"
            have = ", ".join(f"{a:g}° {'convex' if c else 'concave'}" for a, c in avail) \
                or "none"
            raise SkeletonError(
                f"{skeleton.name}: the {kind} corner of {angle:.1f}° at "
                f"{skeleton.frame.at(k.xy)} has no part within {tol:g}°; the library "
                f"has corners of {have}")
        out[k.id] = best
    return out
