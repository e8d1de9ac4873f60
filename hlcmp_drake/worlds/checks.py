"""Checks of a user's demonstration against the arm, before any simulation: can the tool
follow it at all (inverse kinematics along the path) and within the joints' speed limits."""

from __future__ import annotations

from typing import Sequence

import numpy as np
from pydrake.multibody.plant import MultibodyPlant

from hlcmp_drake.config.scenario import ArmTask, Scenario
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.worlds.models import load_models, solve_ik_for_tool

CHECKED_SAMPLES = 40  # IK solves along the path (1-4 ms each)


def check_demonstration_feasible(
    scenario: Scenario,
    t: np.ndarray,
    positions: np.ndarray,
    source: str,
    lines: Sequence[int] | None = None,
) -> None:
    """Check that the arm's tool can follow a demonstration, within the joints' speed limits.

    The path is checked at CHECKED_SAMPLES evenly spaced samples. The first posture is
    solved from the task's IK seed, each next one from the previous posture; the joint
    speeds are finite differences along that chain (they miss peaks between the samples:
    the check catches gross violations, not every one). A sample is judged out of reach,
    or too fast, only when IK from the path's first posture and from the task's IK seed
    finds no posture within the limits either (`_posture_to_follow`).

    Parameters
    ----------
    scenario : Scenario
        With an ArmTask: the models, the tool frame and direction, the IK seed.
    t : (T,) array
        Sample times [s], strictly increasing.
    positions : (T, 3) array
        World positions of the tool point [m].
    source : str
        Where the demonstration came from (e.g. its file), for the message.
    lines : sequence of int, optional
        The CSV line of each sample; None: the message gives the sample's time instead.

    Raises
    ------
    InputError
        When the models cannot be loaded, the tool cannot reach a sample pointing as the
        task requires, or following the path would need a joint faster than its velocity
        limit.
    """
    plant = MultibodyPlant(0.0)
    load_models(plant, scenario)
    indices = np.unique(np.linspace(0, len(t) - 1, min(CHECKED_SAMPLES, len(t))).astype(int))
    limits = plant.GetVelocityUpperLimits()
    task: ArmTask = scenario.task
    task_seed = np.asarray(task.ik_seed_rad, dtype=float)

    def where(k):
        return f"{source}:{lines[k]}" if lines is not None else f"{source} (t = {t[k]:.2f} s)"

    def out_of_reach(k):
        return InputError(
            f"{where(k)}: the tool cannot reach ({positions[k][0]:.3f}, "
            f"{positions[k][1]:.3f}, {positions[k][2]:.3f}) m with the arm "
            f"(world frame); is the demonstration in the scenario's world?"
        )

    first_posture = solve_ik_for_tool(plant, task, positions[indices[0]], task_seed)
    if first_posture is None:
        raise out_of_reach(indices[0])
    previous_k, previous_q = indices[0], first_posture
    for k in indices[1:]:
        q, speed = _posture_to_follow(
            plant,
            task,
            positions[k],
            [previous_q, first_posture, task_seed],
            previous_q,
            t[k] - t[previous_k],
        )
        if q is None:
            raise out_of_reach(k)
        worst = int(np.argmax(speed / limits))
        if speed[worst] > limits[worst]:
            raise InputError(
                f"{where(k)}: following the demonstration needs joint {worst + 1} "
                f"at {speed[worst]:.2f} rad/s, above its limit of {limits[worst]:.2f} rad/s; "
                "slow it down (e.g. hlcmp rollout --duration)"
            )
        previous_k, previous_q = k, q


def _posture_to_follow(
    plant: MultibodyPlant,
    task: ArmTask,
    position: np.ndarray,
    seeds: Sequence[np.ndarray],
    previous: np.ndarray,
    dt: float,
) -> tuple[np.ndarray | None, np.ndarray]:
    """The posture with the tool at `position` that needs the slowest joints to reach from
    `previous` in `dt`: IK from each seed in turn, until one is within the speed limits.

    One solve is no verdict. The tool's pointing constraint bounds the cosine of an angle
    near its maximum, where the cosine is flat; from the previous posture, which already
    meets it, the solver can stop without a posture, or step onto another branch of
    solutions far away in joint space, where another seed finds the one next to it.

    Parameters
    ----------
    plant : MultibodyPlant
        Finalized, with the scenario's models.
    task : ArmTask
        The tool frame and how it points.
    position : (3,) array
        World position of the tool point [m].
    seeds : sequence of (nq,) arrays
        Joint positions [rad] to solve from, in order.
    previous : (nq,) array
        The previous sample's posture [rad].
    dt : float
        The time [s] from the previous sample, > 0.

    Returns
    -------
    posture : (nq,) array or None
        The joint positions [rad], or None when no seed gives a posture.
    speed : (nq,) array
        The joint speeds [rad/s] from `previous` to that posture (inf without one).
    """
    limits = plant.GetVelocityUpperLimits()
    best, best_speed, best_share = None, np.full(len(previous), np.inf), np.inf
    for seed in seeds:
        q = solve_ik_for_tool(plant, task, position, seed)
        if q is None:
            continue
        speed = np.abs(q - previous) / dt
        share = np.max(speed / limits)  # of the joint nearest its limit
        if share < best_share:
            best, best_speed, best_share = q, speed, share
        if best_share <= 1.0:
            break
    return best, best_speed
