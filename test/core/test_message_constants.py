"""fic_core's enums and the master's mode row carry the values of fic_teleop_msgs' constants (each enum's
docstring says so): a node copies the enum's int into a message field, and the recorder, the live view and the
report read it back by the message's constant names."""
from __future__ import annotations

import re
from enum import IntEnum, IntFlag
from pathlib import Path

import pytest

from fic_core.attractor import Phase
from fic_core.guidance_fixture import FixtureKind
from fic_core.input_authority import MODES
from fic_core.limits import LimitFlag
from fic_core.master_station import MASTER_PARAMETERS, Engagement
from fic_core.teleoperation import TeleoperationMode

MESSAGES = Path(__file__).resolve().parents[2] / "fic_teleop_msgs" / "msg"


def message_constants(message: str, prefix: str) -> dict[str, int]:
    """``TYPE NAME=VALUE`` lines of a .msg file whose NAME starts with ``prefix``, by NAME without it."""
    constants = {}
    for line in (MESSAGES / f"{message}.msg").read_text().splitlines():
        match = re.match(r"\s*u?int\d+\s+([A-Z_]+)\s*=\s*(\d+)", line)
        if match and match.group(1).startswith(prefix):
            constants[match.group(1)[len(prefix):]] = int(match.group(2))
    return constants


@pytest.mark.parametrize(("enum", "message", "prefix", "own"), [
    (Phase, "FicState", "PHASE_", {}),
    (Engagement, "OperatorTools", "ENGAGEMENT_", {}),
    (FixtureKind, "OperatorTools", "FIXTURE_", {}),
    (TeleoperationMode, "TeleoperationCommand", "MODE_", {}),
    (LimitFlag, "LimitStatus", "", {"NONE": 0}),   # the empty mask: the message's field is 0, no constant
])
def test_each_enum_has_its_messages_constants_name_for_name(enum: type[IntEnum] | type[IntFlag], message: str,
                                                             prefix: str, own: dict[str, int]) -> None:
    constants = message_constants(message, prefix)
    assert constants, f"no {prefix}* constants in {message}.msg"
    assert {name: int(member) for name, member in enum.__members__.items()} == {**constants, **own}


def test_the_limit_flags_are_one_bit_each() -> None:
    constants = message_constants("LimitStatus", "")
    assert sorted(constants.values()) == [1, 2, 4, 8, 16]


def test_the_masters_mode_row_admits_exactly_the_messages_modes() -> None:
    """The mode is declared with its range; a value no TeleoperationCommand mode has is refused at the row."""
    modes = sorted(message_constants("TeleoperationCommand", "MODE_").values())
    row = MASTER_PARAMETERS["mode"]
    assert (row.low, row.high) == (modes[0], modes[-1]) == (0, 1)
    for mode in modes:
        assert row.checked(mode) == mode
    with pytest.raises(ValueError, match="mode"):
        row.checked(modes[-1] + 1)


def test_the_replica_admits_exactly_the_messages_modes() -> None:
    """The input authority's modes (a command with another is refused) are TeleoperationCommand's MODE_*."""
    assert tuple(sorted(MODES)) == tuple(sorted(message_constants("TeleoperationCommand", "MODE_").values()))
