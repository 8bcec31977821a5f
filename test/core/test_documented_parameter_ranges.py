"""The master's and the input authority's parameter ranges as docs/INTERFACES.md states them to the user, both
ends inclusive: the core's check (the typed parameter object, which the nodes' params-file loader and rclpy's
descriptors share) takes each documented end and refuses the next float past it in one line naming the parameter and
its range. Every numeric row is documented, and nothing else is."""
from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import pytest
from config_values import config_values

from fic_core.errors import FicInputError
from fic_core.input_authority import AUTHORITY_PARAMETERS, AuthorityParameters
from fic_core.master_station import MASTER_PARAMETERS, MasterParameters

INTERFACES = Path(__file__).resolve().parents[2] / "docs" / "INTERFACES.md"
ROW = re.compile(r"^\| `(?P<name>[a-z_]+)` \| (?P<low>[0-9.]+) to (?P<high>[0-9.]+) \|")


def documented_ranges(section: str) -> dict[str, tuple[float, float]]:
    """The ``| `name` | low to high |`` rows of one node's section (from its heading to the next one)."""
    text = INTERFACES.read_text()
    start = text.index(f"### {section} (")
    end = text.index("\n### ", start + 1)
    ranges = {}
    for line in text[start:end].splitlines():
        match = ROW.match(line)
        if match:
            ranges[match["name"]] = (float(match["low"]), float(match["high"]))
    return ranges


MASTER = documented_ranges("master")
AUTHORITY = documented_ranges("replica")
MASTER_VALUES = config_values("master.yaml")
REPLICA_VALUES = config_values("replica.yaml")


def _numeric(table: dict[str, Any]) -> set[str]:
    return {name for name, row in table.items() if row.low is not None}


def test_every_numeric_row_is_documented_and_nothing_else() -> None:
    assert set(MASTER) == _numeric(MASTER_PARAMETERS) and len(MASTER) == 29
    assert set(AUTHORITY) == _numeric(AUTHORITY_PARAMETERS) and len(AUTHORITY) == 5


def _master(name: str, value: Any) -> Any:
    return getattr(MasterParameters.from_values({**MASTER_VALUES, name: value}), name)


def _authority(name: str, value: Any) -> Any:
    values = {key: REPLICA_VALUES[key] for key in AUTHORITY_PARAMETERS}
    return getattr(AuthorityParameters.from_values({**values, name: value}), name)


CASES = [(_master, name, ends) for name, ends in sorted(MASTER.items())] + \
        [(_authority, name, ends) for name, ends in sorted(AUTHORITY.items())]


@pytest.mark.parametrize(("build", "name", "ends"), CASES, ids=[case[1] for case in CASES])
def test_each_documented_end_is_taken_and_the_next_value_past_it_refused(build: Any, name: str,
                                                                          ends: tuple[float, float]) -> None:
    low, high = ends
    integer = name == "mode"
    for end in (low, high):
        value = int(end) if integer else end
        assert build(name, value) == value
    past = (int(low) - 1, int(high) + 1) if integer else \
        (math.nextafter(low, -math.inf), math.nextafter(high, math.inf))
    for value in past:
        with pytest.raises(FicInputError) as refused:
            build(name, value)
        message = str(refused.value)
        assert name in message and f"in [{low:g}, {high:g}]" in message and "\n" not in message
