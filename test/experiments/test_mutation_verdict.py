"""One reading of a pytest run over a mutant for both mutation tools
(fic_teleop_experiments/tools/mutation_verdict.py)."""
from __future__ import annotations

import subprocess

from fic_teleop_experiments.tools.mutation_verdict import ERROR, KILLED, SURVIVED, pytest_verdict, settings_plugin_text


def _run(code: int, stdout: str = "", stderr: str = "") -> subprocess.CompletedProcess:
    return subprocess.CompletedProcess(["pytest"], code, stdout, stderr)


def test_a_clean_run_is_a_survivor() -> None:
    assert pytest_verdict(_run(0, "12 passed in 1.0s\n")) == (SURVIVED, "every test passed")


def test_a_failing_test_kills_and_is_named() -> None:
    stdout = ("..F\nFAILED test/core/test_profile.py::test_monotone[3] - AssertionError\n"
              "FAILED test/core/test_limits.py::test_edge\n1 failed, 2 passed\n")
    assert pytest_verdict(_run(1, stdout)) == (KILLED, "test/core/test_profile.py::test_monotone[3]")


def test_a_module_that_no_longer_imports_kills_through_its_collection_error() -> None:
    stdout = "ERROR test/core/test_attractor.py - SyntaxError\n!!! Interrupted: 1 error during collection !!!\n"
    assert pytest_verdict(_run(2, stdout)) == (KILLED, "test/core/test_attractor.py")


def test_a_failure_without_a_named_test_still_kills_with_the_tail() -> None:
    verdict, detail = pytest_verdict(_run(1, "collected 3 items\nsegfault\n", "Fatal Python error"))
    assert verdict == KILLED and "segfault" in detail and "Fatal Python error" in detail


def test_pytest_that_could_not_judge_is_an_error_not_a_kill() -> None:
    for code, stdout in ((2, "!!! KeyboardInterrupt !!!\n"), (3, "INTERNALERROR> boom\n"),
                         (4, "ERROR: file or directory not found: test/nowhere\n"), (5, "no tests ran\n")):
        verdict, detail = pytest_verdict(_run(code, stdout))
        assert verdict == ERROR, code
        assert stdout.strip() in detail


def test_the_settings_plugin_derandomises_only_when_asked() -> None:
    assert "derandomize=True" in settings_plugin_text(derandomize=True)
    assert "derandomize" not in settings_plugin_text(derandomize=False)
    compile(settings_plugin_text(derandomize=True), "plugin", "exec")
