"""What a pytest run over a mutated fic_core says about the mutant: one reading for the hand-picked mutations
(mutation_check.py) and the seeded random ones (random_mutation.py).

A mutant is KILLED when a test fails (exit code 1, or 2 with a test listed: a module that no longer imports is a
collection error, which stops the session under -x; the first failing or erroring test id is the detail), SURVIVED
when every test passed, and ERROR when pytest could not judge it (interrupted with no test named, an internal or
usage error, no tests collected: exit codes 2-5), which says nothing about the mutant and counts neither way.
A run that does not finish in its time is a kill (a hang is a behaviour the tests noticed); the callers report
that case, as only they hold the timeout.
"""
from __future__ import annotations

import re
import subprocess
from pathlib import Path

KILLED = "KILLED"
SURVIVED = "SURVIVED"
ERROR = "ERROR"

_TESTS_FAILED = 1     #: pytest's exit code when a test failed
_INTERRUPTED = 2      #: pytest's exit code when the session stopped early (a collection error under -x)

SETTINGS_PLUGIN = "fic_mutation_settings"


def settings_plugin_text(derandomize: bool, timing_free: bool = False) -> str:
    """A pytest plugin loaded with ``-p SETTINGS_PLUGIN``: hypothesis reports the first failing example as it
    finds it, without shrinking (shrinking one failing attractor simulation took minutes; a mutant only has to be
    killed) and without an example database (one mutant's failing examples would be replayed under the next).
    ``derandomize`` draws the same examples for the unmutated tree and every mutant, so a property that fails on
    rare random examples neither fails the baseline by chance nor counts as a kill. ``timing_free`` drops the
    deadline and the health checks, which time a test but choose no example (for a run under coverage, which is
    slower: line_coverage_map.py)."""
    timing = ", deadline=None, suppress_health_check=list(HealthCheck)" if timing_free else ""
    return ("from hypothesis import HealthCheck, Phase, settings\n\n"
            "settings.register_profile(\"mutation\", phases=(Phase.explicit, Phase.generate), database=None"
            f"{', derandomize=True' if derandomize else ''}{timing})\n"
            "settings.load_profile(\"mutation\")\n")


def write_settings_plugin(folder: Path, derandomize: bool, timing_free: bool = False) -> None:
    """Write the plugin next to the mutated copy of fic_core (that folder leads PYTHONPATH)."""
    (Path(folder) / f"{SETTINGS_PLUGIN}.py").write_text(settings_plugin_text(derandomize, timing_free))


def pytest_verdict(result: subprocess.CompletedProcess) -> tuple[str, str]:
    """(verdict, detail) of one finished pytest run over a mutant (run with ``-rfE``, so failures are listed as
    ``FAILED <id>`` / ``ERROR <id>`` lines)."""
    if result.returncode == 0:
        return SURVIVED, "every test passed"
    failed = re.findall(r"^(?:FAILED|ERROR) (\S+)", result.stdout or "", flags=re.MULTILINE)
    if result.returncode in (_TESTS_FAILED, _INTERRUPTED) and failed:
        return KILLED, failed[0]
    tail = (result.stdout or "").strip().splitlines()[-2:] + (result.stderr or "").strip().splitlines()[-2:]
    detail = " | ".join(tail)[:300]
    return (KILLED if result.returncode == _TESTS_FAILED else ERROR), detail
