"""Seeded random mutation testing over fic_core, against test/core alone; scored only on held-out draws.

mutation_check.py breaks the laws in hand-picked ways; this breaks them at random. Every place in
fic_core where an operator or a number can be flipped is a *site*:

- comparison: ``<`` to ``>=`` (negated) and to ``<=`` (boundary moved), likewise ``<=``, ``>``, ``>=``; ``==`` and
  ``!=`` swapped; ``is``/``is not`` and ``in``/``not in`` swapped;
- arithmetic: ``+`` and ``-`` swapped, ``*`` and ``/`` swapped, ``**`` to ``*``, ``//`` to ``/``, ``%`` to ``//``
  (also in ``x += y`` and the like);
- boolean: ``and`` and ``or`` swapped, a ``not`` dropped, ``True`` and ``False`` swapped;
- constant: a number ``c`` to ``c + 1`` (off by one);
- sign: a unary minus dropped.

Left out: type annotations, the text of exception messages and f-strings (what a refusal says, not what it
decides), and ``__all__``. A seed picks ``--sample`` sites out of all of them: those with the smallest SHA-256 of
the seed and the site's key (below), so that a run is repeatable, its sample is not hand-picked, and a change in
one module leaves the sample elsewhere as it was. Mutants and tests come from a commit (``git archive``, HEAD by
default), not from the work tree, which other work may be changing; test/core must pass on that commit unmutated
before any mutant counts. Each mutant is the module parsed, the one node changed, and written back with
``ast.unparse`` into a copy of fic_core (the work tree is never touched); the tests are those of test/core that
execute the mutated line on the unmutated tree (line_coverage_map.py, whose rule widens that set wherever a test
could see the mutant without executing the line, and lets a mutant no test executes survive unrun), those in the
files importing the module first, with ``-x`` and a timeout (a hang counts as killed). With ``--full-suite``, the
files of test/core that import the mutated module run first, then the rest, so a survivor has passed the whole of
test/core. Equivalent mutants (no behaviour can tell them from
the original) are listed with a reason in ``equivalent_mutants.yaml`` beside this file, keyed by module,
enclosing function, source line and mutation so that the key survives code moving up or down; they are not run
and do not count in the kill rate.

Scores come only from held-out draws. ``mutation_seeds.yaml`` beside this file records two sets of seeds that never
meet: the fitting seeds, whose survivors were read to write tests (their kill rate is reported as a fit, not a
score: it measures how well the tests fit that draw), and the held-out seeds, kept for scoring (their survivors are
reported, never used to write tests; survivors to write tests from come from fitting seeds). ``--held-out`` runs
every held-out seed, one JSON each, and prints the kill rate per law module over all of them; ``--seed fresh``
draws a seed in neither set. ``--law`` draws from the control-law modules only (``LAW_MODULES``), where the score
is wanted; the result gives the kill rate per module either way.

    source scripts/env.sh && python -m fic_teleop_experiments.tools.random_mutation --seed 1 --sample 60 [--out F]
    python -m fic_teleop_experiments.tools.random_mutation --law --held-out --out-dir results   # the score
    python -m fic_teleop_experiments.tools.random_mutation --law --seed 9 --commit C --out-dir results --resume
    python -m fic_teleop_experiments.tools.random_mutation --table results/random_mutation_held_out_*.json
    python -m fic_teleop_experiments.tools.random_mutation --count     # how many sites fic_core has, per kind
    python -m fic_teleop_experiments.tools.random_mutation --seed 3 --sample 60 --list   # a fitting sample, not run
    python -m fic_teleop_experiments.tools.random_mutation --compare FULL.json SELECTED.json   # the two ways agree?

Exits 1 when the kill rate of the non-equivalent mutants is below --require (default 0.9). A mutant pytest could
not judge (mutation_verdict.py: ERROR) counts in neither the kills nor the survivors; exits 2 when test/core fails,
or does not finish within --baseline-timeout, on the unmutated tree. A mutant whose tests outrun --timeout counts as
killed (a hang), and the result says how many kills were such (``killed_by_timeout``): on a starved machine a slow
run looks like a hang, so give a --timeout well above the time the unmutated tests take there.
"""
from __future__ import annotations

import argparse
import ast
import collections
import concurrent.futures
import hashlib
import json
import os
import re
import resource
import secrets
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from importlib import resources
from pathlib import Path

import yaml

from fic_teleop_experiments.tools import line_coverage_map
from fic_teleop_experiments.tools.line_coverage_map import ALL, NONE, Selection
from fic_teleop_experiments.tools.line_coverage_map import TESTS as TESTS_SELECTED
from fic_teleop_experiments.tools.mutation_verdict import (
    KILLED,
    SETTINGS_PLUGIN,
    SURVIVED,
    pytest_verdict,
    write_settings_plugin,
)
from fic_teleop_runtime.workspace import working_folder

REPO = working_folder()   # runs/ and results/ (FIC_TELEOP_ROOT, else the current folder)
PACKAGE = REPO / "fic_core" / "fic_core"
TESTS = REPO / "test" / "core"
# Data files of this package (setup.py package_data), read where the package is installed.
EQUIVALENT_FILE = Path(str(resources.files("fic_teleop_experiments.tools") / "equivalent_mutants.yaml"))
SEEDS_FILE = Path(str(resources.files("fic_teleop_experiments.tools") / "mutation_seeds.yaml"))

#: The control laws and the loops around them (docs/CONTROL_LAWS.md): the modules a score is wanted for.
LAW_MODULES = tuple(f"{name}.py" for name in (
    "profile", "attractor", "rotational_attractor", "pose_attractor", "master", "master_station", "planner",
    "replica", "replica_loop", "postural_optimisation", "baseline", "set_point", "desired_pose", "teleoperation",
    "posture", "limits", "trajectories", "loop_health", "input_authority"))

FITTING = "fitting"
HELD_OUT = "held_out"

_COMPARISON_NEGATED = {ast.Lt: ast.GtE, ast.LtE: ast.Gt, ast.Gt: ast.LtE, ast.GtE: ast.Lt, ast.Eq: ast.NotEq,
                       ast.NotEq: ast.Eq, ast.Is: ast.IsNot, ast.IsNot: ast.Is, ast.In: ast.NotIn,
                       ast.NotIn: ast.In}
_COMPARISON_BOUNDARY = {ast.Lt: ast.LtE, ast.LtE: ast.Lt, ast.Gt: ast.GtE, ast.GtE: ast.Gt}
_ARITHMETIC = {ast.Add: ast.Sub, ast.Sub: ast.Add, ast.Mult: ast.Div, ast.Div: ast.Mult, ast.Pow: ast.Mult,
               ast.FloorDiv: ast.Div, ast.Mod: ast.FloorDiv}
_BOOLEAN = {ast.And: ast.Or, ast.Or: ast.And}
_SYMBOL = {ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">=", ast.Eq: "==", ast.NotEq: "!=", ast.Is: "is",
           ast.IsNot: "is not", ast.In: "in", ast.NotIn: "not in", ast.Add: "+", ast.Sub: "-", ast.Mult: "*",
           ast.Div: "/", ast.Pow: "**", ast.FloorDiv: "//", ast.Mod: "%", ast.And: "and", ast.Or: "or"}

@dataclass(frozen=True)
class Site:
    """One mutant: ``node`` is the index of the changed node in ``ast.walk`` of the module."""
    module: str        # file name in fic_core/fic_core
    node: int
    line: int
    kind: str          # comparison, arithmetic, boolean, constant, sign
    change: str        # e.g. "< -> <=" (with "#n" for the n-th identical change on one line, n > 0)
    source_line: str   # the line's text, stripped: the key of an equivalent mutant with module, scope and change
    operand: int = 0   # which operator of a chained comparison
    scope: str = ""    # the enclosing class and function, e.g. "PosturalOptimisation._admits_unshaped"


def _skipped_nodes(tree: ast.AST) -> set[int]:
    """ids of the nodes no mutant may touch: annotations, raise statements' messages, f-strings, __all__."""
    skipped: set[int] = set()

    def skip(root: ast.AST | None) -> None:
        if root is not None:
            skipped.update(id(node) for node in ast.walk(root))

    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            skip(node.returns)
            for argument in [*node.args.args, *node.args.kwonlyargs, *node.args.posonlyargs,
                             node.args.vararg, node.args.kwarg]:
                if argument is not None:
                    skip(argument.annotation)
        elif isinstance(node, ast.AnnAssign):
            skip(node.annotation)
        elif isinstance(node, ast.Raise):
            skip(node.exc)
        elif isinstance(node, ast.JoinedStr):
            skip(node)
        elif isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets):
            skip(node)
    return skipped


def _scopes(tree: ast.AST) -> dict[int, str]:
    """id(node) -> the dotted names of the classes and functions around it ("" at module level)."""
    scopes: dict[int, str] = {}

    def visit(node: ast.AST, scope: str) -> None:
        for child in ast.iter_child_nodes(node):
            inner = scope
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                inner = f"{scope}.{child.name}" if scope else child.name
            scopes[id(child)] = inner
            visit(child, inner)
    visit(tree, "")
    return scopes


def _number(node: ast.AST) -> bool:
    return isinstance(node, ast.Constant) and type(node.value) in (int, float)


def sites_of(module: str, source: str) -> list[Site]:
    """Every mutant of one module, in ast.walk order."""
    tree = ast.parse(source)
    lines = source.splitlines()
    skipped = _skipped_nodes(tree)
    scopes = _scopes(tree)
    found: list[Site] = []
    seen: dict[tuple[int, str], int] = {}

    def add(index: int, node: ast.AST, kind: str, change: str, operand: int = 0) -> None:
        line = getattr(node, "lineno", 0)
        count = seen.get((line, change), 0)
        seen[(line, change)] = count + 1
        found.append(Site(module, index, line, kind, change + (f" #{count}" if count else ""),
                          lines[line - 1].strip() if line else "", operand, scopes.get(id(node), "")))

    for index, node in enumerate(ast.walk(tree)):
        if id(node) in skipped:
            continue
        if isinstance(node, ast.Compare):
            for operand, operator in enumerate(node.ops):
                kind = type(operator)
                add(index, node, "comparison", f"{_SYMBOL[kind]} -> {_SYMBOL[_COMPARISON_NEGATED[kind]]}", operand)
                if kind in _COMPARISON_BOUNDARY:
                    add(index, node, "comparison", f"{_SYMBOL[kind]} -> {_SYMBOL[_COMPARISON_BOUNDARY[kind]]}",
                        operand)
        elif isinstance(node, (ast.BinOp, ast.AugAssign)) and type(node.op) in _ARITHMETIC:
            kind = type(node.op)
            augmented = "=" if isinstance(node, ast.AugAssign) else ""
            add(index, node, "arithmetic", f"{_SYMBOL[kind]}{augmented} -> {_SYMBOL[_ARITHMETIC[kind]]}{augmented}")
        elif isinstance(node, ast.BoolOp):
            kind = type(node.op)
            add(index, node, "boolean", f"{_SYMBOL[kind]} -> {_SYMBOL[_BOOLEAN[kind]]}")
        elif isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Not):
            add(index, node, "boolean", "not dropped")
        elif isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
            add(index, node, "sign", "unary minus dropped")
        elif isinstance(node, ast.Constant) and type(node.value) is bool:
            add(index, node, "boolean", f"{node.value} -> {not node.value}")
        elif _number(node):
            add(index, node, "constant", f"{node.value!r} -> {node.value!r} + 1")
    return found


def all_sites(root: Path = REPO) -> list[Site]:
    """Every mutant of fic_core (in the tree at ``root``), modules in name order."""
    sites: list[Site] = []
    for path in sorted((root / PACKAGE.relative_to(REPO)).glob("*.py")):
        sites += sites_of(path.name, path.read_text())
    return sites


def mutated_source(site: Site, root: Path = REPO) -> str:
    """The module's text with ``site`` applied (ast.unparse: comments are gone, behaviour is the module's)."""
    tree = ast.parse((root / PACKAGE.relative_to(REPO) / site.module).read_text())
    nodes = list(ast.walk(tree))
    node = nodes[site.node]
    parents = {id(child): parent for parent in nodes for child in ast.iter_child_nodes(parent)}
    change = site.change.split(" #")[0]
    if isinstance(node, ast.Compare):
        target = change.split(" -> ")[1]
        node.ops[site.operand] = next(kind for kind, symbol in _SYMBOL.items() if symbol == target)()
    elif isinstance(node, (ast.BinOp, ast.AugAssign)):
        node.op = _ARITHMETIC[type(node.op)]()
    elif isinstance(node, ast.BoolOp):
        node.op = _BOOLEAN[type(node.op)]()
    elif isinstance(node, ast.UnaryOp):   # a `not` or a unary minus dropped: the operand takes the node's place
        _replace(parents[id(node)], node, node.operand)
    elif isinstance(node, ast.Constant) and type(node.value) is bool:
        node.value = not node.value
    elif _number(node):
        node.value = node.value + 1
    else:
        raise ValueError(f"{site}: no such mutation")
    return ast.unparse(ast.fix_missing_locations(tree)) + "\n"


def _replace(parent: ast.AST, old: ast.AST, new: ast.AST) -> None:
    for field, value in ast.iter_fields(parent):
        if value is old:
            setattr(parent, field, new)
            return
        if isinstance(value, list):
            for position, item in enumerate(value):
                if item is old:
                    value[position] = new
                    return
    raise ValueError("node not found under its parent")


def _imported_modules(source: str) -> set[str]:
    """fic_core module names a file imports (``from fic_core.x import``, ``import fic_core.x``, ``from .x import``,
    ``from fic_core import x``)."""
    names = set(re.findall(r"(?:from|import)\s+fic_core\.(\w+)", source))
    names |= set(re.findall(r"from\s+\.(\w+)\s+import", source))
    for group in re.findall(r"from\s+fic_core\s+import\s+\(?([\w\s,]+)\)?", source):
        names |= {name.strip() for name in group.split(",") if name.strip()}
    return names


def dependents(module: str, root: Path = REPO) -> set[str]:
    """``module`` and every fic_core module that imports it, directly or through others (names without .py)."""
    imports = {path.stem: _imported_modules(path.read_text())
               for path in (root / PACKAGE.relative_to(REPO)).glob("*.py")}
    found, frontier = {module}, [module]
    while frontier:
        current = frontier.pop()
        for name, imported in imports.items():
            if current in imported and name not in found:
                found.add(name)
                frontier.append(name)
    return found


def test_files(module: str, root: Path = REPO) -> tuple[list[Path], list[Path]]:
    """(files of test/core importing ``module`` itself, files importing it only through another module)."""
    stem = module.removesuffix(".py")
    reach = dependents(stem, root)
    direct, indirect = [], []
    for path in sorted((root / TESTS.relative_to(REPO)).glob("test_*.py")):
        imported = _imported_modules(path.read_text())
        if stem in imported:
            direct.append(path)
        elif imported & reach:
            indirect.append(path)
    return direct, indirect


def equivalent_mutants(path: Path = EQUIVALENT_FILE) -> dict[tuple[str, str, str, str], str]:
    """(module, scope, source line, change) -> the reason the mutant is equivalent."""
    if not path.exists():
        return {}
    entries = yaml.safe_load(path.read_text()) or []
    return {(entry["module"], entry["scope"], entry["line"], entry["change"]): entry["reason"] for entry in entries}


def key(site: Site) -> tuple[str, str, str, str]:
    """What finds a mutant again after the code moved: module, scope, the line's text, the change."""
    return site.module, site.scope, site.source_line, site.change


def site_id(site: Site) -> tuple[str, int, str]:
    """One mutant of one tree: module, node, change. Two lines of the same text in one scope share ``key``; the
    tests a mutant runs and a resumed draw's verdicts are each mutant's own."""
    return site.module, site.node, site.change


def seed_sets(path: Path | None = None) -> tuple[set[int], list[int]]:
    """(the fitting seeds, the held-out seeds) of ``mutation_seeds.yaml``; a seed in both is refused."""
    path = path or SEEDS_FILE
    entries = yaml.safe_load(path.read_text()) if path.exists() else None
    entries = entries or {}
    fitting = {int(entry["seed"] if isinstance(entry, dict) else entry) for entry in entries.get(FITTING) or []}
    held_out = [int(entry["seed"] if isinstance(entry, dict) else entry) for entry in entries.get(HELD_OUT) or []]
    both = fitting.intersection(held_out)
    if both:
        raise ValueError(f"{path.name}: seeds {sorted(both)} are both fitting and held out")
    return fitting, held_out


def role_of(seed: int, path: Path | None = None) -> str:
    """FITTING for a seed whose survivors were used to write tests; HELD_OUT for any other (a recorded held-out
    seed, or one in neither set: a fresh draw)."""
    fitting, _ = seed_sets(path)
    return FITTING if seed in fitting else HELD_OUT


def fresh_seed(path: Path | None = None) -> int:
    """A random seed in neither set of ``mutation_seeds.yaml`` (a draw nobody has looked at)."""
    fitting, held_out = seed_sets(path)
    while True:
        seed = secrets.randbelow(10**6)
        if seed not in fitting and seed not in held_out:
            return seed


def sample(seed: int, size: int, module: str | None = None, root: Path = REPO,
           modules: tuple[str, ...] | None = None) -> list[Site]:
    """``size`` mutants drawn with ``seed`` from every site (of ``module`` only, when given; else of ``modules``,
    when given): the sites whose seeded hash of their key is smallest, so that a change elsewhere in fic_core
    leaves the rest of a sample as it was (a draw by position in the list of sites would change with every line
    added)."""
    sites = [site for site in all_sites(root)
             if (module is None or site.module == module) and (modules is None or site.module in modules)]
    return sorted(sites, key=lambda site: hashlib.sha256(f"{seed}|{'|'.join(key(site))}".encode()).digest())[:size]


def snapshot(commit: str, folder: Path) -> Path:
    """The tree of ``commit`` extracted into ``folder`` (the mutants and the tests come from a commit, not the work
    tree, which other work may be changing while the run goes)."""
    archive = subprocess.run(["git", "archive", commit],
                             cwd=REPO, capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive, check=True)
    return folder


def _pytest(root: Path, folder: str, files: list[Path] | list[str], timeout: float) -> subprocess.CompletedProcess:
    """pytest over ``files`` (or test ids) in the tree at ``root``, with the fic_core under ``folder`` first on the
    path."""
    env = dict(os.environ, PYTHONPATH=folder + os.pathsep + os.environ.get("PYTHONPATH", ""),
               PYTHONDONTWRITEBYTECODE="1", FIC_TELEOP_ROOT=str(root))
    probe = subprocess.run([sys.executable, "-c", "import fic_core; print(fic_core.__file__)"], env=env,
                           capture_output=True, text=True, cwd=root)
    if not probe.stdout.strip().startswith(folder):   # else every mutant would survive vacuously
        raise RuntimeError(f"fic_core imported from {probe.stdout.strip()!r}, not {folder}")
    command = [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-p", SETTINGS_PLUGIN, "-x", "-q", "-rfE",
               f"--timeout={int(timeout)}", *map(str, files)]
    return subprocess.run(command, env=env, capture_output=True, text=True, cwd=root, timeout=max(timeout, 1.0))


#: Seconds for test/core on the unmutated tree. In the machine's background CPU group, beside a loaded suite, it
#: took longer than 900 s (2026-12-05); the per-mutant --timeout is smaller, as a mutant runs only its importers.
BASELINE_TIMEOUT = 3600.0

#: The start of a kill's detail when the mutant's tests did not finish in time (run_mutant): counted apart in the
#: result (``killed_by_timeout``), as on a starved machine a slow run and a hang look alike.
TIMEOUT_DETAIL = "the tests did not finish in"


def baseline(root: Path, timeout: float = BASELINE_TIMEOUT) -> subprocess.CompletedProcess:
    """test/core on the unmutated tree: a mutant counts only if these pass (RuntimeError if they did not finish
    within ``timeout`` seconds)."""
    with tempfile.TemporaryDirectory(prefix="fic_random_mutation_") as folder:
        shutil.copytree(root / "fic_core" / "fic_core", Path(folder) / "fic_core",
                        ignore=shutil.ignore_patterns("__pycache__"))
        # Derandomised: the unmutated tree and every mutant see the same examples, so a property that fails on
        # rare random examples neither fails the baseline by chance nor counts as a kill (one did: test_profile's
        # integral).
        write_settings_plugin(Path(folder), derandomize=True)
        try:
            return _pytest(root, folder, [root / "test" / "core"], timeout)
        except subprocess.TimeoutExpired:
            raise RuntimeError(f"test/core did not finish on the unmutated tree in {timeout:.0f} s (a loaded "
                               f"machine: give a longer --baseline-timeout)") from None


def run_mutant(site: Site, timeout: float, root: Path = REPO,
               chosen: Selection | None = None) -> tuple[str, str, float, float]:
    """(verdict, detail, seconds, CPU seconds of its processes): KILLED with the first failing test (or a timeout),
    SURVIVED, ERROR, or NO TESTS. ``chosen`` (line_coverage_map.selection) names the tests that execute the
    mutated line: only they run, the direct importers' first, and a mutant no test executes survives without a run.
    Without it (or when every test must run), the files that import the module run first, the direct importers
    before the others; a mutant they leave alive runs the rest of test/core as well, so that a survivor has passed
    all of it (a test/core file may reach a module through the fixtures of test/conftest.py or a tools module,
    which the import scan misses). The CPU seconds are exact when one mutant runs at a time."""
    if chosen is not None and chosen.kind == NONE:
        return SURVIVED, chosen.why, 0.0, 0.0
    direct, indirect = test_files(site.module, root)
    if not direct and not indirect:
        return "NO TESTS", f"no file of test/core imports {site.module}", 0.0, 0.0
    importers = set(direct) | set(indirect)
    rest = [path for path in sorted((root / TESTS.relative_to(REPO)).glob("test_*.py")) if path not in importers]
    if chosen is not None and chosen.kind == TESTS_SELECTED:
        # One run over the chosen test ids, those in the importers' files first: most mutants are killed there.
        order = {str(path.relative_to(root)): rank for rank, group in enumerate((direct, indirect, rest))
                 for path in group}
        runs = [sorted(chosen.tests, key=lambda test_id: order.get(test_id.split("::")[0], len(order)))]
    else:
        runs = [files for files in (direct, indirect, rest) if files]
    cpu_before = _children_cpu()
    with tempfile.TemporaryDirectory(prefix="fic_random_mutation_") as folder:
        copy = Path(folder) / "fic_core"
        shutil.copytree(root / "fic_core" / "fic_core", copy, ignore=shutil.ignore_patterns("__pycache__"))
        (copy / site.module).write_text(mutated_source(site, root))
        # Derandomised: the unmutated tree and every mutant see the same examples, so a property that fails on
        # rare random examples neither fails the baseline by chance nor counts as a kill (one did: test_profile's
        # integral).
        write_settings_plugin(Path(folder), derandomize=True)
        started = time.monotonic()
        result = None
        for tests in runs:   # the direct importers first: most mutants are killed there
            try:
                result = _pytest(root, folder, tests, timeout - (time.monotonic() - started))
            except subprocess.TimeoutExpired:
                return KILLED, f"{TIMEOUT_DETAIL} {timeout:.0f} s (a hang counts)", timeout, \
                    _children_cpu() - cpu_before
            if result.returncode != 0:
                break
        seconds = time.monotonic() - started
    verdict, detail = pytest_verdict(result)
    return verdict, detail, seconds, _children_cpu() - cpu_before


def _children_cpu() -> float:
    """CPU seconds (user and system) of this process's finished children so far."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def matching(sites: list[Site], previous: dict, verdicts: tuple[str, ...] = ("SURVIVED",)) -> list[Site]:
    """The sites of ``previous`` (a run's JSON) with one of ``verdicts``, found again by module, source line and
    change (line numbers move with the code)."""
    wanted = {(row["module"], row.get("scope", ""), row["source_line"], row["change"]) for row in previous["mutants"]
              if row["verdict"] in verdicts}
    unscoped = {(module, line, change) for module, scope, line, change in wanted if not scope}
    return [site for site in sites
            if key(site) in wanted or (site.module, site.source_line, site.change) in unscoped]


#: The verdicts that count in a kill rate (ERROR says nothing about the mutant, EQUIVALENT is not a mutant).
COUNTED = ("KILLED", "SURVIVED", "NO TESTS")


def per_module(rows: list[dict], modules: tuple[str, ...] | None = None) -> dict[str, dict]:
    """Per module (those of ``modules`` in its order, drawn or not, else every module drawn): how many mutants
    were drawn, equivalent, counted and killed, and the kill rate (None with none counted)."""
    names = list(modules) if modules is not None else sorted({row["module"] for row in rows})
    table = {}
    for name in names:
        mine = [row for row in rows if row["module"] == name]
        counted = [row for row in mine if row["verdict"] in COUNTED]
        killed = sum(row["verdict"] == KILLED for row in counted)
        table[name] = {"drawn": len(mine), "equivalent": sum(row["verdict"] == "EQUIVALENT" for row in mine),
                       "non_equivalent": len(counted), "killed": killed,
                       "kill_rate": round(killed / len(counted), 3) if counted else None}
    return table


def _judge(chosen: list[Site], root: Path, timeout: float, equivalent: dict, echo, partial: dict,
           out: Path | None, jobs: int = 1, judged: dict | None = None,
           selections: dict[tuple[str, int, str], Selection] | None = None) -> list[dict]:
    """Every verdict of ``chosen`` in the snapshot at ``root``, ``jobs`` mutants at a time, in the sample's order,
    written to ``out`` as it goes (``partial`` is the JSON's head); ``judged`` (key -> row, from an interrupted run
    of the same commit and seed) gives the verdicts already found, which are not run again; ``selections`` (site_id
    -> the tests that execute the mutant's line) what each runs, every test where it gives none."""
    rows = []
    judged = judged or {}
    selections = selections or {}
    pool = concurrent.futures.ThreadPoolExecutor(max_workers=max(1, jobs))   # each mutant is a pytest process
    verdicts = [None if key(site) in equivalent or site_id(site) in judged
                else pool.submit(run_mutant, site, timeout, root, selections.get(site_id(site))) for site in chosen]
    for number, (site, pending) in enumerate(zip(chosen, verdicts), 1):
        cpu, ran = None, _ran(selections.get(site_id(site)))
        if key(site) in equivalent:
            verdict, detail, seconds, ran = "EQUIVALENT", equivalent[key(site)], 0.0, None
        elif pending is None:
            found = judged[site_id(site)]
            verdict, detail, seconds = found["verdict"], found["detail"], found["seconds"]
            cpu, ran = found.get("cpu_seconds"), found.get("tests_run")
        else:
            verdict, detail, seconds, cpu = pending.result()
            cpu = round(cpu, 1) if jobs == 1 else None   # children of several mutants overlap otherwise
        rows.append({**asdict(site), "verdict": verdict, "detail": detail, "seconds": round(seconds, 1),
                     "cpu_seconds": cpu, "tests_run": ran})
        if out is not None:   # as it goes: an interrupted run keeps its verdicts
            out.parent.mkdir(parents=True, exist_ok=True)
            out.write_text(json.dumps({**partial, "partial": True, "mutants": rows}, indent=2) + "\n")
        echo(f"{number:3d} {verdict:10s} {site.module}:{site.line} {site.kind}: {site.change}\n"
             f"               {site.source_line[:100]}\n               {detail} ({seconds:.0f} s"
             f"{'' if cpu is None else f', {cpu:.0f} CPU-s'}; tests: {ran})")
    pool.shutdown()
    return rows


def _ran(chosen: Selection | None) -> str | int | None:
    """What a mutant's row says it ran: "all" (the importers' files, then the rest), the number of test ids
    chosen, or 0 (no test executes its line)."""
    if chosen is None or chosen.kind == ALL:
        return "all"
    return len(chosen.tests)


def selections_of(sites: list[Site], root: Path, line_map: line_coverage_map.LineMap) -> dict:
    """site_id -> line_coverage_map.selection of each site, its module parsed from the tree at ``root``."""
    trees: dict[str, tuple[ast.AST, list[ast.AST]]] = {}
    found = {}
    for site in sites:
        if site.module not in trees:
            tree = ast.parse((root / PACKAGE.relative_to(REPO) / site.module).read_text())
            trees[site.module] = (tree, list(ast.walk(tree)))
        tree, nodes = trees[site.module]
        found[site_id(site)] = line_coverage_map.selection(line_map, site.module, tree, nodes[site.node])
    return found


def unmutated_line_map(root: Path, timeout: float, cache: Path, echo=print) -> line_coverage_map.LineMap:
    """The line map of the tree at ``root``: read from ``cache`` when a run of this tree's content built it (that
    run passed: it was the baseline), else test/core run once under coverage, which is then the baseline, and the
    map stored. Raises RuntimeError when test/core fails or does not finish in ``timeout`` seconds."""
    found = line_coverage_map.cached(root, cache)
    if found is not None:
        echo(f"[random_mutation] line map of tree {found.tree[:12]} read from {cache} (test/core passed on it "
             f"when it was built)")
        return found
    started = time.monotonic()
    try:
        found, result = line_coverage_map.build(root, timeout)
    except subprocess.TimeoutExpired:
        raise RuntimeError(f"test/core did not finish on the unmutated tree in {timeout:.0f} s (a loaded "
                           f"machine: give a longer --baseline-timeout)") from None
    if found is None:
        raise RuntimeError("test/core fails on the unmutated tree: " + result.stdout.strip()[-400:])
    path = line_coverage_map.store(found, cache)
    echo(f"[random_mutation] line map of {len(found.tests)} tests built in {time.monotonic() - started:.0f} s, "
         f"stored in {path}")
    return found


def _result(head: dict, rows: list[dict], sites: int | None, seconds: float, modules: tuple[str, ...] | None) -> dict:
    counted = [row for row in rows if row["verdict"] in COUNTED]
    killed = sum(row["verdict"] == "KILLED" for row in counted)
    timed_out = sum(row["verdict"] == "KILLED" and row["detail"].startswith(TIMEOUT_DETAIL) for row in counted)
    kill_rate = round(killed / len(counted), 3) if counted else None
    return {**head, "sample": len(rows), "sites": sites,
            "equivalent": sum(row["verdict"] == "EQUIVALENT" for row in rows), "non_equivalent": len(counted),
            "killed": killed, "killed_by_timeout": timed_out, "kill_rate": kill_rate,
            # Only a held-out draw scores the suite; a fitting draw's rate is how well the tests fit it.
            "score": kill_rate if head["role"] == HELD_OUT and head.get("rerun_of") is None else None,
            "per_module": per_module(rows, modules), "seconds": round(seconds), "mutants": rows}


def run_draws(seeds: list[int], size: int, timeout: float, outs: list[Path | None], *, module: str | None = None,
              modules: tuple[str, ...] | None = None, echo=print, commit: str = "HEAD",
              baseline_timeout: float = BASELINE_TIMEOUT, rerun: dict | None = None, jobs: int = 1,
              resume: bool = False, full_suite: bool = False, cache: Path | None = None) -> list[dict]:
    """Each seed's draw of ``commit``'s fic_core (``module`` only, or ``modules``) against its test/core, from one
    snapshot and one unmutated run; returns (and writes to its ``outs`` path) each draw's verdicts, its kill rate
    overall and per module, and its role (``role_of``). With ``rerun`` (an earlier run's JSON, one seed): its
    survivors again instead of a sample. With ``resume``: the verdicts an interrupted run of the same commit, seed and
    modules left in an ``outs`` file are kept (``judged_before``), the rest are run. Each mutant runs the tests that
    execute its line (line_coverage_map, its map kept in ``cache``), or with ``full_suite`` test/core until a test
    fails. Raises RuntimeError when test/core fails on the unmutated tree."""
    equivalent = equivalent_mutants()
    revision = subprocess.run(["git", "rev-parse", commit], cwd=REPO, capture_output=True, text=True,
                              check=True).stdout.strip()
    results = []
    drawn_from = module if module is not None else _scope_name(modules)
    with tempfile.TemporaryDirectory(prefix="fic_random_mutation_tree_") as tree:
        root = snapshot(revision, Path(tree))
        if full_suite:
            line_map = None
            unmutated = baseline(root, baseline_timeout)
            if unmutated.returncode != 0:
                raise RuntimeError("test/core fails on the unmutated tree: " + unmutated.stdout.strip()[-400:])
        else:
            line_map = unmutated_line_map(root, baseline_timeout, cache or REPO / line_coverage_map.CACHE, echo)
        every_site = all_sites(root)
        in_scope = len([site for site in every_site if (module is None or site.module == module)
                        and (modules is None or site.module in modules)])
        for seed, out in zip(seeds, outs):
            started = time.monotonic()
            chosen = matching(every_site, rerun) if rerun is not None else sample(seed, size, module, root,
                                                                                   modules=modules)
            head = {"commit": revision, "seed": seed, "role": role_of(seed), "drawn_from": drawn_from,
                    "tests": "full suite" if full_suite else "the tests that execute the mutated line"}
            if rerun is not None:
                head["rerun_of"] = rerun.get("commit")
            judged = judged_before(out, head) if resume and rerun is None else {}
            selections = None if line_map is None else selections_of(chosen, root, line_map)
            rows = _judge(chosen, root, timeout, equivalent, echo, head, out, jobs, judged, selections)
            result = _result(head, rows, in_scope, time.monotonic() - started,
                             modules if module is None else (module,))
            if out is not None:
                out.parent.mkdir(parents=True, exist_ok=True)
                out.write_text(json.dumps(result, indent=2) + "\n")
            results.append(result)
    return results


def judged_before(out: Path | None, head: dict) -> dict[tuple[str, int, str], dict]:
    """site_id -> row of the verdicts (killed, survived, no tests) in ``out``, when it holds a run of ``head``'s commit,
    seed and modules (an interrupted draw); {} otherwise. An ERROR says nothing about its mutant: it is run again."""
    if out is None or not out.exists():
        return {}
    earlier = json.loads(out.read_text())
    if any(earlier.get(field) != head[field] for field in ("commit", "seed", "drawn_from")):
        return {}
    return {(row["module"], row["node"], row["change"]): row for row in earlier["mutants"]
            if row["verdict"] in COUNTED}


def _scope_name(modules: tuple[str, ...] | None) -> str:
    """"all", "law", or "law without a.py, b.py" (LAW_MODULES less some), or the modules' names."""
    if modules is None:
        return "all"
    left_out = [name for name in LAW_MODULES if name not in modules]
    if set(modules) <= set(LAW_MODULES):
        return "law" + (f" without {', '.join(left_out)}" if left_out else "")
    return ", ".join(modules)


def run(seed: int, size: int, timeout: float, module: str | None = None, out: Path | None = None,
        echo=print, commit: str = "HEAD", rerun: dict | None = None,
        baseline_timeout: float = BASELINE_TIMEOUT, modules: tuple[str, ...] | None = None) -> dict:
    """One seed's draw (``run_draws``): every verdict, the kill rate overall and per module, and the role."""
    return run_draws([seed], size, timeout, [out], module=module, modules=modules, echo=echo, commit=commit,
                     baseline_timeout=baseline_timeout, rerun=rerun)[0]


def pooled_table(results: list[dict]) -> str:
    """A Markdown table of the kill rate per module pooled over ``results`` (each draw's JSON), then one line per
    draw and the pooled total; the law modules first, in LAW_MODULES' order, then any other module drawn."""
    rows = [row for result in results for row in result["mutants"]]
    drawn = {row["module"] for row in rows}
    law = all(str(result.get("drawn_from", "")).startswith("law") for result in results)
    names = tuple(LAW_MODULES) + tuple(sorted(drawn - set(LAW_MODULES))) if law else tuple(sorted(drawn))
    table = per_module(rows, names)
    # With several draws, a column a draw: killed / non-equivalent of each module in that draw alone.
    draws = [per_module(result["mutants"], names) for result in results] if len(results) > 1 else []
    seeds = "".join(f" seed {result['seed']} |" for result in results) if draws else ""
    lines = [f"| module | drawn | equivalent |{seeds} killed / non-equivalent | kill rate |",
             "|---|---|---|" + "---|" * len(draws) + "---|---|"]
    for name, entry in table.items():
        rate = "-" if entry["kill_rate"] is None else f"{entry['kill_rate']:.3f}"
        each = "".join(f" {draw[name]['killed']} / {draw[name]['non_equivalent']} |" for draw in draws)
        lines.append(f"| {name.removesuffix('.py')} | {entry['drawn']} | {entry['equivalent']} |{each} "
                     f"{entry['killed']} / {entry['non_equivalent']} | {rate} |")
    for result in results:
        unfinished = ", partial" if result.get("partial") else ""
        lines.append(f"| seed {result['seed']} ({result['role']}{unfinished}, {result['commit'][:10]}) | "
                     f"{result['sample']} | {result['equivalent']} |" + " |" * len(draws) +
                     f" {result['killed']} / {result['non_equivalent']} | {result['kill_rate']} |")
    counted = sum(result["non_equivalent"] for result in results)
    killed = sum(result["killed"] for result in results)
    rate = f"{killed / counted:.3f}" if counted else "-"
    each = "".join(f" {result['killed']} / {result['non_equivalent']} |" for result in results) if draws else ""
    lines.append(f"| all | {len(rows)} | {sum(result['equivalent'] for result in results)} |{each} "
                 f"{killed} / {counted} | {rate} |")
    return "\n".join(lines)


def compared(full: dict, selected: dict) -> tuple[str, bool]:
    """(a Markdown table of each mutant judged in both runs: its verdict and CPU seconds with the full suite and
    with the tests that execute its line, then the mean CPU seconds of each; whether every verdict agrees)."""
    verdicts = {(row["module"], row["scope"], row["source_line"], row["change"]): row for row in full["mutants"]}
    lines = ["| mutant | full suite | CPU-s | selected tests | CPU-s |", "|---|---|---|---|---|"]
    agree, spent = True, [[], []]
    for row in selected["mutants"]:
        other = verdicts.get((row["module"], row["scope"], row["source_line"], row["change"]))
        if other is None or "EQUIVALENT" in (row["verdict"], other["verdict"]):
            continue
        agree &= other["verdict"] == row["verdict"]
        for costs, judged in zip(spent, (other, row)):
            if judged.get("cpu_seconds") is not None:
                costs.append(judged["cpu_seconds"])
        lines.append(f"| {row['module']}:{row['line']} {row['change']} | {other['verdict']} | "
                     f"{other.get('cpu_seconds')} | {row['verdict']} ({row.get('tests_run')} tests) | "
                     f"{row.get('cpu_seconds')} |")
    means = [f"{sum(costs) / len(costs):.1f}" if costs else "-" for costs in spent]
    lines.append(f"| mean of {len(lines) - 2} | | {means[0]} | | {means[1]} |")
    return "\n".join(lines), agree


def tallied(result: dict) -> dict:
    """A draw's JSON with its counts: a finished one as it is; an interrupted one (``partial``: the verdicts so far,
    which ``--resume`` goes on from) counted over the mutants it judged, marked partial, with no score: a score is
    a whole draw's."""
    if not result.get("partial"):
        return result
    head = {field: result[field] for field in ("commit", "seed", "role", "drawn_from")}
    law = str(result["drawn_from"]).startswith("law")
    return {**_result(head, result["mutants"], None, 0.0, LAW_MODULES if law else None), "partial": True,
            "score": None}


def _summary(result: dict) -> str:
    what = (f"score {result['score']}" if result["score"] is not None else
            f"fit {result['kill_rate']} (a {'rerun of survivors' if result.get('rerun_of') else 'fitting seed'}: "
            f"not a score)")
    return (f"commit {result['commit'][:10]}, seed {result['seed']} ({result['role']}, from {result['drawn_from']}): "
            f"{result['sample']} mutants of {result['sites']} sites, {result['equivalent']} equivalent; killed "
            f"{result['killed']} of {result['non_equivalent']} ({what}; {result['killed_by_timeout']} of the kills "
            f"by the timeout) in {result['seconds']} s")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", nargs="+", default=["1"],
                        help="one or more integers (each a draw, from one snapshot and one unmutated run), or "
                             "'fresh': a seed in neither set of mutation_seeds.yaml")
    parser.add_argument("--held-out", action="store_true",
                        help="run every held-out seed of mutation_seeds.yaml (one JSON each in --out-dir)")
    parser.add_argument("--sample", type=int, default=60, help="mutants drawn a seed")
    parser.add_argument("--module", default=None, help="draw from this fic_core file only (e.g. limits.py)")
    parser.add_argument("--law", action="store_true", help="draw from the control-law modules only (LAW_MODULES)")
    parser.add_argument("--exclude", nargs="+", default=[], metavar="MODULE",
                        help="with --law: leave these modules out of the draw (e.g. ones being rewritten)")
    parser.add_argument("--timeout", type=float, default=240.0, help="seconds for the tests of one mutant")
    parser.add_argument("--jobs", type=int, default=1, help="mutants judged at a time (each a pytest process)")
    parser.add_argument("--baseline-timeout", type=float, default=BASELINE_TIMEOUT,
                        help="seconds for test/core on the unmutated tree")
    parser.add_argument("--out", type=Path, default=None, help="write every verdict as JSON")
    parser.add_argument("--out-dir", type=Path, default=None,
                        help="write random_mutation_<role>_seed<N>.json here, one a seed (--held-out: results/)")
    parser.add_argument("--require", type=float, default=0.9, help="least kill rate of the non-equivalent mutants")
    parser.add_argument("--commit", default="HEAD", help="the commit whose fic_core and test/core are run")
    parser.add_argument("--rerun", type=Path, default=None,
                        help="run the survivors of an earlier --out JSON again (found by module, line text, change); "
                             "refused for a held-out draw, whose survivors are not for fitting")
    parser.add_argument("--resume", action="store_true",
                        help="keep the verdicts an interrupted run of the same commit and seed left in its JSON "
                             "(--out or --out-dir), run the rest")
    parser.add_argument("--full-suite", action="store_true",
                        help="run test/core until a test fails for every mutant (the importers' files first), not "
                             "only the tests that execute its line")
    parser.add_argument("--compare", type=Path, nargs=2, default=None, metavar=("FULL", "SELECTED"),
                        help="print, mutant by mutant, the verdicts and CPU seconds of a --full-suite JSON and a run "
                             "of the same mutants with the tests that execute their lines, and exit (1 if a verdict "
                             "differs)")
    parser.add_argument("--list", action="store_true", help="print a fitting seed's sample and exit")
    parser.add_argument("--count", action="store_true", help="print the number of sites per kind and exit")
    parser.add_argument("--table", type=Path, nargs="+", default=None,
                        help="print the kill rate per module pooled over these result JSONs and exit")
    arguments = parser.parse_args(argv)
    unknown = [name for name in arguments.exclude if name not in LAW_MODULES]
    if unknown or (arguments.exclude and not arguments.law):
        print(f"[random_mutation] --exclude takes law modules, with --law (not {unknown or arguments.exclude})",
              file=sys.stderr)
        return 2
    modules = tuple(name for name in LAW_MODULES if name not in arguments.exclude) if arguments.law else None
    if arguments.count:
        sites = [site for site in all_sites() if modules is None or site.module in modules]
        for kind, count in sorted(collections.Counter(site.kind for site in sites).items()):
            print(f"{kind:12s} {count}")
        print(f"{'all':12s} {len(sites)}")
        return 0
    if arguments.table:
        print(pooled_table([tallied(json.loads(path.read_text())) for path in arguments.table]))
        return 0
    if arguments.compare:
        text, agree = compared(*(json.loads(path.read_text()) for path in arguments.compare))
        print(text)
        return 0 if agree else 1
    try:
        fitting, held_out = seed_sets()
    except ValueError as error:
        print(f"[random_mutation] {error}", file=sys.stderr)
        return 2
    if arguments.held_out:
        seeds = held_out
    elif arguments.seed == ["fresh"]:
        seeds = [fresh_seed()]
    else:
        try:
            seeds = [int(seed) for seed in arguments.seed]
        except ValueError:
            print(f"[random_mutation] --seed takes integers or 'fresh', got {arguments.seed}", file=sys.stderr)
            return 2
    rerun = json.loads(arguments.rerun.read_text()) if arguments.rerun else None
    if rerun is not None:
        # A rerun's mutants are the earlier run's survivors: its result carries that run's seed, not --seed's.
        seeds = [rerun.get("seed", seeds[0])]
    refused = [seed for seed in seeds if seed not in fitting]
    if (arguments.list or rerun is not None) and refused:
        print(f"[random_mutation] seed {refused[0]} is not a fitting seed: its sample and survivors are kept for "
              f"scoring; list it in mutation_seeds.yaml under fitting first (it then no longer scores)",
              file=sys.stderr)
        return 2
    if arguments.list:
        for site in sample(seeds[0], arguments.sample, arguments.module, modules=modules):
            print(f"{site.module}:{site.line} {site.kind}: {site.change}    {site.source_line[:90]}")
        return 0
    if arguments.held_out and not seeds:
        print("[random_mutation] mutation_seeds.yaml lists no held-out seed", file=sys.stderr)
        return 2
    if arguments.held_out or arguments.out_dir is not None:
        folder = arguments.out_dir or REPO / "results"
        outs = [folder / f"random_mutation_{role_of(seed)}_seed{seed}.json" for seed in seeds]
    elif len(seeds) > 1:
        print("[random_mutation] several seeds write one JSON each: give --out-dir", file=sys.stderr)
        return 2
    else:
        outs = [arguments.out]
    try:
        results = run_draws(seeds, arguments.sample, arguments.timeout, outs, module=arguments.module,
                            modules=modules, echo=lambda text: print(text, flush=True), commit=arguments.commit,
                            baseline_timeout=arguments.baseline_timeout, rerun=rerun, jobs=arguments.jobs,
                            resume=arguments.resume, full_suite=arguments.full_suite)
    except RuntimeError as error:   # the unmutated tree failed or did not finish: no mutant can be judged
        print(f"[random_mutation] {error}", file=sys.stderr)
        return 2
    for result in results:
        print(_summary(result))
    if len(results) > 1 or arguments.law:
        print(pooled_table(results))
    counted = sum(result["non_equivalent"] for result in results)
    killed = sum(result["killed"] for result in results)
    return 0 if counted and killed / counted >= arguments.require else 1


if __name__ == "__main__":
    sys.exit(main())
