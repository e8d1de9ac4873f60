"""A real arm in a simulated run (the scenario's `robot_imperfection`; the laws are in
`hlcmp_drake.core.robot`): the joints' friction on the simulated arm, the velocity estimate
and the wrist force sensor the controller reads, and the controller's model set off the
arm's."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from pydrake.systems.framework import BasicVector, Context, DiagramBuilder, LeafSystem
from pydrake.systems.primitives import Adder, LinearSystem, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from hlcmp_drake.core.robot import force_noise_samples, joint_friction_torque, low_pass_retention

if TYPE_CHECKING:
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import RigidBody
    from pydrake.systems.framework import OutputPort


class JointFriction(LeafSystem):
    """The joints' friction torque at the plant's state (`joint_friction_torque`), for the
    plant's applied_generalized_force input.

    Sizes: nq positions and nv velocities of the plant (one friction value per velocity).

    Input ports:

    - ``plant_state`` (nq + nv): the plant's positions q [rad] and velocities v [rad/s].

    Output ports:

    - ``generalized_force`` (nv): -(F_v v + F_c tanh(v / v_s)) [N m].

    Parameters
    ----------
    nq : int
        The plant's number of positions.
    viscous : (nv,) array_like
        F_v per joint [N m s/rad] (empty: none).
    coulomb : (nv,) array_like
        F_c per joint [N m] (empty: none).
    speed : float
        v_s [rad/s], > 0.
    """

    def __init__(self, nq: int, viscous, coulomb, speed: float):
        super().__init__()
        viscous, coulomb = np.asarray(viscous, dtype=float), np.asarray(coulomb, dtype=float)
        nv = max(viscous.size, coulomb.size)
        self._viscous = viscous if viscous.size else np.zeros(nv)
        self._coulomb = coulomb if coulomb.size else np.zeros(nv)
        self._speed, self._nq = float(speed), nq
        self.plant_state = self.DeclareVectorInputPort("plant_state", BasicVector(nq + nv))
        self.DeclareVectorOutputPort("generalized_force", nv, self._calc)

    def _calc(self, context: Context, output) -> None:
        v = self.plant_state.Eval(context)[self._nq :]
        output.SetFromVector(joint_friction_torque(v, self._viscous, self._coulomb, self._speed))


def velocity_estimate(n: int, period: float, cutoff_hz: float, q0: np.ndarray) -> LinearSystem:
    """The plant state as a driver reports it: the positions, and velocities from their
    differences over `period` through a first-order low-pass (`low_pass_retention`),

        v_k = a v_(k-1) + (1 - a) (q_k - q_(k-1)) / T,

    a C++ discrete linear system with state [q_(k-1), v_(k-1)] updated every `period`. Its
    output uses the present q_k (feedthrough), so a controller ticking at the same times
    reads v_k with the last difference in it, as in the driver's status.

    Input port 0 (2 n): the plant's positions q [rad] and velocities (unused) [rad/s].
    Output port 0 (2 n): q [rad] and the estimate v_k [rad/s].

    Parameters
    ----------
    n : int
        The plant's positions, one per velocity (revolute joints).
    period : float
        T, the status period [s] (the controller's).
    cutoff_hz : float
        f_c of the low-pass [Hz], > 0.
    q0 : (n,) array
        The positions at t = 0: the first difference is taken from them.

    Returns
    -------
    LinearSystem
        Named "velocity_estimate"; its default state is [q0, 0].
    """
    a = low_pass_retention(cutoff_hz, period)
    gain = (1.0 - a) / period
    eye, zero = np.eye(n), np.zeros((n, n))
    # x = [q_(k-1), v_(k-1)], u = [q_k, v]: the update and the output are the same map.
    transition = np.block([[zero, zero], [-gain * eye, a * eye]])
    feed = np.block([[eye, zero], [gain * eye, zero]])
    system = LinearSystem(transition, feed, transition, feed, period)
    system.configure_default_state(np.concatenate([q0, np.zeros(n)]))
    system.set_name("velocity_estimate")
    return system


def sensed_force(
    builder: DiagramBuilder,
    force: OutputPort,
    *,
    sigma: np.ndarray,
    bias: np.ndarray,
    seed: int,
    period: float,
    duration: float,
) -> OutputPort:
    """Add a wrist force sensor's reading: the true force plus `bias` plus Gaussian noise
    of per-axis `sigma`, a new draw every `period` (`force_noise_samples`), all in C++ (a
    zero-order-hold TrajectorySource and an Adder).

    Parameters
    ----------
    builder : DiagramBuilder
    force : OutputPort
        The true force (3, world) [N].
    sigma, bias : (3,) arrays
        The noise's standard deviation and the bias per world axis [N].
    seed : int
        The noise's seed, >= 0.
    period : float
        How often the noise is drawn [s] (the controller's period).
    duration : float
        The run's duration [s]: the noise is drawn up to it (and held after).

    Returns
    -------
    OutputPort
        The sensed force (3) [N], the Adder's output (named "sensed_force").
    """
    times, noise = force_noise_samples(sigma, seed, period, duration)
    offset = builder.AddSystem(
        TrajectorySource(PiecewisePolynomial.ZeroOrderHold(times, (noise + bias).T))
    )
    offset.set_name("force_sensor_error")
    total = builder.AddSystem(Adder(2, 3))
    total.set_name("sensed_force")
    builder.Connect(force, total.get_input_port(0))
    builder.Connect(offset.get_output_port(), total.get_input_port(1))
    return total.get_output_port()


def set_model_off(
    plant: MultibodyPlant,
    context: Context,
    *,
    arm_bodies: list[RigidBody],
    tool_body: RigidBody,
    link_mass_error: float,
    tool_mass_error: float,
    tool_com_error: np.ndarray,
) -> None:
    """Set a controller's model off the simulated arm, in the parameters of its own
    context of the plant: each arm body's mass times (1 + link_mass_error) (its unit
    inertia kept, so its rotational inertia scales too), the tool body's mass times (1 +
    tool_mass_error) and its centre of mass moved by tool_com_error.

    Parameters
    ----------
    plant : MultibodyPlant
        The simulated arm's plant (finalized).
    context : Context
        A context of `plant` that only the controller uses.
    arm_bodies : list of RigidBody
        The arm's links.
    tool_body : RigidBody
        The tool's body.
    link_mass_error, tool_mass_error : float
        Relative errors of the model's masses, > -1.
    tool_com_error : (3,) array
        The model's tool centre of mass minus the tool's, in the tool body's frame [m].
    """
    for body in arm_bodies:
        body.SetMass(context, body.default_mass() * (1.0 + link_mass_error))
    tool_body.SetMass(context, tool_body.default_mass() * (1.0 + tool_mass_error))
    tool_body.SetCenterOfMassInBodyFrame(
        context, tool_body.default_com() + np.asarray(tool_com_error, dtype=float)
    )


def arm_bodies(plant: MultibodyPlant) -> list[RigidBody]:
    """The bodies that the plant's actuated joints move: the arm's links.

    Parameters
    ----------
    plant : MultibodyPlant
        Finalized.

    Returns
    -------
    list of RigidBody
        The child body of each actuated joint, in actuator order.
    """
    return [
        plant.get_joint_actuator(index).joint().child_body()
        for index in plant.GetJointActuatorIndices()
    ]
