"""Environments that are not contact geometry: the paper's 1-DOF elastic object."""

import numpy as np
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import AffineSystem, Gain, Saturation


def unilateral_spring_force(x: float | np.ndarray, surface: float, stiffness: float) -> np.ndarray:
    """Reaction of an elastic object occupying x < surface: k (surface - x) when the body
    has penetrated it, zero otherwise (the object pulls nothing). 1-DOF experiment, Fig. 13.

    Parameters
    ----------
    x : float or array
        Position of the body [m].
    surface : float
        Position of the object's surface [m].
    stiffness : float
        Stiffness k of the object [N/m].

    Returns
    -------
    array
        Reaction force [N], >= 0 for k >= 0, the shape of `x` (0-d for a scalar).
    """
    return np.where(x < surface, stiffness * (surface - x), 0.0)


class UnilateralSpring(Diagram):
    """The 1-DOF experiment's object as a generalized force on a single-joint plant:
    `unilateral_spring_force` built from Drake's C++ systems (the gap s - q, clamped at 0,
    times k), so that the slider world calls no Python for it, twice a plant step
    (tested equal to `unilateral_spring_force`).

    Input ports:

    - ``plant_state`` (2): the prismatic joint's position q [m] and velocity v [m/s].

    Output ports:

    - ``generalized_force`` (1): k (surface - q) while q < surface, else 0, on the joint
      [N] (to the plant's applied_generalized_force port).
    - ``reaction_force`` (1): the same value, the object's reaction on the body [N] (what a
      force sensor between the body and the object reads, logged as f_ext).

    Parameters
    ----------
    surface : float
        Position of the object's surface along the joint [m]; the object fills
        q < surface.
    stiffness : float
        The object's stiffness k [N/m].
    """

    def __init__(self, surface, stiffness):
        super().__init__()
        builder = DiagramBuilder()
        gap = builder.AddNamedSystem(
            "gap",  # y = surface - q, exactly (the velocity's coefficient is 0)
            AffineSystem(
                A=np.zeros((0, 0)),
                B=np.zeros((0, 2)),
                f0=np.zeros(0),
                C=np.zeros((1, 0)),
                D=[[-1.0, 0.0]],
                y0=[float(surface)],
            ),
        )
        inside = builder.AddNamedSystem("inside", Saturation([0.0], [np.inf]))
        force = builder.AddNamedSystem("stiffness", Gain(float(stiffness), 1))
        builder.Connect(gap.get_output_port(), inside.get_input_port())
        builder.Connect(inside.get_output_port(), force.get_input_port())
        state_input = builder.ExportInput(gap.get_input_port(), "plant_state")
        builder.ExportOutput(force.get_output_port(), "generalized_force")
        builder.ExportOutput(force.get_output_port(), "reaction_force")
        builder.BuildInto(self)
        self.plant_state = self.get_input_port(state_input)
