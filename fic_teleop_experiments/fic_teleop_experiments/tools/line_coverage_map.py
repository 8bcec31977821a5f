"""Which tests of test/core can tell a mutant of fic_core from the original: the tests that execute its line.

random_mutation.py judged each mutant by running test/core until a test failed; a survivor had to pass all of it,
about 120 CPU-s a survivor. But a test that never executes the mutated line runs exactly as on the unmutated tree:
the derandomised suite is deterministic, so up to the first time the line runs, the mutant and the original take
the same steps, and a test that does not reach the line on the original does not reach it on the mutant either.
So one run of test/core under coverage.py, each test's setup, call and teardown recorded as a context of its own,
gives the map "source line of fic_core -> the tests that execute it", and a mutant needs only those tests.

The rule (``selection``), sound by construction:

- a mutant outside every function body (module level, class bodies, decorators, default arguments) changes what
  the module defines when it is imported, which every test sees: every test runs;
- a line executed outside any test (importing a test file, collecting its parameters, its module-level objects):
  every test runs, as every test may hold what it made;
- a line executed while a test's fixtures were set up or torn down: every test of that file runs (a module-scoped
  fixture, such as conftest's ``robot`` and ``limits``, is shared by the file's tests), every test when the test
  reaches a session- or package-scoped fixture (shared across files) or is the last to run (its teardown ends
  the session's fixtures);
- a line executed in a test's call: that test, the tests of its file that share a module- or class-scoped fixture
  with it, and the tests anywhere that share a session- or package-scoped one (an object such a fixture hands
  out may keep what the line computed, as ``PandaLimits``' cached properties do, and the next test reads it
  without executing the line);
- a line no test executes: the mutant survives without a pytest run, as no test can see it.

The map is built once per tree: the hash of what decides it (fic_core's modules, test/conftest.py, test/core,
pytest.ini, this module, the Python version) names its file in ``CACHE``, so a resumed draw reads it instead of
running test/core again. The build is a run of test/core on the unmutated tree, so it is also that tree's baseline:
a map is written only when every test passed.
"""
from __future__ import annotations

import ast
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import coverage

from fic_teleop_experiments.tools.mutation_verdict import SETTINGS_PLUGIN, settings_plugin_text, write_settings_plugin

#: The name of the pytest plugin that marks each test's phases as coverage contexts (written beside the copy of
#: fic_core, like mutation_verdict's settings plugin).
CONTEXT_PLUGIN = "fic_line_contexts"

#: Where the maps are kept, under the repository (gitignored): one JSON per tree hash.
CACHE = Path(".cache") / "line_coverage_map"

#: Fixture scopes whose one value several test files share.
_ACROSS_FILES = ("session", "package")

ALL = "all"
TESTS = "tests"
NONE = "none"

#: What the plugin records: the test ids in the order they ran and, per test, its fixtures wider than one test.
_PLUGIN_TEXT = '''"""Each test's setup, call and teardown as a coverage context of its own ("<test id>|setup" and
so on); what runs between tests, importing and collecting included, keeps the empty context."""
import json
import os

import coverage
import pytest

_COVERAGE = coverage.Coverage.current()
_TESTS = []


def _switch(name):
    if _COVERAGE is not None:
        _COVERAGE.switch_context(name)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_setup(item):
    shared = {name: definitions[-1].scope for name, definitions in item._fixtureinfo.name2fixturedefs.items()
              if definitions and definitions[-1].scope != "function"}
    _TESTS.append({"id": item.nodeid, "shared": shared})
    _switch(item.nodeid + "|setup")
    yield


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_call(item):
    _switch(item.nodeid + "|run")
    yield


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_teardown(item, nextitem):
    _switch(item.nodeid + "|teardown")
    yield
    _switch("")


def pytest_sessionfinish(session, exitstatus):
    with open(os.environ["FIC_LINE_CONTEXTS_TESTS"], "w") as handle:
        json.dump(_TESTS, handle)
'''


@dataclass(frozen=True)
class Selection:
    """What a mutant runs: ALL (every test), TESTS (``tests``, test ids in test/core's order) or NONE."""
    kind: str
    tests: tuple[str, ...] = ()
    why: str = ""


@dataclass(frozen=True)
class LineMap:
    """``tests``: every test id of test/core in run order; ``lines``: module file name -> source line -> the
    indices (into ``tests``) that must run for a mutant there, or ALL."""
    tree: str
    tests: tuple[str, ...]
    lines: dict[str, dict[int, str | tuple[int, ...]]]


def tree_hash(root: Path) -> str:
    """SHA-256 of everything the map depends on, in the tree at ``root``."""
    digest = hashlib.sha256()
    files = sorted([*(root / "fic_core" / "fic_core").glob("*.py"), root / "test" / "conftest.py",
                    root / "pytest.ini", *(path for path in (root / "test" / "core").rglob("*") if path.is_file()
                                           and "__pycache__" not in path.parts)])
    for path in files:
        if path.exists():
            digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes() + b"\0")
    digest.update(Path(__file__).read_bytes() + settings_plugin_text(True, True).encode() + sys.version.encode())
    return digest.hexdigest()


def definition_time(tree: ast.AST, node: ast.AST) -> bool:
    """Whether ``node`` runs when its module is imported rather than when a function is called: it is outside
    every function and lambda body (module level, a class body, a decorator, a default argument). The decorators
    and defaults of a function nested in another one's body run when the outer function is called: not here."""
    parents = {id(child): parent for parent in ast.walk(tree) for child in ast.iter_child_nodes(parent)}
    child = node
    while id(child) in parents:
        parent = parents[id(child)]
        if isinstance(parent, (ast.FunctionDef, ast.AsyncFunctionDef)) and any(child is item for item in parent.body):
            return False
        if isinstance(parent, ast.Lambda) and child is parent.body:
            return False
        child = parent   # a decorator, a default, a class body: runs when the enclosing scope runs
    return True


def site_lines(tree: ast.AST, node: ast.AST) -> range:
    """The source lines whose execution shows ``node`` ran: from the first line of its innermost statement to its
    own last line (the interpreter reports a line when an instruction of it runs, and the node's instructions lie
    on its own lines; a multi-line statement may report only some of them)."""
    parents = {id(child): parent for parent in ast.walk(tree) for child in ast.iter_child_nodes(parent)}
    statement = node
    while not isinstance(statement, ast.stmt) and id(statement) in parents:
        statement = parents[id(statement)]
    first = getattr(statement, "lineno", node.lineno)
    return range(min(first, node.lineno), max(node.end_lineno or node.lineno, node.lineno) + 1)


def selection(line_map: LineMap, module: str, tree: ast.AST, node: ast.AST) -> Selection:
    """The tests a mutant of ``node`` (in ``module``'s parsed ``tree``) runs: the rule of this module's
    docstring."""
    if definition_time(tree, node):
        return Selection(ALL, why="runs when the module is imported")
    executed = line_map.lines.get(module, {})
    chosen: set[int] = set()
    for line in site_lines(tree, node):
        tests = executed.get(line)
        if tests == ALL:
            return Selection(ALL, why=f"line {line} runs outside a single test")
        chosen.update(tests or ())
    if not chosen:
        return Selection(NONE, why="no test executes this line")
    return Selection(TESTS, tuple(line_map.tests[index] for index in sorted(chosen)))


def _test_file(test_id: str) -> str:
    return test_id.split("::")[0]


def line_map_from(tree: str, tests: list[dict], contexts_by_line: dict[str, dict[int, list[str]]]) -> LineMap:
    """The map from what the coverage run recorded: ``tests`` (the plugin's list, in run order: id and the scope
    of each fixture wider than one test it reaches), ``contexts_by_line`` (module file name -> line -> its
    contexts, "" for none)."""
    ids = [test["id"] for test in tests]
    index = {test_id: number for number, test_id in enumerate(ids)}
    by_file: dict[str, list[int]] = {}
    for number, test_id in enumerate(ids):
        by_file.setdefault(_test_file(test_id), []).append(number)
    sharing: dict[int, set[int]] = {}
    reaches_across: set[int] = set()   # tests that reach a fixture shared across files
    for number, test in enumerate(tests):
        within = {name for name, scope in test["shared"].items() if scope not in _ACROSS_FILES}
        across = {name for name, scope in test["shared"].items() if scope in _ACROSS_FILES}
        if across:
            reaches_across.add(number)
        sharing[number] = {number} | {other for other in by_file[_test_file(test["id"])]
                                      if within & set(tests[other]["shared"])}
        sharing[number] |= {other for other in range(len(tests)) if across & set(tests[other]["shared"])}
    lines: dict[str, dict[int, str | tuple[int, ...]]] = {}
    for module, by_line in contexts_by_line.items():
        table = lines.setdefault(module, {})
        for line, contexts in by_line.items():
            chosen: set[int] = set()
            for context in contexts:
                test_id, _, phase = context.rpartition("|")
                if not context or test_id not in index:   # outside a test: importing, collecting
                    chosen = None
                    break
                if phase == "run":
                    chosen |= sharing[index[test_id]]
                elif index[test_id] in reaches_across or index[test_id] == len(ids) - 1:
                    chosen = None                          # a fixture shared across files, or the session's end
                    break
                else:                                      # a fixture's setup or teardown: the file's tests
                    chosen.update(by_file[_test_file(test_id)])
            table[line] = ALL if chosen is None else tuple(sorted(chosen))
    return LineMap(tree, tuple(ids), lines)


def cached(root: Path, cache: Path) -> LineMap | None:
    """The map of the tree at ``root`` when ``cache`` holds it."""
    tree = tree_hash(root)
    path = cache / f"{tree}.json"
    if not path.exists():
        return None
    return _loaded(json.loads(path.read_text()))


def _loaded(stored: dict) -> LineMap:
    return LineMap(stored["tree"], tuple(stored["tests"]),
                   {module: {int(line): (tests if tests == ALL else tuple(tests)) for line, tests in by_line.items()}
                    for module, by_line in stored["lines"].items()})


def build(root: Path, timeout: float) -> tuple[LineMap | None, subprocess.CompletedProcess]:
    """test/core on the unmutated tree at ``root`` under coverage, with the derandomised settings every mutant's
    run has (the same examples; no deadline, as coverage slows a test, which changes no example): (its map, or None
    when a test failed; the pytest process). Raises subprocess.TimeoutExpired past ``timeout`` seconds."""
    tree = tree_hash(root)
    with tempfile.TemporaryDirectory(prefix="fic_line_map_") as folder:
        shutil.copytree(root / "fic_core" / "fic_core", Path(folder) / "fic_core",
                        ignore=shutil.ignore_patterns("__pycache__"))
        write_settings_plugin(Path(folder), derandomize=True, timing_free=True)
        (Path(folder) / f"{CONTEXT_PLUGIN}.py").write_text(_PLUGIN_TEXT)
        data_file, tests_file = Path(folder) / "coverage.data", Path(folder) / "tests.json"
        env = dict(os.environ, PYTHONPATH=folder + os.pathsep + os.environ.get("PYTHONPATH", ""),
                   PYTHONDONTWRITEBYTECODE="1", FIC_TELEOP_ROOT=str(root), FIC_LINE_CONTEXTS_TESTS=str(tests_file))
        command = [sys.executable, "-m", "coverage", "run", f"--data-file={data_file}",
                   f"--source={Path(folder) / 'fic_core'}", "-m", "pytest", "-p", "no:cacheprovider",
                   "-p", SETTINGS_PLUGIN, "-p", CONTEXT_PLUGIN, "-x", "-q", "-rfE", f"--timeout={int(timeout)}",
                   str(root / "test" / "core")]
        result = subprocess.run(command, env=env, capture_output=True, text=True, cwd=root,
                                timeout=max(timeout, 1.0))
        if result.returncode != 0:
            return None, result
        data = coverage.CoverageData(basename=str(data_file))
        data.read()
        contexts_by_line = {Path(path).name: {line: list(contexts) for line, contexts in
                                              data.contexts_by_lineno(path).items()}
                            for path in data.measured_files()
                            if Path(path).parent == Path(folder) / "fic_core"}
        line_map = line_map_from(tree, json.loads(tests_file.read_text()), contexts_by_line)
    return line_map, result


def store(line_map: LineMap, cache: Path) -> Path:
    """Write ``line_map`` to ``cache`` under its tree hash."""
    cache.mkdir(parents=True, exist_ok=True)
    path = cache / f"{line_map.tree}.json"
    path.write_text(json.dumps({"tree": line_map.tree, "tests": list(line_map.tests),
                                "lines": {module: {str(line): (tests if tests == ALL else list(tests))
                                                   for line, tests in by_line.items()}
                                          for module, by_line in line_map.lines.items()}}) + "\n")
    return path
