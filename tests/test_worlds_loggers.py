"""hlcmp_drake.worlds.common.add_loggers: every series of a world logged by one VectorLogSink
(the distinct ports side by side), each at its own columns of what it logs."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, VectorLogSink

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.worlds.build import diagram_factory
from hlcmp_drake.worlds.common import add_loggers


def test_each_series_reads_its_own_columns_of_the_one_log():
    scenario = load_scenario("one_dof")[0]
    builder = DiagramBuilder()
    a = builder.AddSystem(ConstantVectorSource([1.0, 2.0, 3.0]))
    b = builder.AddSystem(ConstantVectorSource([4.0, 5.0]))
    loggers = add_loggers(
        builder,
        scenario,
        {
            "head": (a.get_output_port(), slice(0, 2)),
            "b": b.get_output_port(),
            "tail": (a.get_output_port(), slice(2, None)),
            "a": a.get_output_port(),
        },
    )
    diagram = builder.Build()
    assert sum(isinstance(s, VectorLogSink) for s in diagram.GetSystems()) == 1
    simulator = Simulator(diagram)
    simulator.AdvanceTo(0.05)
    expected = {"head": [1.0, 2.0], "b": [4.0, 5.0], "tail": [3.0], "a": [1.0, 2.0, 3.0]}
    for name, (logger, columns) in loggers.items():
        data = logger.FindLog(simulator.get_context()).data()[columns]
        assert data.shape[1] == 6  # t = 0, 0.01, ..., 0.05
        np.testing.assert_array_equal(data, np.tile(expected[name], (6, 1)).T)


def test_columns_with_a_step_are_refused():
    builder = DiagramBuilder()
    a = builder.AddSystem(ConstantVectorSource([1.0, 2.0, 3.0]))
    with pytest.raises(ValueError, match="step of 1"):
        add_loggers(
            builder, load_scenario("one_dof")[0], {"odd": (a.get_output_port(), slice(0, 3, 2))}
        )


@pytest.mark.parametrize("name, controller", [("one_dof", "hlcmp"), ("insertion", "hlcmp")])
def test_a_world_logs_every_series_with_one_logger(name, controller):
    scenario = load_scenario(name, ["duration_s=0.1"])[0]
    built = diagram_factory(scenario)(controller)
    sinks = [s for s in built.diagram.GetSystems() if isinstance(s, VectorLogSink)]
    assert len(sinks) == 1 and len(built.loggers) > 3
