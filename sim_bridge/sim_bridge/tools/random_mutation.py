"""Seeded random mutation testing over all of fic_core, against test/core alone.

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
``ast.unparse`` into a copy of fic_core (the work tree is never touched); the tests are the files of test/core that
import the mutated module, directly or through another fic_core module, the direct importers first, with ``-x``
and a timeout (a hang counts as killed). Equivalent mutants (no behaviour can tell them from the original) are
listed with a reason in ``equivalent_mutants.yaml`` beside this file, keyed by module, enclosing function, source
line and mutation so that the key survives code moving up or down; they are not run and do not count in the kill
rate.

    source scripts/env.sh && python -m sim_bridge.tools.random_mutation --seed 1 --sample 60 [--out OUT.json]
    python -m sim_bridge.tools.random_mutation --count          # how many sites fic_core has, per kind
    python -m sim_bridge.tools.random_mutation --seed 1 --sample 60 --list   # the sample, without running it

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
import json
import os
import hashlib
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import yaml

from sim_bridge.tools.mutation_verdict import KILLED, SETTINGS_PLUGIN, pytest_verdict, write_settings_plugin

REPO = Path(__file__).resolve().parents[3]
PACKAGE = REPO / "fic_core" / "fic_core"
TESTS = REPO / "test" / "core"
EQUIVALENT_FILE = Path(__file__).resolve().parent / "equivalent_mutants.yaml"

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


def sample(seed: int, size: int, module: str | None = None, root: Path = REPO) -> list[Site]:
    """``size`` mutants drawn with ``seed`` from every site (of ``module`` only, when given): the sites whose
    seeded hash of their key is smallest, so that a change elsewhere in fic_core leaves the rest of a sample as
    it was (a draw by position in the list of sites would change with every line added)."""
    sites = [site for site in all_sites(root) if module is None or site.module == module]
    return sorted(sites, key=lambda site: hashlib.sha256(f"{seed}|{'|'.join(key(site))}".encode()).digest())[:size]


def snapshot(commit: str, folder: Path) -> Path:
    """The tree of ``commit`` extracted into ``folder`` (the mutants and the tests come from a commit, not the work
    tree, which other work may be changing while the run goes)."""
    archive = subprocess.run(["git", "archive", commit],
                             cwd=REPO, capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive, check=True)
    return folder


def _pytest(root: Path, folder: str, files: list[Path], timeout: float) -> subprocess.CompletedProcess:
    """pytest over ``files`` in the tree at ``root``, with the fic_core under ``folder`` first on the path."""
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


def run_mutant(site: Site, timeout: float, root: Path = REPO) -> tuple[str, str, float]:
    """(verdict, detail, seconds): KILLED with the first failing test (or a timeout), SURVIVED, ERROR, or NO
    TESTS."""
    direct, indirect = test_files(site.module, root)
    if not direct and not indirect:
        return "NO TESTS", f"no file of test/core imports {site.module}", 0.0
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
        for files in (direct, indirect):   # the direct importers first: most mutants are killed there
            if not files:
                continue
            try:
                result = _pytest(root, folder, files, timeout - (time.monotonic() - started))
            except subprocess.TimeoutExpired:
                return KILLED, f"{TIMEOUT_DETAIL} {timeout:.0f} s (a hang counts)", timeout
            if result.returncode != 0:
                break
        seconds = time.monotonic() - started
    verdict, detail = pytest_verdict(result)
    return verdict, detail, seconds


def matching(sites: list[Site], previous: dict, verdicts: tuple[str, ...] = ("SURVIVED",)) -> list[Site]:
    """The sites of ``previous`` (a run's JSON) with one of ``verdicts``, found again by module, source line and
    change (line numbers move with the code)."""
    wanted = {(row["module"], row.get("scope", ""), row["source_line"], row["change"]) for row in previous["mutants"]
              if row["verdict"] in verdicts}
    unscoped = {(module, line, change) for module, scope, line, change in wanted if not scope}
    return [site for site in sites
            if key(site) in wanted or (site.module, site.source_line, site.change) in unscoped]


def run(seed: int, size: int, timeout: float, module: str | None = None, out: Path | None = None,
        echo=print, commit: str = "HEAD", rerun: dict | None = None,
        baseline_timeout: float = BASELINE_TIMEOUT) -> dict:
    """Run a seeded sample of ``commit``'s fic_core against its test/core; returns (and writes to ``out``) every
    verdict and the kill rate. With ``rerun`` (an earlier run's JSON): its survivors again instead of a sample.
    Raises RuntimeError when test/core fails on the unmutated tree."""
    equivalent = equivalent_mutants()
    rows = []
    started = time.monotonic()
    revision = subprocess.run(["git", "rev-parse", commit], cwd=REPO, capture_output=True, text=True,
                              check=True).stdout.strip()
    with tempfile.TemporaryDirectory(prefix="fic_random_mutation_tree_") as tree:
        root = snapshot(revision, Path(tree))
        unmutated = baseline(root, baseline_timeout)
        if unmutated.returncode != 0:
            raise RuntimeError("test/core fails on the unmutated tree: " + unmutated.stdout.strip()[-400:])
        sites = len(all_sites(root))
        chosen = matching(all_sites(root), rerun) if rerun is not None else sample(seed, size, module, root)
        for number, site in enumerate(chosen, 1):
            reason = equivalent.get(key(site))
            if reason is not None:
                verdict, detail, seconds = "EQUIVALENT", reason, 0.0
            else:
                verdict, detail, seconds = run_mutant(site, timeout, root)
            rows.append({**asdict(site), "verdict": verdict, "detail": detail, "seconds": round(seconds, 1)})
            if out is not None:   # as it goes: an interrupted run keeps its verdicts
                out.parent.mkdir(parents=True, exist_ok=True)
                out.write_text(json.dumps({"commit": revision, "seed": seed, "partial": True, "mutants": rows},
                                          indent=2) + "\n")
            echo(f"{number:3d} {verdict:10s} {site.module}:{site.line} {site.kind}: {site.change}\n"
                 f"               {site.source_line[:100]}\n               {detail} ({seconds:.0f} s)")
    counted = [row for row in rows if row["verdict"] in ("KILLED", "SURVIVED", "NO TESTS")]
    killed = sum(row["verdict"] == "KILLED" for row in counted)
    timed_out = sum(row["verdict"] == "KILLED" and row["detail"].startswith(TIMEOUT_DETAIL) for row in counted)
    result = {"commit": revision, "seed": seed, "sample": len(rows), "sites": sites, "module": module,
              "equivalent": sum(row["verdict"] == "EQUIVALENT" for row in rows), "non_equivalent": len(counted),
              "killed": killed, "killed_by_timeout": timed_out,
              "kill_rate": round(killed / len(counted), 3) if counted else None,
              "seconds": round(time.monotonic() - started), "mutants": rows}
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(result, indent=2) + "\n")
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--sample", type=int, default=60, help="mutants drawn from all of fic_core's sites")
    parser.add_argument("--module", default=None, help="draw from this fic_core file only (e.g. limits.py)")
    parser.add_argument("--timeout", type=float, default=240.0, help="seconds for the tests of one mutant")
    parser.add_argument("--baseline-timeout", type=float, default=BASELINE_TIMEOUT,
                        help="seconds for test/core on the unmutated tree")
    parser.add_argument("--out", type=Path, default=None, help="write every verdict as JSON")
    parser.add_argument("--require", type=float, default=0.9, help="least kill rate of the non-equivalent mutants")
    parser.add_argument("--commit", default="HEAD", help="the commit whose fic_core and test/core are run")
    parser.add_argument("--rerun", type=Path, default=None,
                        help="run the survivors of an earlier --out JSON again (found by module, line text, change)")
    parser.add_argument("--list", action="store_true", help="print the sample and exit")
    parser.add_argument("--count", action="store_true", help="print the number of sites per kind and exit")
    arguments = parser.parse_args(argv)
    if arguments.count:
        sites = all_sites()
        for kind, count in sorted(collections.Counter(site.kind for site in sites).items()):
            print(f"{kind:12s} {count}")
        print(f"{'all':12s} {len(sites)}")
        return 0
    if arguments.list:
        for site in sample(arguments.seed, arguments.sample, arguments.module):
            print(f"{site.module}:{site.line} {site.kind}: {site.change}    {site.source_line[:90]}")
        return 0
    rerun = json.loads(arguments.rerun.read_text()) if arguments.rerun else None
    # A rerun's mutants are the earlier run's survivors: its result carries that run's seed, not --seed's default.
    seed = rerun.get("seed", arguments.seed) if rerun is not None else arguments.seed
    try:
        result = run(seed, arguments.sample, arguments.timeout, arguments.module, arguments.out,
                     echo=lambda text: print(text, flush=True), commit=arguments.commit, rerun=rerun,
                     baseline_timeout=arguments.baseline_timeout)
    except RuntimeError as error:   # the unmutated tree failed or did not finish: no mutant can be judged
        print(f"[random_mutation] {error}", file=sys.stderr)
        return 2
    print(f"commit {result['commit'][:10]}, seed {result['seed']}: {result['sample']} mutants of {result['sites']} "
          f"sites, {result['equivalent']} equivalent; killed {result['killed']} of {result['non_equivalent']} "
          f"(kill rate {result['kill_rate']}; {result['killed_by_timeout']} of the kills by the timeout) in "
          f"{result['seconds']} s")
    return 0 if result["kill_rate"] is not None and result["kill_rate"] >= arguments.require else 1


if __name__ == "__main__":
    sys.exit(main())
