"""Ctrl-C or SIGTERM that lands in numba's dispatcher (its Python code around a kernel
call) surfaces as a SystemError caused by the KeyboardInterrupt. The solver's drivers
raise it as the KeyboardInterrupt it is, and the command line stops with "interrupted"
(exit 130) or "terminated" (143), never "internal error" (exit 3, a traceback): seen
once in CI, where the Ctrl-C test's alarm fired while numba unpickled a kernel."""

from __future__ import annotations

import pytest

from citysynth.pipeline.city.process import Terminated
from citysynth.pipeline.cli import main
from citysynth.pipeline.commands import solve as solve_command
from citysynth.solver.interrupts import interrupt_in, kernel_calls


def _wrapped(signal: KeyboardInterrupt) -> SystemError:
    """What numba's dispatcher raises when a signal handler raised in its Python code."""
    try:
        try:
            raise signal
        except KeyboardInterrupt as exc:
            raise SystemError("returned a result with an exception set") from exc
    except SystemError as err:
        return err


def test_interrupt_in_follows_causes_and_contexts():
    stop = KeyboardInterrupt()
    assert interrupt_in(_wrapped(stop)) is stop
    assert interrupt_in(stop) is stop
    try:
        try:
            raise stop
        except KeyboardInterrupt:
            raise ValueError("while handling it") from None   # handled: suppressed
    except ValueError as exc:
        assert interrupt_in(exc) is None
    try:
        try:
            raise stop
        except KeyboardInterrupt:
            raise ValueError("while handling it")              # noqa: B904 - context
    except ValueError as exc:
        assert interrupt_in(exc) is stop
    assert interrupt_in(SystemError("a real one")) is None


def test_kernel_calls_raise_the_signal_itself():
    for signal in (KeyboardInterrupt(), Terminated()):
        with pytest.raises(type(signal)) as caught, kernel_calls():
            raise _wrapped(signal)
        assert caught.value is signal
    with pytest.raises(SystemError, match="a real one"), kernel_calls():
        raise SystemError("a real one")


@pytest.mark.parametrize("signal, code, word", [(KeyboardInterrupt(), 130, "interrupted"),
                                                (Terminated(), 143, "terminated")])
def test_the_command_line_says_stopped_not_internal_error(monkeypatch, capsys, tmp_path,
                                                          signal, code, word):
    def stopped(args):
        raise _wrapped(signal)
    monkeypatch.setattr(solve_command, "_run", stopped)
    problem = tmp_path / "p.json"
    problem.write_text("{}")
    assert main(["solve", str(problem)]) == code
    err = capsys.readouterr().err
    assert err.strip() == f"citysynth: {word}" and "Traceback" not in err


def test_ctrl_c_stops_the_intermediate_graph_while_it_grows(monkeypatch):
    """rcksp grows its intermediate graph in one compiled call (seconds on a wide
    three-resource street), run in a thread the main thread waits on in short slices
    (solver.interrupts.in_background): SIGINT, here an alarm raising
    KeyboardInterrupt 0.1 s into the growth, stops the solve while the growth still
    runs. Before, the kernel held the signal until the graph was grown."""
    import signal
    import threading

    from citysynth.solver import Problem, graph, solve
    from citysynth.solver.samples import street_front

    solve(Problem.from_dict(street_front(20, resources=3)), k=5, method="rcksp")  # compiled
    kernel = graph._grow
    where: list[threading.Thread] = []
    done = threading.Event()

    def alarmed(*args):
        where.append(threading.current_thread())
        signal.setitimer(signal.ITIMER_REAL, 0.1)
        try:
            return kernel(*args)
        finally:
            done.set()
    monkeypatch.setattr(graph, "_grow", alarmed)

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGALRM, interrupt)
    try:
        with pytest.raises(KeyboardInterrupt):
            solve(Problem.from_dict(street_front(120, resources=3)), k=1000, method="rcksp")
        assert where[0] is not threading.main_thread()
        assert not done.is_set()    # stopped while the graph was still growing
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    # let it end, so no other test shares the machine with it (not Thread.join: a
    # join interrupted by a signal marks the thread stopped, bpo-45274's fix)
    assert done.wait(120)
