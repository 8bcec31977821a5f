"""The stable verdict's tests (fic_teleop_tools.verdict.run_verdict), each named by how the reasons it gives begin,
and how many of a set of judged runs failed each: the claims report counts them per law and cell
(claims_report.law_statistics), the claims tables give them a column each (tables.claims_markdown)."""
from __future__ import annotations

from collections.abc import Sequence

#: test name -> the start of its reasons.
UNSTABLE_TESTS = {"tail motion": "free oscillation in the quiet tail",
                  "tail energy": "energy does not decay in the quiet tail",
                  "oscillation (no tail)": "sustained oscillation", "growing energy": "growing energy",
                  "port generation": "steady energy generation", "runaway": "runaway", "parked": "parked"}


def unstable_by_test(rows: Sequence[dict]) -> dict[str, int]:
    """How many of the judged runs each stable test failed (a run may fail several): what a reader needs to see
    whether one test, or one threshold, decides a law's share."""
    counts = dict.fromkeys(UNSTABLE_TESTS, 0)
    for row in rows:
        reasons = row.get("verdict", {}).get("stable_reasons", []) if isinstance(row.get("verdict"), dict) else []
        for test, start in UNSTABLE_TESTS.items():
            counts[test] += any(reason.startswith(start) for reason in reasons)
    return counts
