"""Each node's parameters as one declarative table (fic_core.parameter_row rows), the one place a node declares them
from.

One source for each value: a row holds the name, type, description, range and whether it is fixed at start; the
default lives only in the node's file under config/ (``config/<node>.yaml``, or the one the row table names).
``declare`` reads the node's section of that file (``/**`` then the node's own name, as rcl applies a params file)
and declares every row with it, so ``param describe`` shows the description and range and a value outside the range
is refused by rclpy itself; a params file or ``-p`` given at start still overrides it.

Why the nodes read config/ rather than the config files being generated from the tables: the files are what an
operator edits and what the launcher passes, with their comments on why each value is what it is; a generator
would either lose those or need them copied into code, a second home for the same words. The tables hold what the
code must know (type, range, meaning); test/runtime/test_parameter_schemas.py loads every file under config/ against
them (every key declared, of its type and inside its range, every declared key given by the node's own file).

A key that no row declares is refused at start, in one line naming it and the nearest declared key: rclpy would
otherwise ignore it, and a misspelt ``translaton_stiffness`` would leave the arm at the default stiffness without
a word. An empty list has no type in a params file (rcl reads ``lockstep_peers: []`` as no value): the row is
declared by its own type and read back as an empty list.
"""
from __future__ import annotations

import re
import sys
from collections.abc import Iterable, Mapping, Sequence
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import ParameterNotDeclaredException, ParameterUninitializedException
from rclpy.node import Node
from rclpy.parameter import Parameter

from fic_core.errors import FicInputError

# The row constructors, for the nodes' tables (one row type for fic_core's tables and the nodes'), and the one hint
# of the nearest declared name that every refusal of an unknown name gives.
from fic_core.parameter_row import (  # noqa: F401
    LISTS,
    Kind,
    ParameterRow,
    integer,
    nearest_name_hint,
    number,
    numbers,
    switch,
    text,
    texts,
)
from fic_teleop_runtime.workspace import config_folder

Type = Parameter.Type
#: Parameters rclpy itself declares or reads on every node; a params file may give them.
_RCLPY_OWN_PREFIXES = ("qos_overrides.",)
#: The ROS arguments of the node being built (the process's, then the node's own when it shares a process):
#: node_main.run_entries sets them; None: the process's command line.
START_ARGUMENTS: ContextVar[tuple[str, ...] | None] = ContextVar("START_ARGUMENTS", default=None)


#: rclpy's type of each kind of row.
RCLPY_TYPES = {Kind.NUMBER: Type.DOUBLE, Kind.INTEGER: Type.INTEGER, Kind.SWITCH: Type.BOOL, Kind.TEXT: Type.STRING,
               Kind.NUMBERS: Type.DOUBLE_ARRAY, Kind.INTEGERS: Type.INTEGER_ARRAY, Kind.TEXTS: Type.STRING_ARRAY}


def descriptor(row: ParameterRow) -> ParameterDescriptor:
    """The row as rclpy declares it: its description, fixed at start or not, and its range, which rclpy then
    enforces on every change (``param set``) with the bounds ``row.checked`` uses."""
    result = ParameterDescriptor(description=row.description, read_only=row.read_only)
    if row.low is not None and row.kind in (Kind.NUMBER, Kind.NUMBERS):
        result.floating_point_range = [FloatingPointRange(from_value=float(row.low), to_value=float(row.high),
                                                          step=0.0)]
    elif row.low is not None and row.kind in (Kind.INTEGER, Kind.INTEGERS):
        result.integer_range = [IntegerRange(from_value=int(row.low), to_value=int(row.high), step=1)]
    return result


@dataclass(frozen=True)
class Schema:
    """A node's rows and the file under config/ that holds their defaults."""

    config_file: str
    rows: tuple[ParameterRow, ...]

    def __init__(self, config_file: str, *rows: ParameterRow | Iterable[ParameterRow]) -> None:
        flat: list[ParameterRow] = []
        for row in rows:
            flat.extend([row] if isinstance(row, ParameterRow) else row)
        names = [row.name for row in flat]
        duplicates = sorted({name for name in names if names.count(name) > 1})
        if duplicates:
            raise ValueError(f"parameters declared twice: {duplicates}")
        object.__setattr__(self, "config_file", config_file)
        object.__setattr__(self, "rows", tuple(flat))

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(row.name for row in self.rows)

    def row(self, name: str) -> ParameterRow:
        return next(row for row in self.rows if row.name == name)


# --- the config files --------------------------------------------------------------------------------------------
class _RclLoader(yaml.SafeLoader):
    """YAML read as rcl reads a params file: ``1.0e6`` and ``1e3`` are doubles (PyYAML's YAML 1.1 wants a signed
    exponent and a point, and would give the strings '1.0e6' and '1e3')."""


_RclLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*\.[0-9_]*(?:[eE][-+]?[0-9]+)?|[0-9][0-9_]*[eE][-+]?[0-9]+|\.[0-9_]+"
               r"(?:[eE][-+]?[0-9]+)?)$"),
    list("-+0123456789."))


def _flat(values: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested mappings as rcl names them: ``a: {b: 1}`` is parameter ``a.b``."""
    result: dict[str, Any] = {}
    for key, value in values.items():
        if isinstance(value, Mapping):
            result.update(_flat(value, f"{prefix}{key}."))
        else:
            result[f"{prefix}{key}"] = value
    return result


def file_sections(path: Path) -> dict[str, dict[str, Any]]:
    """Each node section of a params file (``/**``, ``name`` or ``/name``) -> its flat parameter values."""
    try:
        data = yaml.load(path.read_text(), Loader=_RclLoader) or {}  # noqa: S506 - a SafeLoader
    except (OSError, yaml.YAMLError) as exc:
        raise FicInputError(f"cannot read {path}: {exc}") from None
    if not isinstance(data, Mapping):
        raise FicInputError(f"{path}: not a params file (node names to ros__parameters)")
    sections = {}
    for key, section in data.items():
        parameters = section.get("ros__parameters") if isinstance(section, Mapping) else None
        if not isinstance(parameters, Mapping):
            raise FicInputError(f"{path}: section {key!r} has no ros__parameters mapping")
        sections[str(key)] = _flat(parameters)
    return sections


def node_values(sections: Mapping[str, Mapping[str, Any]], node_name: str) -> dict[str, Any] | None:
    """The values a node named ``node_name`` takes from a file's sections, the wildcard first and its own name
    over it; None if no section applies to it."""
    wildcard = [values for key, values in sections.items() if key in ("/**", "**")]
    own = [values for key, values in sections.items() if key.lstrip("/") == node_name.lstrip("/")]
    if not wildcard and not own:
        return None
    result: dict[str, Any] = {}
    for values in (*wildcard, *own):
        result.update(values)
    return result


def typed(row: ParameterRow, value: Any, where: str) -> Any:
    """``value`` of a params file checked against the row (``ParameterRow.checked`` as rcl reads the file: a
    double written with a point); FicInputError names the parameter."""
    return row.checked(value, where, exact=True)


def unknown_key_error(name: str, known: Sequence[str], node_name: str) -> FicInputError:
    """The refusal of a key no row declares, naming the nearest declared one."""
    return FicInputError(f"unknown parameter {name!r} for node {node_name}{nearest_name_hint(name, known)}")


def check_keys(given: Iterable[str], schema: Schema, node_name: str, also_known: Iterable[str] = ()) -> None:
    """Every key of ``given`` is declared by ``schema`` (or by rclpy itself: ``also_known``, qos_overrides)."""
    known = set(schema.names) | set(also_known)
    for name in given:
        if name not in known and not name.startswith(_RCLPY_OWN_PREFIXES):
            raise unknown_key_error(name, schema.names, node_name)


def given_keys(arguments: Sequence[str], node_name: str) -> set[str]:
    """The parameter names the ROS arguments give node ``node_name``: the keys of every ``--params-file``'s
    sections that apply to it (the wildcard and its own name, as rcl applies them) and every ``-p``/``--param``
    rule (``name:=value``, or ``node:name:=value`` for this node). Only what follows ``--ros-args``, up to ``--``,
    is a ROS argument."""
    names: set[str] = set()
    in_ros_arguments = False
    items = iter(arguments)
    for item in items:
        if item == "--ros-args":
            in_ros_arguments = True
        elif item == "--":
            in_ros_arguments = False
        elif in_ros_arguments and item == "--params-file":
            values = node_values(file_sections(Path(next(items, ""))), node_name)
            names.update(values or {})
        elif in_ros_arguments and item in ("-p", "--param"):
            name = next(items, "").partition(":=")[0]
            target, _, own = name.rpartition(":")
            if not target or target.lstrip("/") == node_name.lstrip("/"):
                names.add(own)
    return names


# --- declaring on a node -----------------------------------------------------------------------------------------
def defaults_for(schema: Schema, node_name: str, folder: Path | None = None) -> dict[str, Any]:
    """The node's defaults from its config file, typed and checked; every row not ``optional`` must be there."""
    path = (folder or config_folder()) / schema.config_file
    values = node_values(file_sections(path), node_name)
    if values is None:
        raise FicInputError(f"{path} has no section for node {node_name} (nor /**)")
    where = f"{path.name} [{node_name}]"
    check_keys(values, schema, node_name)
    missing = [row.name for row in schema.rows if row.name not in values and not row.optional]
    if missing:
        raise FicInputError(f"{where} gives no value for {', '.join(missing)}")
    return {row.name: typed(row, values[row.name], where) for row in schema.rows if row.name in values}


def declare(node: Node, schema: Schema) -> dict[str, Any]:
    """Declare every row of ``schema`` on ``node`` with its default from config/, after refusing any key given at
    start that no row declares; returns name -> value (``values``). Raises FicInputError or rclpy's
    ParameterException (wrong type, out of range), which run_node turns into one FATAL line."""
    # What the params files and -p of the start gave this node, read from the ROS arguments (rclpy applies them
    # but names them nowhere in its public API). Parameters rclpy declared itself (use_sim_time, ...) and any the
    # node declared before are already listed on the node.
    arguments = START_ARGUMENTS.get()
    given = given_keys(sys.argv if arguments is None else arguments, node.get_name())
    check_keys(given, schema, node.get_name(), also_known=node.list_parameters([], 0).names)
    defaults = defaults_for(schema, node.get_name())
    for row in schema.rows:
        default = defaults.get(row.name)
        if default is None or default == []:
            # No value, or an empty list: rcl reads ``[]`` in a params file as a value of no type, and rclpy would
            # type an empty default as a byte array. Declared by the row's type and left unset: ``values`` reads
            # an unset list as empty.
            node.declare_parameter(row.name, RCLPY_TYPES[row.kind], descriptor(row))
        else:
            node.declare_parameter(row.name, default, descriptor(row))
    result = values(node, schema)
    unset = [row.name for row in schema.rows if result[row.name] is None and not row.optional]
    if unset:
        raise FicInputError(f"no value for {', '.join(unset)} (an empty entry in a params file?)")
    return result


def values(node: Node, schema: Schema, names: Iterable[str] | None = None) -> dict[str, Any]:
    """name -> the node's current value; a list declared by type and never set is empty, any other such row None."""
    result = {}
    for name in schema.names if names is None else names:
        try:
            result[name] = node.get_parameter(name).value
        except ParameterUninitializedException:
            result[name] = [] if schema.row(name).kind in LISTS else None
    return result


def refuse_unknown_names(node: Node, schema: Schema):
    """A pre-set check that refuses a name the node does not declare in one line naming the nearest declared one.
    rclpy refuses it anyway, but Jazzy's reason lists no name ("Invalid access to undeclared parameter(s): []": it
    reads the names from a spent generator). Call it first in the node's one pre-set callback: rclpy concatenates
    the lists that several such callbacks return, so each parameter would be set twice."""
    def check(parameters: list[Parameter]) -> list[Parameter]:
        for parameter in parameters:
            if not node.has_parameter(parameter.name):
                raise ParameterNotDeclaredException(
                    f"{parameter.name!r}{nearest_name_hint(parameter.name, schema.names)}")
        return parameters
    return check
