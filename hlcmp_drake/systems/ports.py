"""The port layout shared by every task-space controller, so they are interchangeable."""

from dataclasses import dataclass

import numpy as np
from pydrake.systems.framework import BasicVector, Context, InputPort, LeafSystem

from hlcmp_drake.core.laws import TaskSpaceInstant

# What every desired-motion source outputs and every controller reads.
REFERENCE_PORTS = ("desired_position", "desired_velocity", "desired_acceleration", "phase")


@dataclass(frozen=True)
class TaskSpaceInputs:
    """Input ports of a task-space controller (all sizes in task-space axes M)."""

    position: InputPort
    velocity: InputPort
    desired_position: InputPort
    desired_velocity: InputPort
    desired_acceleration: InputPort
    phase: InputPort
    inertia: InputPort
    coriolis: InputPort
    gravity: InputPort

    def errors_and_reference(
        self, context: Context
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Evaluate the measured and desired motion: (x, x', x_d, x_d', x_d'').

        Parameters
        ----------
        context : Context
            A context of the system that declared these ports.

        Returns
        -------
        x, xdot : (M,) arrays
            Measured position [m] and velocity [m/s].
        xd, xd_dot, xd_ddot : (M,) arrays
            Desired position [m], velocity [m/s] and acceleration [m/s^2].
        """
        return (
            self.position.Eval(context),
            self.velocity.Eval(context),
            self.desired_position.Eval(context),
            self.desired_velocity.Eval(context),
            self.desired_acceleration.Eval(context),
        )

    def dynamics(self, context: Context, n_axes: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Evaluate the task-space M (M x M), C (M x M) and G (M,) supplied by Drake.

        Parameters
        ----------
        context : Context
            A context of the system that declared these ports.
        n_axes : int
            M, the number of task-space axes.

        Returns
        -------
        inertia : (M, M) array
            Task-space inertia [kg].
        coriolis : (M, M) array
            Task-space Coriolis matrix [kg/s].
        gravity : (M,) array
            Task-space gravity force [N].
        """
        return (
            self.inertia.Eval(context).reshape(n_axes, n_axes),
            self.coriolis.Eval(context).reshape(n_axes, n_axes),
            self.gravity.Eval(context),
        )

    def instant(self, context: Context, n_axes: int) -> TaskSpaceInstant:
        """Everything a law reads, evaluated from these ports.

        Parameters
        ----------
        context, n_axes
            As for `dynamics`.

        Returns
        -------
        TaskSpaceInstant
            x, x', x_d, x_d', x_d'', the phase s and the task-space M, C, G.
        """
        inertia, coriolis, gravity = self.dynamics(context, n_axes)
        return TaskSpaceInstant(
            *self.errors_and_reference(context),
            self.phase.Eval(context)[0],
            inertia,
            coriolis,
            gravity,
        )


def declare_task_space_inputs(system: LeafSystem, n_axes: int) -> TaskSpaceInputs:
    """Declare the standard controller inputs on `system`.

    position, velocity: measured task-space x, x'. desired_*: x_d, x_d', x_d'' from the
    reference (DMP source). phase: the canonical phase s. inertia, coriolis: row-major
    M x M task-space matrices, gravity: the task-space G, all from TaskSpaceDynamics.

    Parameters
    ----------
    system : LeafSystem
        The controller to declare the ports on.
    n_axes : int
        M, the number of task-space axes.

    Returns
    -------
    TaskSpaceInputs
        The declared vector ports: size M for the positions [m], velocities [m/s],
        acceleration [m/s^2] and gravity [N]; 1 for the phase [-]; M * M for the inertia
        [kg] and Coriolis matrix [kg/s]. Each port is named as its field, except
        task_inertia, task_coriolis and task_gravity.
    """

    def vec(name, size):
        return system.DeclareVectorInputPort(name, BasicVector(size))

    return TaskSpaceInputs(
        position=vec("position", n_axes),
        velocity=vec("velocity", n_axes),
        desired_position=vec("desired_position", n_axes),
        desired_velocity=vec("desired_velocity", n_axes),
        desired_acceleration=vec("desired_acceleration", n_axes),
        phase=vec("phase", 1),
        inertia=vec("task_inertia", n_axes * n_axes),
        coriolis=vec("task_coriolis", n_axes * n_axes),
        gravity=vec("task_gravity", n_axes),
    )
