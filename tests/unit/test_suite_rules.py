"""The suite's own rules (CONTRIBUTING.md, "Tests"), read from its source: no sleep stands for
"long enough for something to happen", and no assert compares a wall-clock duration. A sleep is
allowed where it is one of two things:
- polling, inside a `while` loop that waits for a condition (with a deadline that bounds a hang);
- a signal trial's random moment, said on its line or the line above with "the moment": the delay
  is drawn at random after a line the process printed, and no outcome depends on its length.
A wall clock in an assert is allowed only against a `deadline` (the bound on a hang), or where
its line says it checks "consistency" (a part of a measured time within its whole), not a bound."""

from __future__ import annotations

import ast

from tests.helpers import ROOT
from tests.helpers.scheduling import SHARED_SETUP, unit_of

TESTS = ROOT / "tests"
CLOCKS = {"monotonic", "monotonic_ns", "perf_counter", "perf_counter_ns", "time", "time_ns"}
#: names that hold a duration measured on the wall clock, as tests have called them
DURATION_WORDS = ("took", "elapsed", "wall_s", "wall_time")


def _parents(tree: ast.AST) -> dict[ast.AST, ast.AST]:
    return {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}


def _is_sleep(call: ast.Call) -> bool:
    f = call.func
    return (isinstance(f, ast.Attribute) and f.attr == "sleep") or (isinstance(f, ast.Name) and f.id == "sleep")


def _polls(node: ast.AST, parents: dict[ast.AST, ast.AST]) -> bool:
    """Inside a `while` loop of its own function."""
    while node in parents:
        node = parents[node]
        if isinstance(node, ast.While):
            return True
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            return False
    return False


def _is_clock(node: ast.AST) -> bool:
    return (
        isinstance(node, ast.Call)
        and isinstance(node.func, ast.Attribute)
        and node.func.attr in CLOCKS
        and isinstance(node.func.value, ast.Name)
        and node.func.value.id == "time"
    )


def _names_a_duration(node: ast.AST) -> bool:
    name = node.id if isinstance(node, ast.Name) else node.attr if isinstance(node, ast.Attribute) else ""
    return any(word in name.lower() for word in DURATION_WORDS)


def _against_a_deadline(compare: ast.Compare) -> bool:
    sides = [compare.left, *compare.comparators]
    return any(isinstance(s, ast.Name) and s.id == "deadline" for s in sides)


def broken_rules(source: str) -> list[str]:
    """Each sleep and each wall-clock assert `source` has that the rules above do not allow."""
    tree = ast.parse(source)
    lines = source.splitlines()
    parents = _parents(tree)
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and _is_sleep(node) and not _polls(node, parents):
            said = " ".join(lines[max(0, node.lineno - 2) : node.lineno])
            if "the moment" not in said:
                found.append(f"{node.lineno}: a sleep that is neither polling nor a trial's moment")
        if isinstance(node, ast.Assert) and "consistency" not in lines[node.lineno - 1]:
            for compare in (n for n in ast.walk(node.test) if isinstance(n, ast.Compare)):
                if _against_a_deadline(compare):
                    continue
                sides = [compare.left, *compare.comparators]
                if any(_is_clock(n) or _names_a_duration(n) for side in sides for n in ast.walk(side)):
                    found.append(f"{node.lineno}: an assert on a wall-clock duration")
    return sorted(found, key=lambda line: int(line.split(":")[0]))


def test_no_test_sleeps_for_a_moment_or_asserts_a_wall_clock_duration():
    broken = {
        path.relative_to(TESTS).as_posix(): rules
        for path in sorted(TESTS.rglob("*.py"))
        if (rules := broken_rules(path.read_text()))
    }
    assert not broken, broken


def test_the_rules_see_what_they_forbid():
    """Each shape the rules forbid, as tests once had it, and the shapes they allow."""
    forbidden = """
import time
def test_a():
    proc = start()
    time.sleep(2.0)  # long enough to record something
    assert count(proc) > 60
def test_b():
    t0 = time.monotonic()
    run()
    took = time.monotonic() - t0
    assert took < 20
def test_c():
    t0 = time.perf_counter()
    run()
    assert time.perf_counter() - t0 < 10
def test_d():
    for trial in range(6):
        sleep(0.5)
        send()
"""
    assert [line.split(":")[0] for line in broken_rules(forbidden)] == ["5", "11", "15", "18"]
    allowed = """
import time
def test_a():
    deadline = time.monotonic() + 30
    while not ready():
        assert time.monotonic() < deadline, "never ready"
        time.sleep(0.1)
def test_b():
    wait_for_line(proc, "recording to", 1)
    # the moment: a random delay after the line
    time.sleep(rng.uniform(0.0, 0.5))
    time.sleep(0.2)  # the moment
"""
    assert broken_rules(allowed) == []


def _shares_a_setup(source: str) -> bool:
    """Whether a test file defines a fixture made once for the file (module- or class-scoped)."""
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.FunctionDef):
            for decorator in node.decorator_list:
                if isinstance(decorator, ast.Call) and any(
                    k.arg == "scope" and isinstance(k.value, ast.Constant) and k.value.value in ("module", "class")
                    for k in decorator.keywords
                ):
                    return True
    return False


def test_every_file_with_a_setup_for_all_its_tests_hands_them_out_together():
    """A parallel run gives the tests that share a file's setup to one worker (SHARED_SETUP),
    or each worker that runs one of them would make it again (the signal trials: 170 s of CPU)."""
    sharing = {
        path.relative_to(TESTS).as_posix()
        for kind in ("unit", "integration", "e2e")
        for path in sorted((TESTS / kind).glob("test_*.py"))
        if _shares_a_setup(path.read_text())
    }
    assert sharing == set(SHARED_SETUP)
    assert unit_of("tests/e2e/test_signals.py::test_a") == unit_of("tests/e2e/test_signals.py::test_b")
    assert unit_of("tests/e2e/test_ros2.py::test_a[jazzy-x]") == unit_of("tests/e2e/test_ros2.py::test_b[jazzy-x]")
    assert unit_of("tests/e2e/test_ros2.py::test_a[jazzy-x]") != unit_of("tests/e2e/test_ros2.py::test_a[kilted-x]")
    assert unit_of("tests/unit/test_mixer.py::test_a") != unit_of("tests/unit/test_mixer.py::test_b")
