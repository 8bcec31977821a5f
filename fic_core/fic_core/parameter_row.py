"""One parameter of a node or station: name, kind, meaning, range, fixed at start or not, and the one check of a
value against it.

Every table of parameters is made of these rows: fic_core's own (``replica_parameters``, ``master_station``,
``channel_ports``, ``exchanged_energy_ports``), which the in-process runner checks values against, and the nodes'
schemas (``fic_teleop_runtime.parameters``), which declare them on rclpy with the same range as a descriptor and
read the params files under config/ through ``checked``. So a range is written once and refused the same way by
fic_core, by the params-file loader and (through the descriptor) by rclpy.

A table also gives its station a typed object (``parameter_set``): a frozen dataclass generated at import from the
same rows, one field a row, so a station reads ``parameters.stiffness`` where it looked up ``values["stiffness"]``,
and a name that is not in the table is refused where the object is built, in one line naming the nearest one.
"""
from __future__ import annotations

import array
import dataclasses
import difflib
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from enum import Enum
from typing import Any, ClassVar, TypeVar

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


def nearest_name_hint(name: str, known: Sequence[str], otherwise: str | None = None) -> str:
    """``; did you mean 'x'?`` for the declared name nearest ``name``, else ``otherwise`` (default: the declared
    names)."""
    close = difflib.get_close_matches(name, known, n=1, cutoff=0.6)
    if close:
        return f"; did you mean {close[0]!r}?"
    return f"; declared: {', '.join(sorted(known))}" if otherwise is None else otherwise


#: The Python type of each kind's value, as ``ParameterRow.checked`` returns it.
PYTHON_TYPES = {Kind.NUMBER: float, Kind.INTEGER: int, Kind.SWITCH: bool, Kind.TEXT: str, Kind.NUMBERS: list[float],
                Kind.INTEGERS: list[int], Kind.TEXTS: list[str]}

Parameters = TypeVar("Parameters", bound="ParameterSet")


class ParameterSet:
    """What every generated parameter set (``parameter_set``) has besides its fields: its rows, and the two ways to
    build one from names and values, both checked against the rows."""

    __slots__ = ()
    ROWS: ClassVar[dict[str, ParameterRow]]
    OWNER: ClassVar[str]   # whose parameters, for the refusals ("master")

    @classmethod
    def _checked(cls, values: Mapping[str, Any]) -> dict[str, Any]:
        for name in values:
            if name not in cls.ROWS:
                raise FicInputError(f"unknown {cls.OWNER} parameter {name!r}{nearest_name_hint(name, list(cls.ROWS))}")
        return {name: cls.ROWS[name].checked(value) for name, value in values.items()}

    @classmethod
    def from_values(cls: type[Parameters], values: Mapping[str, Any]) -> Parameters:
        """Every row's value from ``values`` (a node's declared values, or config/<node>.yaml's with overrides),
        each checked against its row; FicInputError names a key no row has (and the nearest row), the first value
        of the wrong type or out of its range, or the rows not given."""
        checked = cls._checked(values)
        missing = [name for name in cls.ROWS if name not in checked]
        if missing:
            raise FicInputError(f"{cls.OWNER} parameters missing: {', '.join(missing)}")
        return cls(**checked)

    def replaced(self: Parameters, changes: Mapping[str, Any]) -> Parameters:
        """A copy with ``changes`` (names of rows, each value checked against its row)."""
        return dataclasses.replace(self, **type(self)._checked(changes))

    def part(self, kind: type[Parameters]) -> Parameters:
        """The values of ``kind``'s rows (a set of some of this set's rows: a station's part takes its own), as a
        ``kind``; checked already, by the same rows."""
        return kind(**{name: getattr(self, name) for name in kind.ROWS})


def parameter_set(class_name: str, module: str, owner: str, rows: Iterable[ParameterRow],
                  doc: str) -> type[ParameterSet]:
    """A frozen dataclass named ``class_name`` in ``module`` (the module that binds it to that name), one field a
    row in the rows' order, typed by its kind (``PYTHON_TYPES``): the typed object a station takes
    (``ParameterSet.from_values``); ``owner`` names whose parameters they are in a refusal."""
    table = rows_by_name(*rows)
    return dataclasses.make_dataclass(
        class_name, [(name, PYTHON_TYPES[row.kind]) for name, row in table.items()], bases=(ParameterSet,),
        namespace={"__doc__": doc, "ROWS": table, "OWNER": owner, "__module__": module}, frozen=True, slots=True)
