"""limits.LIMIT_FLAGS, the LimitFlag of every combination of the five limits by its int value (the replica's tick
and the postural optimisation look flags up there): exactly the 32 combinations, each its LimitFlag, and no other
value (a value that is no combination of the limits would be a flag no status message can carry)."""
from __future__ import annotations

import itertools

from fic_core.limits import LIMIT_FLAGS, LimitFlag

LIMITS = [flag for flag in LimitFlag if flag != LimitFlag.NONE]


def test_the_table_holds_every_combination_of_the_limits_and_nothing_else() -> None:
    combinations = set()
    for count in range(len(LIMITS) + 1):
        for chosen in itertools.combinations(LIMITS, count):
            value = 0
            for flag in chosen:
                value |= flag.value
            combinations.add(value)
    assert len(LIMITS) == 5 and len(combinations) == 32
    assert set(LIMIT_FLAGS) == combinations
    for value, flag in LIMIT_FLAGS.items():
        assert flag == LimitFlag(value) and flag.value == value
        assert {member for member in LIMITS if member & flag} == {member for member in LIMITS if member.value & value}
