"""One parameter of a node or station: name, kind, meaning, range, fixed at start or not, and the one check of a
value against it.

Every table of parameters is made of these rows: fic_core's own (``replica_parameters``, ``master_station``,
``channel_ports``, ``exchanged_energy_ports``), which the in-process runner checks values against, and the nodes'
schemas (``fic_teleop_runtime.parameters``), which declare them on rclpy with the same range as a descriptor and
read the params files under config/ through ``checked``. So a range is written once and refused the same way by
fic_core, by the params-file loader and (through the descriptor) by rclpy.
"""
from __future__ import annotations

import array
import math
from dataclasses import dataclass
from enum import Enum
from typing import Any

from .errors import FicInputError


class Kind(Enum):
    """What a row holds; ``fic_teleop_runtime.parameters`` maps each to rclpy's parameter type."""

    NUMBER = "number"
    INTEGER = "integer"
    SWITCH = "switch"
    TEXT = "text"
    NUMBERS = "numbers"
    INTEGERS = "integers"
    TEXTS = "texts"


LISTS = (Kind.NUMBERS, Kind.INTEGERS, Kind.TEXTS)


@dataclass(frozen=True)
class ParameterRow:
    """``low``/``high`` bound a number or each item of a list of numbers (inclusive); ``read_only``: fixed at
    start; ``optional``: may be left unset (a list whose absence means none)."""

    name: str
    kind: Kind
    description: str
    low: float | None = None
    high: float | None = None
    read_only: bool = False
    optional: bool = False

    def checked(self, value: Any, where: str = "", exact: bool = False) -> Any:
        """``value`` of this row's kind and inside its range; FicInputError names the row (after ``where``).

        ``exact``: as rcl reads a params file, a number must be written as a double (``200.0``: rcl reads ``200``
        as an integer and rclpy then refuses it for a double); otherwise an integer is a number too (in-process
        values) and comes back as a float."""
        def fail(expected: str) -> FicInputError:
            return FicInputError(f"{where + ': ' if where else ''}{self.name} must be {expected}, got {value!r}")

        def number(item: Any) -> float:
            if isinstance(item, float):
                return item
            if not exact and isinstance(item, int) and not isinstance(item, bool):
                return float(item)
            raise fail("a number with a decimal point (a double)" if exact else "a number")

        def integer(item: Any) -> int:
            if isinstance(item, bool) or not isinstance(item, int):
                raise fail("an integer")
            return item

        kind = self.kind
        if kind == Kind.NUMBER:
            value = number(value)
        elif kind == Kind.INTEGER:
            value = integer(value)
        elif kind == Kind.SWITCH:
            if not isinstance(value, bool):
                raise fail("true or false")
        elif kind == Kind.TEXT:
            if not isinstance(value, str):
                raise fail("a string")
        else:
            # rclpy hands a double or integer array set at run time as an array.array.
            if not isinstance(value, (list, tuple, array.array)):
                raise fail(f"a list of {kind.value}")
            if kind == Kind.TEXTS and not all(isinstance(item, str) for item in value):
                raise fail("a list of strings")
            value = [number(item) for item in value] if kind == Kind.NUMBERS else \
                [integer(item) for item in value] if kind == Kind.INTEGERS else list(value)
        if self.low is not None and self.high is not None:
            items = value if isinstance(value, list) else [value]
            if not all(math.isfinite(item) and self.low <= item <= self.high for item in items):
                raise fail(f"in [{self.low:g}, {self.high:g}]")
        return value


def number(name: str, low: float, high: float, description: str, read_only: bool = False) -> ParameterRow:
    return ParameterRow(name, Kind.NUMBER, description, low, high, read_only)


def integer(name: str, low: int, high: int, description: str, read_only: bool = False) -> ParameterRow:
    return ParameterRow(name, Kind.INTEGER, description, low, high, read_only)


def switch(name: str, description: str, read_only: bool = False) -> ParameterRow:
    return ParameterRow(name, Kind.SWITCH, description, read_only=read_only)


def text(name: str, description: str, read_only: bool = False) -> ParameterRow:
    return ParameterRow(name, Kind.TEXT, description, read_only=read_only)


def numbers(name: str, description: str, read_only: bool = False, optional: bool = False) -> ParameterRow:
    return ParameterRow(name, Kind.NUMBERS, description, read_only=read_only, optional=optional)


def texts(name: str, description: str, read_only: bool = False, optional: bool = False) -> ParameterRow:
    return ParameterRow(name, Kind.TEXTS, description, read_only=read_only, optional=optional)


def rows_by_name(*rows: ParameterRow) -> dict[str, ParameterRow]:
    """A table of rows by name (ValueError on a name given twice)."""
    table: dict[str, ParameterRow] = {}
    for row in rows:
        if row.name in table:
            raise ValueError(f"parameter {row.name!r} given twice")
        table[row.name] = row
    return table
