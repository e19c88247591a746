"""Human-readable rendering of solver results for the terminal."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from citysynth.solver import Result


def _num(x: float) -> str:
    return f"{round(x, 6):g}"


def format_result(result: Result, *, strip_resource: str | None = "length") -> str:
    """The status, each solution (cost, resource totals, sequence) and the stats."""
    st = result.stats
    lines = [f"status: {result.status}  (method {st.get('method')}, k={st.get('k')})"]
    if result.status != "ok":
        lines.append(f"reason: {result.reason}")
    for i, sol in enumerate(result.solutions, 1):
        res = ", ".join(f"{k} {_num(v)}" for k, v in sol.resources.items())
        lines.append(f"#{i:<3} cost {_num(sol.cost):<10} {res}")
        lines.append("     " + " ".join(sol.sequence))
    timing = (f"setup {1e3 * st.get('setup_s', 0):.2f} ms, "
              f"solve {1e3 * st.get('solve_s', 0):.2f} ms")
    lines.append(f"graph: {st.get('nodes', 0):,} nodes kept of "
                 f"{st.get('nodes_generated', st.get('nodes', 0)):,}; {timing}")
    return "\n".join(lines)
