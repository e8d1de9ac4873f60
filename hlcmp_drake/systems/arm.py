"""The parts of task-space control that only a redundant arm needs: the orientation and
posture held below the translational task, and the wrist force sensor."""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RotationMatrix
from pydrake.multibody.plant import ContactResults
from pydrake.multibody.tree import Frame, JacobianWrtVariable
from pydrake.systems.framework import BasicVector, Context, LeafSystem

from hlcmp_drake.core.kernels import implementation, kernel_path
from hlcmp_drake.core.operational_space import below_task_torque


class BelowTaskImpedance:
    """tau_0 = N^T (G(q) + J_w^T (-K_o e_R - D_o w) - K_p (q - q_0) - D_p q')
    (`core.operational_space.below_task_torque`, compiled or numpy as
    `core.kernels.kernel_path` says when it is made).

    Holds the tool's orientation with a fixed rotational impedance (e_R: the rotation
    vector from the desired to the current tool orientation, w: the tool's angular
    velocity) and the arm's posture near q_0, projected with the dynamically consistent
    N^T = I - J^T Jbar^T of the translational task, so neither disturbs the task-space
    dynamics that Eqs. 33-34 assume; G(q) completes the gravity compensation whose
    task-space share J^T Jbar^T G is already in f_c.

    Parameters
    ----------
    plant : MultibodyPlant
        Finalized; a control-side context of it is made here.
    tool_frame : Frame
        The tool frame whose orientation is held.
    desired_orientation : RotationMatrix
        The tool orientation to hold, world.
    nominal_positions : (nq,) array
        q_0 [rad].
    orientation_stiffness, orientation_damping : float
        K_o [N m/rad] and D_o [N m s/rad].
    posture_stiffness, posture_damping : float
        K_p [N m/rad] and D_p [N m s/rad].
    """

    def __init__(
        self,
        plant,
        tool_frame,
        desired_orientation: RotationMatrix,
        nominal_positions,
        orientation_stiffness: float,
        orientation_damping: float,
        posture_stiffness: float,
        posture_damping: float,
    ):
        self._plant, self._frame = plant, tool_frame
        self._context = plant.CreateDefaultContext()
        self._R_desired_inverse = desired_orientation.inverse().matrix()
        self._q0 = np.asarray(nominal_positions, dtype=float)
        self._k_o, self._d_o = float(orientation_stiffness), float(orientation_damping)
        self._k_p, self._d_p = float(posture_stiffness), float(posture_damping)
        self.nq, self.nv = plant.num_positions(), plant.num_velocities()
        self._world = plant.world_frame()
        self._below_task_torque = implementation(below_task_torque, kernel_path())

    @property
    def held(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """What `below_task_torque` holds, as a compiled tick takes it: R_d^T (3, 3), q_0
        (nq,) and the gains [K_o, D_o, K_p, D_p] (4,)."""
        gains = np.array([self._k_o, self._d_o, self._k_p, self._d_p])
        return self._R_desired_inverse, self._q0, gains

    def torque(
        self,
        state: np.ndarray,
        projector: np.ndarray,
        joint_gravity: np.ndarray,
        context: Context | None = None,
    ) -> np.ndarray:
        """tau_0 at the plant state `state`.

        Parameters
        ----------
        state : (nq + nv,) array
            The plant's positions and velocities.
        projector : (nv, nv) array
            N^T of the translational task.
        joint_gravity : (nv,) array
            G(q) [N m].
        context : Context, optional
            A context of the same plant that already holds `state`'s positions (e.g.
            `TaskSpaceModel.context`), whose kinematics are then reused; only
            position-dependent terms are read from it.

        Returns
        -------
        (nv,) array
            The joint torque below the task [N m].
        """
        plant = self._plant
        if context is None:
            context = self._context
            plant.SetPositions(context, state[: self.nq])
        return self.torque_at(
            state,
            projector,
            joint_gravity,
            self._frame.CalcRotationMatrixInWorld(context).matrix(),
            plant.CalcJacobianAngularVelocity(
                context, JacobianWrtVariable.kV, self._frame, self._world, self._world
            ),
        )

    def torque_at(
        self,
        state: np.ndarray,
        projector: np.ndarray,
        joint_gravity: np.ndarray,
        rotation: np.ndarray,
        angular_jacobian: np.ndarray,
    ) -> np.ndarray:
        """tau_0 where the tool frame's orientation and angular-velocity Jacobian at
        `state`'s positions are already read (`TaskSpaceTerms.rotation` and
        `.angular_jacobian` of a `TaskSpaceModel` of this tool frame): no plant query.

        Parameters
        ----------
        state, projector, joint_gravity
            As for `torque`.
        rotation : (3, 3) array
            The tool frame's orientation R, world.
        angular_jacobian : (3, nv) array
            J_w, world.

        Returns
        -------
        (nv,) array
            The joint torque below the task [N m].
        """
        return self._below_task_torque(
            projector,
            joint_gravity,
            angular_jacobian,
            rotation,
            self._R_desired_inverse,
            state[: self.nq],
            state[self.nq :],
            self._q0,
            self._k_o,
            self._d_o,
            self._k_p,
            self._d_p,
        )

    @property
    def frame(self) -> Frame:
        """The tool frame whose orientation is held."""
        return self._frame


class NullSpaceImpedance(LeafSystem):
    """`BelowTaskImpedance` as a Drake system: tau_0, the tool's orientation and the arm's
    posture held below the translational task, for `TaskForceToJointTorque`'s
    ``extra_torque`` input.

    Sizes: nq positions and nv velocities of the plant; matrices flattened row-major.

    Input ports:

    - ``plant_state`` (nq + nv): the plant's positions q [rad] and velocities v [rad/s].
    - ``null_space_projector`` (nv * nv, row-major): N^T of the translational task [-],
      from `TaskSpaceDynamics`.
    - ``joint_gravity`` (nv): G(q) [N m], from `TaskSpaceDynamics`.

    Output ports:

    - ``joint_torque`` (nv): tau_0 [N m], `BelowTaskImpedance.torque` (the null-space
      share N^T G(q) of the gravity compensation included).

    Parameters
    ----------
    plant, tool_frame, desired_orientation, nominal_positions
        As for `BelowTaskImpedance`: the finalized plant, the tool frame whose orientation
        is held, that orientation (RotationMatrix, world) and q_0 ((nq,) array [rad]).
    orientation_stiffness, orientation_damping : float
        K_o [N m/rad] and D_o [N m s/rad], >= 0.
    posture_stiffness, posture_damping : float
        K_p [N m/rad] and D_p [N m s/rad], >= 0.
    """

    def __init__(
        self,
        plant,
        tool_frame,
        desired_orientation: RotationMatrix,
        nominal_positions,
        orientation_stiffness,
        orientation_damping,
        posture_stiffness,
        posture_damping,
    ):
        super().__init__()
        self._impedance = BelowTaskImpedance(
            plant,
            tool_frame,
            desired_orientation,
            nominal_positions,
            orientation_stiffness,
            orientation_damping,
            posture_stiffness,
            posture_damping,
        )
        nq, nv = self._impedance.nq, self._impedance.nv
        self._nv = nv
        self.plant_state = self.DeclareVectorInputPort("plant_state", BasicVector(nq + nv))
        self.projector = self.DeclareVectorInputPort("null_space_projector", BasicVector(nv * nv))
        self.gravity = self.DeclareVectorInputPort("joint_gravity", BasicVector(nv))
        self.DeclareVectorOutputPort(
            "joint_torque", nv, self._calc, {self.all_input_ports_ticket()}
        )

    def _calc(self, context, output):
        output.SetFromVector(
            self._impedance.torque(
                self.plant_state.Eval(context),
                self.projector.Eval(context).reshape(self._nv, self._nv),
                self.gravity.Eval(context),
            )
        )


class ToolContactForce(LeafSystem):
    """The contact force on the tool's body, world frame, and its torque about the tool
    point: what a wrist force/torque sensor reads of the environment (gravity and inertia
    of the tool aside). Sums the hydroelastic and point contacts in the plant's contact
    results that involve the tool's body.

    Input ports:

    - ``contact_results`` (abstract, `ContactResults`): the plant's contact results
      output.
    - ``body_poses`` (abstract, vector of RigidTransform): the plant's body poses, for
      the torque's lever arms and the tool frame.
    - ``applied_force`` (3), only with `applied_force=True`: a force the world applies to
      the tool other than by contact (a torn hole's friction, `HoleFriction`'s ``force``),
      which a wrist sensor reads too, world [N]; taken as acting at the tool point (no
      torque about it: the hole's friction acts along the tool's axis).

    Output ports:

    - ``force`` (3): the environment's force on the tool, world [N] (`force_on_tool`).
    - ``task_force`` (M): its components along `axes`, M = len(axes) [N].
    - ``torque`` (3): the environment's torque on the tool about the tool point, in the
      tool frame's axes [N m] (`torque_on_tool`).

    Parameters
    ----------
    plant : MultibodyPlant
        Finalized; the tool body's collision geometries are looked up in it.
    tool_frame : Frame
        The tool point's frame; its body's contacts are summed.
    axes : sequence of int
        The world axes (0 = x, 1 = y, 2 = z) of ``task_force``; default all three.
    applied_force : bool
        Whether to declare the ``applied_force`` input (default False).
    """

    def __init__(self, plant, tool_frame, axes=(0, 1, 2), applied_force: bool = False):
        super().__init__()
        self._plant = plant
        tool_body = tool_frame.body()
        self._body_index = tool_body.index()
        self._X_BT = tool_frame.GetFixedPoseInBodyFrame()
        self._geometries = set(plant.GetCollisionGeometriesForBody(tool_body))
        self._axes = list(axes)
        self.contact_results = self.DeclareAbstractInputPort(
            "contact_results", AbstractValue.Make(ContactResults())
        )
        self.body_poses = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate()
        )
        self.applied_force = (
            self.DeclareVectorInputPort("applied_force", BasicVector(3)) if applied_force else None
        )
        prereq = {self.all_input_ports_ticket()}
        self.DeclareVectorOutputPort("force", 3, self._calc_force, prereq)
        self.DeclareVectorOutputPort("task_force", len(self._axes), self._calc_task_force, prereq)
        self.DeclareVectorOutputPort("torque", 3, self._calc_torque, prereq)

    def _tool_contacts(self, context: Context):
        """(p_WC, f) of each contact on the tool: its point, world [m], and the force on
        the tool there, world [N]; with a hydroelastic contact also its moment about C."""
        results = self.contact_results.Eval(context)
        for i in range(results.num_hydroelastic_contacts()):
            info = results.hydroelastic_contact_info(i)
            surface = info.contact_surface()
            wrench = info.F_Ac_W()  # on the body of geometry M, at the centroid C
            sign = 1.0 if surface.id_M() in self._geometries else -1.0
            if sign > 0 or surface.id_N() in self._geometries:
                yield surface.centroid(), sign * wrench.translational(), sign * wrench.rotational()
        for i in range(results.num_point_pair_contacts()):
            info = results.point_pair_contact_info(i)
            if info.bodyA_index() == self._body_index:  # contact_force() acts on body B
                yield info.contact_point(), -info.contact_force(), np.zeros(3)
            elif info.bodyB_index() == self._body_index:
                yield info.contact_point(), info.contact_force(), np.zeros(3)

    def force_on_tool(self, context: Context) -> np.ndarray:
        """The contact force on the tool's body at this context, world frame.

        Parameters
        ----------
        context : Context
            A context of this system (its `contact_results` input is evaluated).

        Returns
        -------
        (3,) array
            Sum of the hydroelastic and point-contact forces acting on the tool's body, plus
            the `applied_force` input when there is one [N].
        """
        total = np.zeros(3)
        for _, force, _ in self._tool_contacts(context):
            total += force
        if self.applied_force is not None:
            total += self.applied_force.Eval(context)
        return total

    def torque_on_tool(self, context: Context) -> np.ndarray:
        """The contacts' torque on the tool's body about the tool point T, tool frame:
        R_WT^T sum(tau_C + (p_WC - p_WT) x f_C).

        Parameters
        ----------
        context : Context
            A context of this system (its `contact_results` and `body_poses` inputs are
            evaluated).

        Returns
        -------
        (3,) array
            [N m], about the tool frame's x, y, z.
        """
        X_WT = self.body_poses.Eval(context)[int(self._body_index)] @ self._X_BT
        p_WT = X_WT.translation()
        total = np.zeros(3)
        for point, force, moment in self._tool_contacts(context):
            total += moment + np.cross(np.asarray(point) - p_WT, force)
        return X_WT.rotation().inverse() @ total

    def _calc_torque(self, context, output):
        output.SetFromVector(self.torque_on_tool(context))

    def _calc_force(self, context, output):
        output.SetFromVector(self.force_on_tool(context))

    def _calc_task_force(self, context, output):
        output.SetFromVector(self.force_on_tool(context)[self._axes])
