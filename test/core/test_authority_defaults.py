"""The input authority's default bounds are the documented envelope (docs/SECURITY.md, "What an input may ask of
the arm") and the shipped one (config/replica.yaml): an authority built without arguments, as the in-process
runner's and the tests' are, judges as the replica node does. The bounds are one immutable value: a component
handed them cannot widen them for the others."""
from __future__ import annotations

import dataclasses

import pytest
from config_values import config_values

from fic_core.input_authority import AUTHORITY_PARAMETERS, AuthorityBounds, AuthorityParameters


def test_the_defaults_are_the_documented_envelope() -> None:
    bounds = AuthorityBounds()
    assert bounds.offset_lower == (-0.5, -0.5, -0.5) and bounds.offset_upper == (0.5, 0.5, 0.5)   # +-0.5 m
    assert (bounds.max_offset_speed, bounds.max_offset_burst) == (1.0, 0.05)      # 1 m/s, 5 cm at once
    assert (bounds.future_tolerance, bounds.max_age) == (0.5, 3.0)                # 0.5 s ahead, 3 s behind
    assert bounds.haptic_gain == (0.0, 1.0) and bounds.workspace_scale == (0.01, 100.0)
    assert bounds.velocity_gain == (0.0, 100.0) and bounds.max_handle_position == 10.0


def test_the_defaults_are_the_shipped_bounds() -> None:
    values = config_values("replica.yaml")
    shipped = AuthorityBounds.from_parameters(AuthorityParameters.from_values(
        {name: values[name] for name in AUTHORITY_PARAMETERS}))
    assert shipped == AuthorityBounds()


def test_the_bounds_cannot_be_changed_once_made() -> None:
    bounds = AuthorityBounds()
    with pytest.raises(dataclasses.FrozenInstanceError):
        bounds.max_offset_speed = 10.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        bounds.offset_upper = (2.0, 2.0, 2.0)
    assert bounds == AuthorityBounds()
