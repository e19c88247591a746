import json

import pytest

from citysynth.solver import Problem, ProblemError

BASE = {
    "resources": ["length", "doors"],
    "elements": [{"id": "A", "resources": {"length": 4.0, "doors": 1}},
                 {"id": "B", "resources": {"length": 6.2}}],
    "transitions": [["A", "B", 0.5]],
    "constraints": {"length": [10.2, 10.2]},
}


def with_(**kw):
    d = json.loads(json.dumps(BASE))
    d.update(kw)
    return d


@pytest.mark.parametrize("data, fragment", [
    (with_(colour="red"), 'unknown key(s) "colour"; allowed keys are'),
    (with_(resources=[]), '"resources" must be a non-empty list'),
    # names that print as no letter: solve wrote them raw (a line break split the
    # sequence's line, an escape recoloured the terminal, U+202E reversed the text)
    (with_(elements=[{"id": "A\nB", "resources": {"length": 1}}]),
     'elements[0].id: the id "A\\nB" holds a character that prints as no letter (U+000A'),
    (with_(elements=[{"id": "A", "resources": {"length": 1}},
                     {"id": "B\u202eevil", "resources": {"length": 1}}]),
     'elements[1].id: the id "B\\u202eevil" holds a character that prints as no letter '
     "(U+202E"),
    (with_(resources=["length", "do\x1b[31mors"]),
     'resources[1]: a resource\'s name "do\\u001b[31mors" holds a character'),
    (with_(elements=[{"id": "A", "resources": {"length": 1}},
                     {"id": "A", "resources": {"length": 2}}]), 'duplicate element id "A"'),
    (with_(elements=[{"id": "A", "resources": {"length": -1}}]),
     "elements[0].resources.length: must be >= 0"),
    (with_(elements=[{"id": "A", "resources": {"height": 1}}]),
     "elements[0].resources.height: unknown resource"),
    (with_(elements=[{"id": "A", "resources": {"length": 1}, "cost": float("nan")}]),
     "elements[0].cost: expected a finite number"),
    (with_(transitions=[["A", "Z", 1.0]]), "transitions[0]: unknown to element 'Z'"),
    (with_(transitions=[["A", "B"]]), "transitions[0]: must be [from_id, to_id, cost]"),
    (with_(transitions=[["A", "B", 1], ["A", "B", 2]]), "duplicate transition"),
    (with_(transitions=[["A", "B", -1]]), "transitions[0] cost: must be >= 0"),
    (with_(constraints={"length": [5, 4]}), "min 5 is greater than max 4"),
    (with_(constraints={}), "no constraints"),
    (with_(constraints={"width": [1, 2]}), "constraints.width: unknown resource"),
    (with_(front=[]), '"front" must be a non-empty list'),
    (with_(back=["Q"]), "back: unknown element 'Q'"),
    (with_(k=0), '"k" must be a positive integer'),
    (with_(quantum={"length": 0}), "quantum.length: must be > 0"),
    (with_(quantum={"length": -0.1}), "quantum.length: must be > 0"),   # not ">= 0"
    # a cost of 1e308 summed to infinity; a 1e-18 quantum overflowed the tables
    (with_(elements=[{"id": "A", "resources": {"length": 1}, "cost": 1e308}]),
     "elements[0].cost: must be <= 1e+15"),
    (with_(transitions=[["A", "B", 1e300]]), "transitions[0] cost: must be <= 1e+15"),
    # an amount of a resource no constraint bounds overflowed the totals (a traceback)
    (with_(elements=[{"id": "A", "resources": {"length": 4.0, "doors": 1.7e308}},
                     {"id": "B", "resources": {"length": 6.2}}]),
     "elements[0].resources.doors: must be <= 1e+15 (an amount this large"),
])
def test_bad_input_names_the_place(data, fragment):
    with pytest.raises(ProblemError) as exc:
        Problem.from_dict(data)
    assert fragment in str(exc.value)


@pytest.mark.parametrize("data, said", [
    (with_(constraints={"length": None}), "got null"),
    (with_(constraints={"length": {"min": 1, "max": 2}}), 'got {"min": 1, "max": 2}'),
    (with_(elements=[{"id": "A", "resources": {"length": 4.0}, "cost": "0"}]), 'got "0"'),
    (with_(elements=[{"id": "A", "resources": {"doors": True}}]), "got true"),
    (with_(constraints={"zz": [1, 2]}), "resources are length, doors"),
])
def test_values_are_quoted_as_the_file_spells_them(data, said):
    """A value in a message reads as JSON writes it (null, true, "0", {"min": 1}), and a
    list of names as a list: not Python's None, True, '0', {'min': 1} or ['length',
    'doors'] (found by a probe on 2026-11-30)."""
    with pytest.raises(ProblemError) as e:
        Problem.from_dict(data)
    assert said in str(e.value)
    assert not any(w in str(e.value) for w in ("None", "True", "'"))


def test_defaults():
    p = Problem.from_dict(BASE)
    assert p.front == ("A", "B") and p.back == ("A", "B") and p.k == 1
    assert p.elements[1].resources == {"length": 6.2, "doors": 0.0}
    assert p.elements[1].cost == 0.0
    assert Problem.from_dict(p.to_dict()) == p


def test_load_reports_file_and_position(tmp_path):
    f = tmp_path / "broken.json"
    f.write_text('{"resources": ["length"],\n "elements": [}')
    with pytest.raises(ProblemError) as exc:
        Problem.load(f)
    assert str(f) in str(exc.value) and "line 2" in str(exc.value)
    with pytest.raises(ProblemError, match="cannot read the problem file"):
        Problem.load(tmp_path / "missing.json")


def test_a_quantum_far_too_fine_is_refused_with_a_coarser_one_to_try():
    from citysynth.solver import solve
    p = Problem.from_dict(with_(quantum={"length": 1e-18}))
    with pytest.raises(ProblemError) as exc:
        solve(p)
    assert 'resource "length": with a quantum of 1e-18' in str(exc.value)
    assert '"quantum": {"length":' in str(exc.value)
