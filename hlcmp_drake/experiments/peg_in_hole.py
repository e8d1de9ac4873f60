"""The peg in a tilted hole (issue 19, item 4): how deep the peg got into a hole whose axis
is 3 degrees off the demonstrated insertion direction, with the insertion's translational
metrics. The world and why it is so: docs/worlds.md, "The peg in a tilted hole".

No claims yet: the controllers the experiment is for (rotation learned as well as
translation) come later; what today's translational controllers do is measured only."""

import numpy as np
from pydrake.multibody.plant import MultibodyPlant

from hlcmp_drake.config.scenario import ArmTask, ControllerConfig, Scenario
from hlcmp_drake.experiments import insertion
from hlcmp_drake.experiments.experiment import Experiment
from hlcmp_drake.experiments.insertion import controller_metrics as translational_metrics
from hlcmp_drake.experiments.plots import new_figure
from hlcmp_drake.experiments.table import Table
from hlcmp_drake.io.runs import RunResult
from hlcmp_drake.worlds.models import load_models, scoped_frame

HOLE_FRAME = "peg_fixture::hole"  # the entrance's centre, +z out of the block along the axis
DEPTH_TOLERANCE_M = 0.005  # done: within 5 mm of the demonstrated depth


def hole_axis(scenario: Scenario) -> tuple[np.ndarray, np.ndarray]:
    """The hole's entrance centre and its axis into the block, world, from the scenario's
    models alone.

    Parameters
    ----------
    scenario : Scenario
        With the fixture's model (frame HOLE_FRAME).

    Returns
    -------
    (entrance (3,), unit axis into the block (3,))
    """
    plant = MultibodyPlant(0.0)
    load_models(plant, scenario)
    pose = scoped_frame(plant, HOLE_FRAME).CalcPoseInWorld(plant.CreateDefaultContext())
    return pose.translation(), -pose.rotation().matrix()[:, 2]


def depth_in_hole(points: np.ndarray, entrance: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """(T,) the depth of each point below the hole's entrance along its axis [m] (negative:
    above it).

    Parameters
    ----------
    points : (T, 3) array
        World points [m].
    entrance, axis : (3,) arrays
        The entrance's centre [m] and the unit axis into the block.
    """
    return (points - entrance) @ axis


def controller_metrics(run: RunResult, config: ControllerConfig, scenario: Scenario) -> dict:
    """The insertion's translational metrics, and the depth the peg's tip reached along the
    hole's axis and the demonstrated one.

    Parameters
    ----------
    run : RunResult
        Its x, xd (T, 3) [m], f_ext (T, 3) [N] and the learner's profiles.
    config : controller config
    scenario : Scenario

    Returns
    -------
    dict
        The controller's entry of metrics.json.
    """
    entrance, axis = hole_axis(scenario)
    return {
        **translational_metrics(run, config, scenario),
        "depth_reached_m": float(np.max(depth_in_hole(run.series["x"], entrance, axis))),
        "depth_demonstrated_m": float(np.max(depth_in_hole(run.series["xd"], entrance, axis))),
    }


def table(metrics: dict) -> Table:
    """Per controller: the depth its tip reached along the hole's axis (and the
    demonstrated one), then the insertion's columns.

    Parameters
    ----------
    metrics : dict
        {controller label: controller metrics}.
    """
    translational = insertion.table(metrics)
    result = Table(
        [translational.headers[0], "depth reached / demonstrated [mm]", *translational.headers[1:]]
    )
    for row, m in zip(translational.rows, metrics.values()):
        depth = f"{1000 * m['depth_reached_m']:.1f} / {1000 * m['depth_demonstrated_m']:.1f}"
        result.add(row[0], depth, *row[1:])
    return result


def inserted(run: RunResult, scenario: Scenario) -> dict:
    """Whether the peg got within DEPTH_TOLERANCE_M of the demonstrated depth in the hole.

    Parameters
    ----------
    run : RunResult
    scenario : Scenario

    Returns
    -------
    dict
        {"done", "evidence"}.
    """
    entrance, axis = hole_axis(scenario)
    reached = float(np.max(depth_in_hole(run.series["x"], entrance, axis)))
    target = float(np.max(depth_in_hole(run.series["xd"], entrance, axis)))
    done = reached >= target - DEPTH_TOLERANCE_M
    return {
        "done": bool(done),
        "evidence": f"the tip reached {1000 * reached:.1f} mm into the hole, the reference "
        f"{1000 * target:.1f} mm (done within {1000 * DEPTH_TOLERANCE_M:.0f} mm)",
    }


def claims(
    metrics: dict, scenario: Scenario, runs: dict | None = None, learner_name: str | None = None
) -> dict:
    """None yet (see the module's docstring).

    Parameters
    ----------
    metrics : dict
        Every controller's metrics, by label.
    scenario : Scenario
    runs : dict, optional
    learner_name : str, optional

    Returns
    -------
    dict
        Empty.
    """
    return {}


def figures(runs: dict, scenario: Scenario) -> dict:
    """peg_in_hole.png: each controller's depth in the hole and axial force over time.

    Parameters
    ----------
    runs : dict of str to RunResult
    scenario : Scenario
    """
    entrance, axis = hole_axis(scenario)
    fig, (depth, force) = new_figure(2, 1, size=(8, 6), sharex=True)
    for k, (name, run) in enumerate(runs.items()):
        reached = depth_in_hole(run.series["x"], entrance, axis)
        depth.plot(run.t, 1000 * reached, f"C{k}", label=name)
        force.plot(run.t, run.series["f_ext"] @ -axis, f"C{k}", label=name)
    first = next(iter(runs.values()))
    depth.plot(first.t, 1000 * depth_in_hole(first.series["xd"], entrance, axis), "k--", lw=0.8)
    depth.set_ylabel("tip depth in the hole [mm]")
    force.set_ylabel("force against the insertion [N]")
    force.set_xlabel("t [s]")
    depth.legend(fontsize=8)
    for axis_ in (depth, force):
        axis_.grid(alpha=0.3)
    return {"peg_in_hole.png": fig}


EXPERIMENT = Experiment(
    name="peg_in_hole",
    title="A peg in a tilted hole (iiwa14)",
    paper_section="VI",  # beyond the paper's experiments: listed after them
    paper_figures="none (issue 19)",
    world=ArmTask,
    controller_metrics=controller_metrics,
    claims=claims,
    table=table,
    figures=figures,
    task_done=inserted,
)
