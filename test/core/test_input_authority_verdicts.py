"""Each verdict of the command authority says what was done to the command and nothing more (docs/SECURITY.md:
clamped onto the box, approached at the bounded speed), and its counts add up the same: a command outside the
workspace but within the rate bound is clamped and not rate-limited, first or later; one inside the box but too
far is rate-limited and not clamped."""
from __future__ import annotations

import numpy as np
from test_input_authority import NOW, command

from fic_core.input_authority import AuthorityBounds, CommandAuthority


def test_a_command_outside_the_box_within_the_rate_bound_is_clamped_only() -> None:
    authority = CommandAuthority(AuthorityBounds(max_offset_speed=1.0, max_offset_burst=0.05))
    first = authority.check(**command(now=NOW, desired_offset=[0.6, 0.0, 0.0]))   # the first: no rate bound yet
    assert first.accepted and first.clamped and not first.rate_limited
    np.testing.assert_array_equal(first.offset, [0.5, 0.0, 0.0])
    later = authority.check(**command(now=NOW + 0.01, desired_offset=[0.7, 0.005, 0.0]))   # 5 mm in 10 ms
    assert later.accepted and later.clamped and not later.rate_limited
    np.testing.assert_array_equal(later.offset, [0.5, 0.005, 0.0])
    assert "outside the workspace" in later.reason and "m/s" not in later.reason
    assert (authority.accepted, authority.clamped, authority.rate_limited) == (2, 2, 0)


def test_a_command_inside_the_box_but_too_far_is_rate_limited_only() -> None:
    authority = CommandAuthority(AuthorityBounds(max_offset_speed=1.0, max_offset_burst=0.05))
    authority.check(**command(now=NOW, desired_offset=[0.0, 0.0, 0.0]))
    jump = authority.check(**command(now=NOW + 0.01, desired_offset=[0.3, 0.0, 0.0]))
    assert jump.accepted and jump.rate_limited and not jump.clamped
    assert "beyond 1 m/s" in jump.reason and "outside the workspace" not in jump.reason
    assert (authority.accepted, authority.clamped, authority.rate_limited) == (2, 0, 1)
