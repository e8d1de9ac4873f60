"""hlcmp_drake.systems.arm_loop: ArmControlLoop, the arm's controller in one Python evaluation
per plant step, against the modular systems and ArmTick."""

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from hlcmp_drake.core.laws import TaskSpaceInstant
from hlcmp_drake.systems.arm import BelowTaskImpedance, NullSpaceImpedance
from hlcmp_drake.systems.arm_loop import ArmControlLoop, ArmTick
from hlcmp_drake.systems.task_space import TaskSpaceDynamics, TaskSpaceModel
from hlcmp_drake.worlds.controllers import hlcmp_law, modular_system
from hlcmp_drake.worlds.models import add_plant, scoped_frame


def test_one_tick_gives_the_modular_systems_torque(insertion):
    """At a contact-like state, the loop's torque equals J^T f_c + the null-space torque of
    the modular chain, to rounding."""
    scenario, setup = insertion
    builder = DiagramBuilder()
    plant, _ = add_plant(builder, scenario)
    tip = scoped_frame(plant, scenario.task.tool_frame)
    law = hlcmp_law(scenario.controllers["hlcmp"], scenario)
    gains = (100.0, 10.0, 20.0, 5.0)
    effort = [plant.get_joint_actuator(i).effort_limit() for i in plant.GetJointActuatorIndices()]
    loop = ArmControlLoop(
        ArmTick(
            TaskSpaceModel(plant, tip),
            BelowTaskImpedance(plant, tip, setup.tool_orientation, setup.q0, *gains),
            law,
            effort,
        ),
        0.001,
    )
    rng = np.random.default_rng(3)
    state = np.concatenate([setup.q0 + rng.normal(0, 0.02, 7), rng.normal(0, 0.2, 7)])
    theta = rng.uniform(0, 300, law.theta_size)
    reference = dict(
        desired_position=setup.dmp.start + [0.0, 0.0, -0.01],
        desired_velocity=[0.0, 0.0, -0.03],
        desired_acceleration=[0.0, 0.0, 0.02],
        phase=[0.4],
    )
    context = loop.CreateDefaultContext()
    loop.plant_state.FixValue(context, state)
    loop.GetInputPort("theta").FixValue(context, theta)
    for name, value in reference.items():
        loop.GetInputPort(name).FixValue(context, value)
    Simulator(loop, context).AdvanceTo(0.0005)  # the tick at t = 0
    fast_torque = loop.GetOutputPort("joint_torque").Eval(context)
    fast_rates = loop.GetOutputPort("theta_rate").Eval(context)

    task_space = TaskSpaceDynamics(plant, tip)
    ts_context = task_space.CreateDefaultContext()
    task_space.plant_state.FixValue(ts_context, state)
    terms = task_space.terms(ts_context)
    out = law.command(
        TaskSpaceInstant(
            terms.position,
            terms.velocity,
            *(
                np.asarray(reference[k], float)
                for k in ("desired_position", "desired_velocity", "desired_acceleration")
            ),
            0.4,
            terms.inertia,
            terms.coriolis,
            terms.gravity,
        ),
        theta,
    )
    below = NullSpaceImpedance(plant, tip, setup.tool_orientation, setup.q0, *gains)
    below_context = below.CreateDefaultContext()
    below.plant_state.FixValue(below_context, state)
    below.projector.FixValue(below_context, terms.null_space.ravel())
    below.gravity.FixValue(below_context, terms.joint_gravity)
    modular_torque = np.clip(
        terms.jacobian.T @ out.force + below.get_output_port().Eval(below_context),
        -np.asarray(effort),
        effort,
    )
    assert np.abs(out.force).max() > 1.0  # a state that asks for a real command
    np.testing.assert_allclose(fast_torque, modular_torque, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(fast_rates, out.rates, rtol=1e-12)
    # and the modular controller system computes the same force from the same terms
    controller = modular_system(
        scenario.controllers["hlcmp"], scenario, np.zeros(3), law.unflatten(theta)
    )
    assert controller.num_continuous_states() == law.theta_size
