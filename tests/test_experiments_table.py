"""hlcmp_drake.experiments.table: table cells rounded without negative zero."""

from hlcmp_drake.experiments.table import number, per_axis


def test_cells_are_rounded_without_negative_zero():
    assert number(-0.0001) == "0.00" and number(None) == "never" and number(-1.234, 1) == "-1.2"
    assert per_axis({"x": 0.001, "y": -0.0000001, "z": 0.0125}, "xyz", 1000) == "1.00/0.00/12.50"
