"""Per-resource quantisation: real-valued resources become integers.

The intermediate graph indexes nodes by integer resource consumption (paper §3.1,
footnote 1), so every constrained resource needs a quantum q with each value an
integer multiple of q. We prefer the *exact* common divisor of the element values and
the bounds (0.2 m parts and an 83.4 m target give q = 0.2, nothing is rounded); only
when none exists (within 1e-9) do we need a user quantum, and then we round values to
the nearest multiple and report the largest rounding error. Bounds are always rounded
inward, so a quantised solution never violates the original interval.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from functools import lru_cache

import numpy as np

from citysynth.solver.errors import ProblemError

TOL = 1e-9
_MAX_DENOMINATOR = 10**4  # 0.1 mm on metres; finer "divisors" are noise


@dataclass(frozen=True)
class Quantisation:
    """How one constrained resource was quantised."""

    resource: str
    quantum: float
    exact: bool          # every element value and bound is an integer multiple of quantum
    max_error: float     # largest |value - rounded value| over element values (original units)
    lo: int              # bounds in quanta, rounded inward
    hi: int
    asked: tuple[float, float]  # bounds as the user gave them

    def to_dict(self) -> dict:
        return {
            "quantum": self.quantum,
            "exact": self.exact,
            "max_rounding_error": self.max_error,
            "bounds_quantised": [self.lo, self.hi],
        }


def exact_divisor(values: list[float]) -> Fraction | None:
    """The largest q with every value an integer multiple of q (within 1e-9), or None.

    Values are read as rationals with denominators up to 10**4; the gcd of rationals
    a_i/b_i is gcd(a_i * L/b_i) / L with L = lcm(b_i). All-zero input gives 1.
    """
    distinct = {v for v in values if v != 0}   # a library repeats its few lengths
    if not distinct:
        return Fraction(1)
    if all(float(v).is_integer() for v in distinct):   # counts: the gcd of integers
        return Fraction(math.gcd(*(int(v) for v in distinct)))
    fracs = []
    for v in distinct:          # exact integer arithmetic below: order is immaterial
        f = _rational(v)
        if f is None:
            return None
        fracs.append(f)
    lcm = 1
    for f in fracs:
        lcm = lcm * f.denominator // math.gcd(lcm, f.denominator)
    g = 0
    for f in fracs:
        g = math.gcd(g, f.numerator * (lcm // f.denominator))
    if g == 0:   # every value is 0 within 1e-9, none is 0: no divisor (q = 0 divided by 0)
        return None
    return Fraction(g, lcm)


@lru_cache(maxsize=4096)
def _rational(v: float) -> Fraction | None:
    """v as a rational with a denominator up to 10**4, or None when none is within
    1e-9 of it (made once per value: problems from one library repeat its lengths)."""
    f = Fraction(v).limit_denominator(_MAX_DENOMINATOR)
    return f if abs(float(f) - v) <= TOL * max(1.0, abs(v)) else None


def _hint(values: list[float]) -> str:
    """A quantum to suggest for values with no common divisor: 0.1, or a power of ten
    no larger than the smallest value (values of 1e-8 given a quantum of 0.1 would
    each count as nothing)."""
    small = min((abs(v) for v in values if v != 0 and math.isfinite(v)), default=1.0)
    if small >= 0.1:
        return "0.1"
    return f"{10.0 ** max(math.floor(math.log10(small)), -300):g}"


def quanta_text(amount: float) -> str:
    """A count of quanta in three figures, or past what a float holds (1e308 m of 0.2
    m quanta), as messages say it."""
    return f"{amount:.3g} quanta" if math.isfinite(amount) else "beyond 1e308 quanta"


def is_multiple(v: float, q: float) -> bool:
    """v is an integer multiple of q (within 1e-9, relative to the multiple)."""
    m = v / q
    if not math.isfinite(m):   # 1e308 of a 0.2 quantum: no multiple, and past any cap
        return False
    return abs(m - round(m)) <= TOL * max(1.0, abs(m))


QUANTA_CAP = 1 << 62   # quanta: the largest bound the int64 tables take
VALUE_QUANTA_MAX = 1e9   # quanta: an element's value past this is a quantum far too fine


def quantise_resource(
    name: str, values: list[float], lo: float, hi: float, quantum: float | None
) -> tuple[Quantisation, list[int]]:
    """Quantise one resource's element values and bounds; returns the integer values too."""
    if quantum is None:
        q_exact = exact_divisor(values + [lo, hi])
        if q_exact is None:
            raise ProblemError(
                f'resource "{name}": its values have no common divisor (within 1e-9); '
                f'give one in "quantum", e.g. "quantum": {{"{name}": {_hint(values)}}}'
            )
        q = float(q_exact)
    else:
        q = float(quantum)
    # one vector pass over the values (a street front's 74 parts, a library's
    # hundreds): the same arithmetic as is_multiple and round, element by element
    v = np.asarray(values, dtype=np.float64)
    with np.errstate(over="ignore"):      # 1e308 / 0.2: refused just below
        m = v / q
    if len(m) and not np.all(np.abs(m) < VALUE_QUANTA_MAX):
        worst = float(np.max(np.abs(v)))
        quanta = worst / q
        hint = (f'give a coarser "quantum", e.g. "quantum": {{"{name}": '
                f"{max(worst / 1e4, 1e-9):.2g}}}" if worst <= VALUE_QUANTA_MAX * 1e3 else
                "check the value, which no element plausibly has")
        raise ProblemError(
            f'resource "{name}": with a quantum of {q:g}, its value {worst:g} is '
            f"{quanta_text(quanta)} (at most {VALUE_QUANTA_MAX:.0e}); {hint}")
    near = np.rint(m)   # round half to even, as round() does
    ints = near.astype(np.int64).tolist()
    values_exact = bool(np.all(np.abs(m - near) <= TOL * np.maximum(1.0, np.abs(m))))
    max_err = 0.0 if values_exact or not len(v) else float(np.max(np.abs(v - near * q)))
    exact = values_exact and is_multiple(lo, q) and is_multiple(hi, q)
    qlo, qhi = bounds_in_quanta(lo, hi, q)
    return Quantisation(name, q, exact, max_err, qlo, qhi, (lo, hi)), ints


def bounds_in_quanta(lo: float, hi: float, q: float) -> tuple[int, int]:
    """[lo, hi] in multiples of q, rounded inward (a quantised total inside them
    never breaks the asked interval), within +-2**62 quanta: a bound past that (1e20
    doors) is no bound at all, and the tables hold int64."""
    return _capped(lo / q, math.ceil, -1.0), _capped(hi / q, math.floor, 1.0)


def _capped(m: float, to_int, toward: float) -> int:
    """m quanta rounded by ``to_int`` after allowing the tolerance ``toward`` it, within
    +-2**62 (also when m overflowed to infinity: 1e308 m in 0.2 m quanta). The
    tolerance is for the float error of m = bound / quantum: 1e-9 of m, but at most
    :data:`SLACK_QUANTA` of a quantum (or a few of m's last bits, where they are
    coarser): 1e-9 of 2e9 quanta (1e7 m in 0.005 m quanta) was two whole quanta, and an
    equality of 1e7 m took sequences of 10,000,000.01 m."""
    if not abs(m) < QUANTA_CAP:
        return QUANTA_CAP if m > 0 else -QUANTA_CAP
    slack = min(TOL * max(1.0, abs(m)), max(SLACK_QUANTA, 8 * math.ulp(m)))
    return max(-QUANTA_CAP, min(QUANTA_CAP, to_int(m + toward * slack)))


SLACK_QUANTA = 1e-6   # quanta: far above the float error of bound / quantum
