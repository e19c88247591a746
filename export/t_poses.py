"""How a T part stands at a T junction: its pose, named in its key element's id.

A library T part is made in one way only (README, "The canonical frame"): the main range
runs along X with its facade facing -Y, the wing leaves behind it (+Y) and the wing's
facade faces +X, the in-leg's side. A skeleton asks for more: its wing may leave on the
street side of the main line (a courtyard ring whose facades face out, with a wing going
out), and its facade may face either side of the wing line (in an H, the bar between two
T junctions is one wing of both, seen from opposite ends). Two flags cover every case:

- ``swap``: the part is turned end for end along the main line, so the structure's in-leg
  is the part's leg 1 and its out-leg the part's leg 0 (its in- and out-sections swap);
- ``street``: the part is turned over about the middle of its main range's depth, so its
  back face stands on the facade line and the wing leaves from there on the street side;
  the wing then reaches ``depth`` less past the key point, and the main sections are
  seen from the other face (mirrored about the middle of the depth).

Whether the placed part is a mirror image follows from the two flags and the fronts (the
export fits it to the skeleton; see :mod:`citysynth.export.place`). Profiles symmetric
about the middle of their depth (the sample library's) look the same turned over; for
others the ``street`` pose shows the main range's courtyard side to the street.

A T key element is the part id alone in the canonical pose, else the id, ``@`` and the
flags (``classic_t@swap+street``), so the solver's transitions and legs can differ by pose
while export still finds the part.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

SEP = "@"


class TPose(NamedTuple):
    part: str          # the library part
    swap: bool         # turned end for end along the main line
    street: bool       # turned over: the wing leaves on the street side


def t_element(part: str, swap: bool, street: bool) -> str:
    """The key element id of T part ``part`` in a pose.

    >>> t_element("classic_t", False, False), t_element("classic_t", True, True)
    ('classic_t', 'classic_t@swap+street')
    """
    flags = [name for name, on in (("swap", swap), ("street", street)) if on]
    return part if not flags else part + SEP + "+".join(flags)


def t_pose(element: str) -> TPose:
    """The part and pose of a key element (any key element: poses only name T parts).

    >>> t_pose("classic_t@street")
    TPose(part='classic_t', swap=False, street=True)
    """
    part, _, flags = element.partition(SEP)
    names = set(flags.split("+")) if flags else set()
    return TPose(part, "swap" in names, "street" in names)


def part_leg(element: str, leg: int) -> int:
    """The part's leg that realises the structure's leg ``leg`` of this element."""
    if leg == 2 or not t_pose(element).swap:
        return leg
    return 1 - leg


def main_depth(sec_in: object, quantum: float | None = None) -> float:
    """The depth of a T part's main range (facade to back face), on the quantum if one is
    given (the solver's legs) or as measured (the export's geometry): its section reaches
    as far past the back face as past the facade (symmetric profiles), so the depth is
    what lies between. Only the ``street`` pose needs it."""
    u0, _v0, u1, _v1 = sec_in.bounds  # type: ignore[attr-defined]
    depth = -(u0 + u1)
    return depth if quantum is None else round(round(depth / quantum) * quantum, 9)


def pose_from_ground(u_main: np.ndarray, main_front_right: bool, w: np.ndarray,
                     wing_front_right: bool) -> tuple[bool, bool]:
    """(swap, street) for a T whose main line runs along ``u_main`` (its travel through
    the junction) with its facade on the right of travel or not, and whose wing leaves
    along ``w`` with its facade on the right of that (outward) travel or not.

    The canonical part: main travel +X, facade right (-Y), wing +Y, wing facade +X.

    >>> x, y = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    >>> pose_from_ground(x, True, y, True), pose_from_ground(x, True, -y, True)
    ((False, False), (True, True))
    """
    def right(u: np.ndarray) -> np.ndarray:
        return np.array([u[1], -u[0]])
    n_main = right(u_main) if main_front_right else -right(u_main)
    n_wing = right(w) if wing_front_right else -right(w)
    return bool(n_wing @ u_main < 0), bool(w @ n_main > 0)
