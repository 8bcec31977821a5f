"""fic_core.parameter_row: the one row type and its one check, the same for fic_core's tables, the params-file loader
and (through the descriptor) rclpy's declaration."""
from __future__ import annotations

import array
import dataclasses
import math
import pickle

import pytest

from fic_core.errors import FicInputError
from fic_core.parameter_row import (
    Kind,
    ParameterRow,
    integer,
    number,
    numbers,
    parameter_set,
    rows_by_name,
    switch,
    texts,
)

#: A parameter set generated as a station's is, bound to its own name here so that it pickles (the engine's workers).
Sample = parameter_set("Sample", __name__, "sample", [number("gain", 0.0, 2.0, "a gain"), integer("mode", 0, 1, "m"),
                                                      switch("on", "s"), numbers("point", "p"), texts("names", "n")],
                       "A sample of a station's parameters.")


def test_a_number_inside_its_range_passes_and_outside_is_refused_by_name() -> None:
    row = number("stiffness", 1.0, 5000.0, "K0")
    assert row.checked(200.0) == 200.0
    assert row.checked(200) == 200.0 and isinstance(row.checked(200), float)   # in-process: an int is a number
    for bad in (0.5, 5000.5, math.nan, math.inf):
        with pytest.raises(FicInputError, match=r"master.yaml: stiffness must be in \[1, 5000\]"):
            row.checked(bad, "master.yaml")
    for bad in (True, "200", None):
        with pytest.raises(FicInputError, match="stiffness must be a number"):
            row.checked(bad)


def test_a_params_file_needs_a_double_written_as_one() -> None:
    """rcl reads ``200`` as an integer, which rclpy then refuses for a double: the loader says so first."""
    with pytest.raises(FicInputError, match="a number with a decimal point"):
        number("stiffness", 1.0, 5000.0, "K0").checked(200, exact=True)


def test_lists_switches_and_texts() -> None:
    assert numbers("via", "points").checked([1, 2.5]) == [1.0, 2.5]
    assert ParameterRow("gains", Kind.NUMBERS, "", 0.0, 1.0).checked((0.5,)) == [0.5]
    # A double array set on a running node comes from rclpy as an array.array.
    assert numbers("guidance_point", "").checked(array.array("d", [0.0, 0.1, 0.2])) == [0.0, 0.1, 0.2]
    with pytest.raises(FicInputError, match=r"gains must be in \[0, 1\]"):
        ParameterRow("gains", Kind.NUMBERS, "", 0.0, 1.0).checked([0.5, 2.0])
    with pytest.raises(FicInputError, match="a list of strings"):
        texts("topics", "").checked(["/a", 3])
    with pytest.raises(FicInputError, match="true or false"):
        switch("paper_law", "").checked(1)


def test_a_table_refuses_a_name_given_twice() -> None:
    assert list(rows_by_name(switch("a", ""), switch("b", ""))) == ["a", "b"]
    with pytest.raises(ValueError, match="'a' given twice"):
        rows_by_name(switch("a", ""), switch("a", ""))


def test_the_replica_and_master_tables_are_rows_and_fic_core_checks_them() -> None:
    from fic_core.master_station import MASTER_NUMBERS
    from fic_core.replica_parameters import REPLICA_NUMBERS, REPLICA_SWITCHES

    for row in (*REPLICA_NUMBERS.values(), *REPLICA_SWITCHES.values(), *MASTER_NUMBERS.values()):
        assert isinstance(row, ParameterRow)
    assert MASTER_NUMBERS["control_rate"].read_only and not MASTER_NUMBERS["stiffness"].read_only


def test_a_parameter_set_is_a_frozen_dataclass_of_its_rows_each_value_checked() -> None:
    sample = Sample.from_values({"gain": 1, "mode": 0, "on": True, "point": array.array("d", [0.5]), "names": ["a"]})
    assert [(field.name, field.type) for field in dataclasses.fields(sample)] == \
        [("gain", float), ("mode", int), ("on", bool), ("point", list[float]), ("names", list[str])]
    assert sample.gain == 1.0 and isinstance(sample.gain, float) and sample.point == [0.5]
    assert Sample.__doc__ == "A sample of a station's parameters." and Sample.ROWS["gain"].high == 2.0
    assert pickle.loads(pickle.dumps(sample)) == sample
    assert sample.replaced({"mode": 1}) == dataclasses.replace(sample, mode=1) and sample.mode == 0
    with pytest.raises(dataclasses.FrozenInstanceError):
        sample.gain = 0.5
    with pytest.raises(FicInputError, match=r"^unknown sample parameter 'gian'; did you mean 'gain'\?$"):
        sample.replaced({"gian": 0.5})
    with pytest.raises(FicInputError, match=r"^gain must be in \[0, 2\], got 3.0$"):
        sample.replaced({"gain": 3.0})
    with pytest.raises(FicInputError, match=r"^unknown sample parameter 'zzz'; declared: gain, mode, names, on, "
                                            r"point$"):
        Sample.from_values({"zzz": 1})
    with pytest.raises(FicInputError, match=r"^sample parameters missing: on, point, names$"):
        Sample.from_values({"gain": 1.0, "mode": 1})
