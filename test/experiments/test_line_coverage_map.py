"""The rule that lets a mutant run only the tests that execute its line (fic_teleop_experiments/tools/
line_coverage_map.py): a mutant that runs at import time runs every test, one on a line no test executes survives
without a pytest run, and one on any other line runs exactly the tests that execute it (widened to a file's tests
only where a fixture shares state among them). The map is built here for real, under coverage, from a small
fic_core and test/core of our own, so a broken context plugin or a misread coverage file fails too."""
from __future__ import annotations

import ast
import subprocess
import textwrap
from pathlib import Path

import pytest

from fic_teleop_experiments.tools import line_coverage_map, random_mutation
from fic_teleop_experiments.tools.line_coverage_map import ALL, NONE, TESTS, LineMap, Selection, selection

LAW = '''\
OFFSET = 2.0 + 1.0


def scaled(gain=1.0 + 1.0):
    return gain * 3.0


class Gain:
    scale = 3 * 2

    def doubled(self, value):
        return 2 * value


def shared_start():
    return 5 - 1


def never_called(value):
    return value / 2
'''

TEST_LAW = '''\
import pytest

from fic_core.law import Gain, scaled, shared_start


@pytest.fixture(scope="module")
def shared():
    return shared_start()


def test_doubled():
    assert Gain().doubled(2) == 4


def test_shared_a(shared):
    assert shared == 4


def test_shared_b(shared):
    assert shared == 4


def test_scaled():
    assert scaled() == 6.0
'''

TEST_OTHER = '''\
from fic_core.law import Gain


def test_doubled_again():
    assert Gain().doubled(3) == 6


def test_nothing_of_the_law():
    assert 1 + 1 == 2
'''


def _line(source: str, text: str) -> int:
    return next(number for number, line in enumerate(source.splitlines(), 1) if text in line)


def _node(source: str, text: str, kind: type) -> tuple[ast.AST, ast.AST]:
    """(the module's tree, the first node of ``kind`` on the line holding ``text``)."""
    tree = ast.parse(source)
    line = _line(source, text)
    return tree, next(node for node in ast.walk(tree) if isinstance(node, kind) and node.lineno == line)


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> LineMap:
    """The map of a tree with fic_core/fic_core/law.py and two test files, built by the tool's own run."""
    root = tmp_path_factory.mktemp("tree")
    (root / "fic_core" / "fic_core").mkdir(parents=True)
    (root / "fic_core" / "fic_core" / "__init__.py").write_text("")
    (root / "fic_core" / "fic_core" / "law.py").write_text(LAW)
    (root / "test" / "core").mkdir(parents=True)
    (root / "test" / "core" / "test_law.py").write_text(TEST_LAW)
    (root / "test" / "core" / "test_other.py").write_text(TEST_OTHER)
    (root / "pytest.ini").write_text("[pytest]\ntestpaths = test\n")
    line_map, result = line_coverage_map.build(root, 120.0)
    assert line_map is not None, result.stdout[-2000:] + result.stderr[-2000:]
    return line_map


def _ids(line_map: LineMap, line: int) -> set[str]:
    entry = line_map.lines["law.py"][line]
    assert entry != ALL, line
    return {line_map.tests[index] for index in entry}


def test_a_line_run_in_one_test_selects_exactly_the_tests_that_run_it(built: LineMap) -> None:
    line = _line(LAW, "return 2 * value")
    assert _ids(built, line) == {"test/core/test_law.py::test_doubled", "test/core/test_other.py::test_doubled_again"}
    tree, node = _node(LAW, "return 2 * value", ast.BinOp)
    chosen = selection(built, "law.py", tree, node)
    assert chosen.kind == TESTS
    assert set(chosen.tests) == _ids(built, line)


def test_a_line_run_by_a_shared_fixture_selects_every_test_of_its_file(built: LineMap) -> None:
    """shared_start runs once, in test_shared_a's setup; test_shared_b reads what it made without running it."""
    assert _ids(built, _line(LAW, "return 5 - 1")) == {f"test/core/test_law.py::{name}" for name in
                                                        ("test_doubled", "test_shared_a", "test_shared_b",
                                                         "test_scaled")}


def test_a_line_no_test_runs_is_absent_and_selects_none(built: LineMap) -> None:
    assert _line(LAW, "return value / 2") not in built.lines["law.py"]
    tree, node = _node(LAW, "return value / 2", ast.BinOp)
    assert selection(built, "law.py", tree, node) == Selection(NONE, why="no test executes this line")


def test_what_runs_at_import_selects_every_test(built: LineMap) -> None:
    """Module level, a class body, a default argument: every test sees what they define, whatever the map says of
    their lines (the import ran them outside any test, or inside whichever test imported first)."""
    for text, kind in (("OFFSET = 2.0 + 1.0", ast.BinOp), ("scale = 3 * 2", ast.BinOp),
                       ("def scaled(gain=1.0 + 1.0)", ast.BinOp)):
        tree, node = _node(LAW, text, kind)
        assert selection(built, "law.py", tree, node).kind == ALL, text
        # Even a map that names one test for the line (a lazy import inside that test) does not narrow it.
        narrow = LineMap(built.tree, built.tests, {"law.py": {node.lineno: (0,)}})
        assert selection(narrow, "law.py", tree, node).kind == ALL, text
    tree, node = _node(LAW, "return gain * 3.0", ast.BinOp)   # the function's body: only when called
    assert selection(built, "law.py", tree, node).kind == TESTS


def test_contexts_outside_a_test_or_in_a_fixture_widen_and_a_call_does_not() -> None:
    tests = [{"id": "test/core/test_a.py::test_1", "shared": {"robot": "module"}},
             {"id": "test/core/test_a.py::test_2", "shared": {}},
             {"id": "test/core/test_a.py::test_3", "shared": {"robot": "module"}},
             {"id": "test/core/test_b.py::test_1", "shared": {"robot": "module", "world": "session"}},
             {"id": "test/core/test_c.py::test_1", "shared": {"world": "session"}},
             {"id": "test/core/test_c.py::test_2", "shared": {}}]
    line_map = line_coverage_map.line_map_from("t", tests, {"m.py": {
        1: [""],                                                    # importing or collecting
        2: ["test/core/test_a.py::test_2|setup"],                   # a fixture: the file's tests
        3: ["test/core/test_a.py::test_2|run", "test/core/test_c.py::test_2|run"],
        4: ["test/core/test_a.py::test_1|run"],                     # shares robot (module) with test_3 only
        5: ["test/core/test_b.py::test_1|run"],                     # shares world (session) with test_c's test_1
        6: ["test/core/test_b.py::test_1|setup"],                   # may set up the session's world
        7: ["test/core/test_c.py::test_2|teardown"],                # the last test: the session's fixtures end
    }})
    assert line_map.lines["m.py"] == {1: ALL, 2: (0, 1, 2), 3: (1, 5), 4: (0, 2), 5: (3, 4), 6: ALL, 7: ALL}


def test_a_mutant_no_test_executes_survives_without_a_pytest_run(monkeypatch) -> None:
    monkeypatch.setattr(random_mutation, "_pytest", lambda *arguments: pytest.fail("pytest ran"))
    site = next(site for site in random_mutation.all_sites() if site.module == "limits.py")
    verdict, detail, seconds, _ = random_mutation.run_mutant(site, 60.0, chosen=Selection(NONE, why="no test "
                                                                                           "executes this line"))
    assert (verdict, detail, seconds) == ("SURVIVED", "no test executes this line", 0.0)


def test_a_selected_mutant_runs_exactly_its_tests_the_direct_importers_first(monkeypatch) -> None:
    runs: list[list] = []

    def passing(root: Path, folder: str, tests: list, timeout: float) -> subprocess.CompletedProcess:
        runs.append(list(tests))
        return subprocess.CompletedProcess(["pytest"], 0, "passed", "")

    monkeypatch.setattr(random_mutation, "_pytest", passing)
    site = next(site for site in random_mutation.all_sites() if site.module == "limits.py")
    direct, _ = random_mutation.test_files("limits.py")
    outsider = sorted(path for path in (random_mutation.TESTS).glob("test_*.py") if path not in direct)[0]
    first = f"{direct[0].relative_to(random_mutation.REPO)}::test_x"
    last = f"{outsider.relative_to(random_mutation.REPO)}::test_y"
    verdict, *_ = random_mutation.run_mutant(site, 60.0, chosen=Selection(TESTS, (last, first)))
    assert verdict == "SURVIVED"
    assert runs == [[first, last]]   # one run, these two ids and no other, the importer's first


def test_a_draw_runs_each_mutant_with_its_selection_and_reads_a_stored_map(monkeypatch, tmp_path: Path) -> None:
    sites = [site for site in random_mutation.all_sites() if site.module == "limits.py"][:2]
    stored = LineMap("h", ("test/core/test_limits.py::test_a",), {})
    monkeypatch.setattr(random_mutation, "snapshot", lambda commit, folder: random_mutation.REPO)
    monkeypatch.setattr(line_coverage_map, "cached", lambda root, cache: stored)
    monkeypatch.setattr(line_coverage_map, "build", lambda root, timeout: pytest.fail("the map was rebuilt"))
    monkeypatch.setattr(random_mutation, "baseline", lambda root, timeout: pytest.fail("baseline ran again"))
    monkeypatch.setattr(random_mutation, "sample", lambda seed, size, module, root, modules=None: sites)
    monkeypatch.setattr(random_mutation, "equivalent_mutants", lambda: {})
    seen = []

    def judged(site, timeout, root, chosen):
        seen.append(chosen.kind)
        return "SURVIVED", chosen.why or "every test passed", 0.0, 0.0

    monkeypatch.setattr(random_mutation, "run_mutant", judged)
    result = random_mutation.run(2, 2, 60.0, out=tmp_path / "out.json", echo=lambda text: None)
    assert result["tests"] == "the tests that execute the mutated line"
    # An empty map: a mutant in a function body selects no test, one at import time every test.
    tree = ast.parse((random_mutation.PACKAGE / "limits.py").read_text())
    nodes = list(ast.walk(tree))
    expected = [ALL if line_coverage_map.definition_time(tree, nodes[site.node]) else NONE for site in sites]
    assert seen == expected


def test_lines_of_a_site_span_its_statement_head_to_its_own_end() -> None:
    source = textwrap.dedent('''\
        def f(a, b):
            value = (a +
                     b * 2)
            return value
        ''')
    tree, node = _node(source, "b * 2", ast.BinOp)
    assert list(line_coverage_map.site_lines(tree, node)) == [2, 3]
