"""The seeded random mutation run (fic_teleop_experiments/tools/random_mutation.py): on a loaded machine, test/core that
does not finish on the unmutated tree is one clear line and exit 2 (not a traceback), and kills by the timeout are
counted apart, as a slow run and a hang look alike when the machine is starved; a score comes only from a held-out draw
(a fitting seed's rate is a fit, a held-out draw's survivors cannot be rerun or its sample listed); a survivor has
passed all of test/core; the kill rate per law module. The pytest runs are replaced: what is checked is the tool's
own accounting."""
from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from fic_teleop_experiments.tools import line_coverage_map, random_mutation
from fic_teleop_experiments.tools.line_coverage_map import LineMap
from fic_teleop_experiments.tools.random_mutation import KILLED, Site


def _site(line: int) -> Site:
    return Site("limits.py", line, line, "comparison", "< -> <=", f"a < b  # {line}")


def test_test_core_that_does_not_finish_on_the_unmutated_tree_is_one_line_and_exit_2(monkeypatch, capsys) -> None:
    def slow(root: Path, folder: str, files: list[Path], timeout: float) -> subprocess.CompletedProcess:
        raise subprocess.TimeoutExpired(["pytest"], timeout)

    def slow_map(root: Path, timeout: float):
        raise subprocess.TimeoutExpired(["coverage"], timeout)

    monkeypatch.setattr(random_mutation, "snapshot", lambda commit, folder: random_mutation.REPO)
    monkeypatch.setattr(random_mutation, "_pytest", slow)
    with pytest.raises(RuntimeError, match="did not finish on the unmutated tree in 7 s"):
        random_mutation.baseline(random_mutation.REPO, 7.0)
    assert random_mutation.main(["--seed", "2", "--sample", "3", "--baseline-timeout", "7", "--full-suite"]) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and "--baseline-timeout" in error[0], error
    # The same with the line map, which is built by the unmutated run (none stored for this tree here).
    monkeypatch.setattr(line_coverage_map, "cached", lambda root, cache: None)
    monkeypatch.setattr(line_coverage_map, "build", slow_map)
    assert random_mutation.main(["--seed", "2", "--sample", "3", "--baseline-timeout", "7"]) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and "--baseline-timeout" in error[0], error


def test_kills_by_the_timeout_are_counted_apart(monkeypatch, tmp_path: Path) -> None:
    sites = [_site(10), _site(20), _site(30), _site(40)]
    verdicts = {10: (KILLED, "test/core/test_limits.py::test_edge", 3.0),
                20: (KILLED, f"{random_mutation.TIMEOUT_DETAIL} 900 s (a hang counts)", 900.0),
                30: ("SURVIVED", "every test passed", 4.0),
                40: (KILLED, f"{random_mutation.TIMEOUT_DETAIL} 900 s (a hang counts)", 900.0)}
    monkeypatch.setattr(random_mutation, "snapshot", lambda commit, folder: random_mutation.REPO)
    monkeypatch.setattr(random_mutation, "unmutated_line_map",
                        lambda root, timeout, cache, echo: LineMap("tree", (), {}))
    monkeypatch.setattr(random_mutation, "all_sites", lambda root: sites)
    monkeypatch.setattr(random_mutation, "sample", lambda seed, size, module, root, modules=None: sites)
    monkeypatch.setattr(random_mutation, "equivalent_mutants", lambda: {})
    monkeypatch.setattr(random_mutation, "run_mutant",
                        lambda site, timeout, root, chosen: (*verdicts[site.line], 1.0))
    result = random_mutation.run(2, 4, 900.0, out=tmp_path / "out.json", echo=lambda text: None)
    assert (result["killed"], result["killed_by_timeout"], result["non_equivalent"]) == (3, 2, 4)
    assert result["kill_rate"] == 0.75


def test_a_rerun_carries_the_seed_of_the_run_whose_survivors_it_reruns(monkeypatch, tmp_path: Path) -> None:
    earlier = tmp_path / "seed5.json"
    earlier.write_text('{"seed": 5, "mutants": []}')
    seen = {}

    def fake_run(seeds, size, timeout, outs, **kwargs) -> list[dict]:
        seen["seed"], seen["rerun"] = seeds[0], kwargs["rerun"]
        return [{"commit": "0" * 40, "seed": seeds[0], "role": "fitting", "drawn_from": "all", "rerun_of": "0",
                 "sample": 0, "sites": 0, "equivalent": 0, "non_equivalent": 0, "killed": 0, "killed_by_timeout": 0,
                 "kill_rate": None, "score": None, "seconds": 0, "mutants": []}]

    monkeypatch.setattr(random_mutation, "run_draws", fake_run)
    monkeypatch.setattr(random_mutation, "seed_sets", lambda: ({5}, [7]))
    random_mutation.main(["--rerun", str(earlier), "--require", "0"])
    assert seen == {"seed": 5, "rerun": {"seed": 5, "mutants": []}}


def _seeds_file(tmp_path: Path, fitting: list[int], held_out: list[int]) -> Path:
    path = tmp_path / "seeds.yaml"
    path.write_text("fitting:\n" + "".join(f"  - seed: {seed}\n    note: read\n" for seed in fitting)
                    + "held_out:\n" + "".join(f"  - {seed}\n" for seed in held_out))
    return path


def test_the_recorded_seed_sets_never_meet_and_a_fresh_seed_is_in_neither(tmp_path: Path) -> None:
    fitting, held_out = random_mutation.seed_sets()
    assert fitting and len(held_out) >= 3 and not fitting.intersection(held_out)
    assert {1, 2} <= fitting   # the draws whose survivors wrote tests before the held-out seeds were kept
    assert random_mutation.fresh_seed() not in fitting | set(held_out)
    with pytest.raises(ValueError, match="both fitting and held out"):
        random_mutation.seed_sets(_seeds_file(tmp_path, [3, 4], [4, 9]))
    path = _seeds_file(tmp_path, [3], [9])
    assert (random_mutation.role_of(3, path), random_mutation.role_of(9, path), random_mutation.role_of(11, path)) \
        == ("fitting", "held_out", "held_out")
    noted = tmp_path / "noted.yaml"   # a held-out seed may carry a note (when and why it was drawn), as fitting ones do
    noted.write_text("fitting:\n  - seed: 3\n    note: read\n"
                     "held_out:\n  - 9\n  - seed: 12\n    note: drawn for a score\n")
    assert random_mutation.seed_sets(noted) == ({3}, [9, 12])


def _fake_draws(monkeypatch, verdicts: dict[int, tuple[str, str, float]], modules: list[str]) -> None:
    sites = [Site(module, line, line, "comparison", "< -> <=", f"a < b  # {line}")
             for line, module in zip(sorted(verdicts), modules)]
    monkeypatch.setattr(random_mutation, "snapshot", lambda commit, folder: random_mutation.REPO)
    monkeypatch.setattr(random_mutation, "unmutated_line_map",
                        lambda root, timeout, cache, echo: LineMap("tree", (), {}))
    monkeypatch.setattr(random_mutation, "all_sites", lambda root: sites)
    monkeypatch.setattr(random_mutation, "sample", lambda seed, size, module, root, modules=None: sites)
    monkeypatch.setattr(random_mutation, "equivalent_mutants", lambda: {})
    monkeypatch.setattr(random_mutation, "run_mutant",
                        lambda site, timeout, root, chosen: (*verdicts[site.line], 1.0))


def test_only_a_held_out_draw_scores_and_each_law_module_gets_its_kill_rate(monkeypatch, tmp_path: Path) -> None:
    verdicts = {10: (KILLED, "test/core/test_limits.py::test_edge", 3.0), 20: ("SURVIVED", "every test passed", 4.0),
                30: (KILLED, "test/core/test_replica.py::test_x", 2.0), 40: (KILLED, "test/core/test_replica.py::y",
                                                                             2.0)}
    _fake_draws(monkeypatch, verdicts, ["limits.py", "limits.py", "replica.py", "replica.py"])
    monkeypatch.setattr(random_mutation, "SEEDS_FILE", _seeds_file(tmp_path, [3], [9]))
    fit, score = random_mutation.run_draws([3, 9], 4, 60.0, [None, tmp_path / "9.json"],
                                           modules=random_mutation.LAW_MODULES, echo=lambda text: None)
    assert (fit["role"], fit["score"], fit["kill_rate"]) == ("fitting", None, 0.75)
    assert (score["role"], score["score"], score["drawn_from"]) == ("held_out", 0.75, "law")
    assert "not a score" in random_mutation._summary(fit) and "score 0.75" in random_mutation._summary(score)
    assert list(score["per_module"]) == list(random_mutation.LAW_MODULES)   # every law module, drawn or not
    assert score["per_module"]["limits.py"] == {"drawn": 2, "equivalent": 0, "non_equivalent": 2, "killed": 1,
                                                "kill_rate": 0.5}
    assert score["per_module"]["replica.py"]["kill_rate"] == 1.0
    assert score["per_module"]["planner.py"] == {"drawn": 0, "equivalent": 0, "non_equivalent": 0, "killed": 0,
                                                 "kill_rate": None}
    table = random_mutation.pooled_table([fit, score])   # a column a draw, then the pooled figures
    assert "| limits | 4 | 0 | 1 / 2 | 1 / 2 | 2 / 4 | 0.500 |" in table
    assert "| replica | 4 | 0 | 2 / 2 | 2 / 2 | 4 / 4 | 1.000 |" in table
    assert "| planner | 0 | 0 | 0 / 0 | 0 / 0 | 0 / 0 | - |" in table
    assert "| all | 8 | 0 | 3 / 4 | 3 / 4 | 6 / 8 | 0.750 |" in table
    assert "| limits | 2 | 0 | 1 / 2 | 0.500 |" in random_mutation.pooled_table([score])   # one draw: no column


def test_a_held_out_draw_can_be_neither_listed_nor_rerun(monkeypatch, tmp_path: Path, capsys) -> None:
    monkeypatch.setattr(random_mutation, "SEEDS_FILE", _seeds_file(tmp_path, [3], [9]))
    monkeypatch.setattr(random_mutation, "run_draws", lambda *arguments, **kwargs: pytest.fail("a mutant ran"))
    earlier = tmp_path / "seed9.json"
    earlier.write_text('{"seed": 9, "mutants": []}')
    for argv in (["--seed", "9", "--list"], ["--rerun", str(earlier)], ["--seed", "fresh", "--list"]):
        assert random_mutation.main(argv) == 2, argv
        error = capsys.readouterr().err.strip().splitlines()
        assert len(error) == 1 and "not a fitting seed" in error[0], error
    assert random_mutation.main(["--seed", "3", "--list", "--sample", "2"]) == 0
    assert len(capsys.readouterr().out.strip().splitlines()) == 2


def test_a_mutant_the_importers_leave_alive_runs_the_rest_of_test_core(monkeypatch) -> None:
    runs: list[list[Path]] = []

    def passing(root: Path, folder: str, files: list[Path], timeout: float) -> subprocess.CompletedProcess:
        runs.append(files)
        return subprocess.CompletedProcess(["pytest"], 0, "passed", "")

    monkeypatch.setattr(random_mutation, "_pytest", passing)
    site = next(site for site in random_mutation.all_sites() if site.module == "limits.py")
    verdict, *_ = random_mutation.run_mutant(site, 60.0)
    assert verdict == "SURVIVED"
    every = sorted((random_mutation.REPO / "test" / "core").glob("test_*.py"))
    assert sorted(path for files in runs for path in files) == every   # each file once, all of them
    direct, _ = random_mutation.test_files("limits.py")
    assert runs[0] == direct


def test_the_law_modules_are_fic_core_files() -> None:
    assert len(random_mutation.LAW_MODULES) == 19
    assert all((random_mutation.PACKAGE / name).is_file() for name in random_mutation.LAW_MODULES)


def test_every_equivalence_claim_names_a_site_of_fic_core_and_gives_its_reason() -> None:
    """A claim whose line or change no longer exists would excuse nothing and mislead: each must key a site of the
    tree as it is, with a reason (a sentence at least)."""
    sites = {random_mutation.key(site) for site in random_mutation.all_sites()}
    claims = random_mutation.equivalent_mutants()
    assert claims
    for claim, reason in claims.items():
        assert claim in sites, claim
        assert len(reason.split()) >= 5, claim


def test_a_draw_can_leave_law_modules_out_and_says_so(monkeypatch, tmp_path: Path, capsys) -> None:
    seen = {}

    def fake_run(seeds, size, timeout, outs, **kwargs) -> list[dict]:
        seen["modules"] = kwargs["modules"]
        return []

    monkeypatch.setattr(random_mutation, "run_draws", fake_run)
    random_mutation.main(["--seed", "3", "--law", "--exclude", "set_point.py", "desired_pose.py", "--require", "0"])
    assert len(seen["modules"]) == 17 and "set_point.py" not in seen["modules"] and "limits.py" in seen["modules"]
    assert random_mutation._scope_name(seen["modules"]) == "law without set_point.py, desired_pose.py"
    assert random_mutation._scope_name(random_mutation.LAW_MODULES) == "law"
    assert random_mutation.main(["--seed", "3", "--exclude", "limits.py"]) == 2
    assert random_mutation.main(["--seed", "3", "--law", "--exclude", "robot_model.py"]) == 2
    assert "--exclude takes law modules" in capsys.readouterr().err


def test_several_seeds_write_one_json_each_named_by_role(monkeypatch, tmp_path: Path, capsys) -> None:
    monkeypatch.setattr(random_mutation, "SEEDS_FILE", _seeds_file(tmp_path, [3], [9, 11]))
    seen = {}

    def fake_run(seeds, size, timeout, outs, **kwargs) -> list[dict]:
        seen["seeds"], seen["outs"] = seeds, outs
        return []

    monkeypatch.setattr(random_mutation, "run_draws", fake_run)
    random_mutation.main(["--seed", "9", "3", "--out-dir", str(tmp_path), "--require", "0"])
    assert seen == {"seeds": [9, 3], "outs": [tmp_path / "random_mutation_held_out_seed9.json",
                                              tmp_path / "random_mutation_fitting_seed3.json"]}
    random_mutation.main(["--held-out", "--out-dir", str(tmp_path), "--require", "0"])
    assert seen["seeds"] == [9, 11]
    assert random_mutation.main(["--seed", "9", "11"]) == 2   # two draws, one --out
    assert "give --out-dir" in capsys.readouterr().err


def test_a_resumed_draw_keeps_the_verdicts_its_interrupted_run_left_and_runs_the_rest(monkeypatch,
                                                                                       tmp_path: Path) -> None:
    verdicts = {10: (KILLED, "test/core/test_limits.py::test_edge", 3.0), 20: ("SURVIVED", "every test passed", 4.0),
                30: (KILLED, "test/core/test_replica.py::test_x", 2.0)}
    _fake_draws(monkeypatch, verdicts, ["limits.py", "limits.py", "replica.py"])
    monkeypatch.setattr(random_mutation, "SEEDS_FILE", _seeds_file(tmp_path, [3], [9]))
    out = tmp_path / "9.json"
    first = random_mutation.run_draws([9], 3, 60.0, [out], modules=random_mutation.LAW_MODULES,
                                      echo=lambda text: None)[0]
    rows = first["mutants"]
    rows[2]["verdict"], rows[2]["detail"] = "ERROR", "interrupted"   # says nothing: run again
    out.write_text(json.dumps({**{field: first[field] for field in ("commit", "seed", "role", "drawn_from")},
                               "partial": True, "mutants": rows}))
    ran = []
    monkeypatch.setattr(random_mutation, "run_mutant",
                        lambda site, timeout, root, chosen: ran.append(site.line) or (*verdicts[site.line], 1.0))
    resumed = random_mutation.run_draws([9], 3, 60.0, [out], modules=random_mutation.LAW_MODULES,
                                        echo=lambda text: None, resume=True)[0]
    assert ran == [30] and resumed["killed"] == 2 and resumed["score"] == first["score"]
    assert [row["seconds"] for row in resumed["mutants"]] == [3.0, 4.0, 2.0]
    ran.clear()   # another seed's file, or without --resume: every mutant runs
    random_mutation.run_draws([9], 3, 60.0, [out], modules=random_mutation.LAW_MODULES, echo=lambda text: None)
    assert ran == [10, 20, 30]
    assert random_mutation.judged_before(out, {"commit": first["commit"], "seed": 11, "drawn_from": "law"}) == {}


def test_an_interrupted_draw_is_tallied_over_what_it_judged_and_gives_no_score(monkeypatch, tmp_path: Path) -> None:
    verdicts = {10: (KILLED, "test/core/test_limits.py::test_edge", 3.0), 20: ("SURVIVED", "every test passed", 4.0)}
    _fake_draws(monkeypatch, verdicts, ["limits.py", "replica.py"])
    monkeypatch.setattr(random_mutation, "SEEDS_FILE", _seeds_file(tmp_path, [3], [9]))
    whole = random_mutation.run_draws([9], 2, 60.0, [None], modules=random_mutation.LAW_MODULES,
                                      echo=lambda text: None)[0]
    interrupted = {field: whole[field] for field in ("commit", "seed", "role", "drawn_from")}
    interrupted |= {"partial": True, "mutants": whole["mutants"][:1]}
    tally = random_mutation.tallied(interrupted)
    assert (tally["sample"], tally["killed"], tally["kill_rate"], tally["score"]) == (1, 1, 1.0, None)
    assert tally["per_module"]["limits.py"]["killed"] == 1 and random_mutation.tallied(whole) is whole
    assert "held_out, partial" in random_mutation.pooled_table([tally])


def test_two_lines_of_the_same_text_in_one_scope_each_run_their_own_lines_tests(tmp_path: Path) -> None:
    """Two mutants that ``key`` cannot tell apart (same module, scope, text and change: kept together for
    equivalence reasons and reruns) are two mutants of the tree: each runs the tests that execute its own line."""
    module = tmp_path / "fic_core" / "fic_core" / "twice.py"
    module.parent.mkdir(parents=True)
    module.write_text("def f(a, b):\n    if a:\n        b = 0.0\n    else:\n        b = 0.0\n    return b\n")
    sites = [site for site in random_mutation.sites_of("twice.py", module.read_text()) if site.kind == "constant"]
    assert [site.line for site in sites] == [3, 5] and random_mutation.key(sites[0]) == random_mutation.key(sites[1])
    line_map = LineMap("tree", ("test_twice.py::test_a", "test_twice.py::test_b"), {"twice.py": {3: (0,), 5: (1,)}})
    chosen = random_mutation.selections_of(sites, tmp_path, line_map)
    assert [chosen[random_mutation.site_id(site)].tests for site in sites] == [("test_twice.py::test_a",),
                                                                               ("test_twice.py::test_b",)]
