"""Environments that are not contact geometry: the paper's 1-DOF elastic object."""

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem


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


class UnilateralSpring(LeafSystem):
    """The 1-DOF experiment's object as a generalized force on a single-joint plant.

    Input `plant_state` [q, v]; outputs `generalized_force` (to the plant's
    applied_generalized_force port) and `reaction_force` (what a force sensor between the
    body and the object reads, logged as f_ext).

    Input ports:

    - ``plant_state`` (2): the prismatic joint's position q [m] and velocity v [m/s].

    Output ports:

    - ``generalized_force`` (1): k (surface - q) while q < surface, else 0
      (`unilateral_spring_force`), on the joint [N].
    - ``reaction_force`` (1): the same value, the object's reaction on the body [N].

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
        self._surface, self._stiffness = float(surface), float(stiffness)
        self.plant_state = self.DeclareVectorInputPort("plant_state", BasicVector(2))
        prereq = {self.all_input_ports_ticket()}
        self.DeclareVectorOutputPort("generalized_force", 1, self._calc, prereq)
        self.DeclareVectorOutputPort("reaction_force", 1, self._calc, prereq)

    def _calc(self, context, output):
        q = self.plant_state.Eval(context)[0]
        output.SetFromVector([unilateral_spring_force(q, self._surface, self._stiffness)])
