"""Checks of a user's demonstration against the arm, before any simulation: can the tool
follow it at all (inverse kinematics along the path) and within the joints' speed limits."""

from __future__ import annotations

from typing import Sequence

import numpy as np
from pydrake.multibody.plant import MultibodyPlant

from hlcmp_drake.config.scenario import Scenario
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.worlds.models import load_models, solve_ik_for_tool

CHECKED_SAMPLES = 40  # IK solves along the path (about 20 ms each)


def check_demonstration_feasible(
    scenario: Scenario,
    t: np.ndarray,
    positions: np.ndarray,
    source: str,
    lines: Sequence[int] | None = None,
) -> None:
    """Check that the arm's tool can follow a demonstration, within the joints' speed limits.

    The path is checked at CHECKED_SAMPLES evenly spaced samples, each IK seeded with the
    previous solution, so the joint speeds are finite differences along that chain (they
    miss peaks between the samples: the check catches gross violations, not every one).

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
    seed, previous = np.asarray(scenario.task.ik_seed_rad, dtype=float), None

    def where(k):
        return f"{source}:{lines[k]}" if lines is not None else f"{source} (t = {t[k]:.2f} s)"

    for k in indices:
        q = solve_ik_for_tool(plant, scenario.task, positions[k], seed)
        if q is None:
            raise InputError(
                f"{where(k)}: the tool cannot reach ({positions[k][0]:.3f}, "
                f"{positions[k][1]:.3f}, {positions[k][2]:.3f}) m with the arm "
                f"(world frame); is the demonstration in the scenario's world?"
            )
        if previous is not None:
            speed = np.abs(q - previous[1]) / (t[k] - t[previous[0]])
            worst = int(np.argmax(speed / limits))
            if speed[worst] > limits[worst]:
                raise InputError(
                    f"{where(k)}: following the demonstration needs joint {worst + 1} "
                    f"at {speed[worst]:.2f} rad/s, above its limit of {limits[worst]:.2f} rad/s; "
                    "slow it down (e.g. hlcmp rollout --duration)"
                )
        previous, seed = (k, q), q
