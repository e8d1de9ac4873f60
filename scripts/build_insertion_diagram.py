"""Build the insertion diagram by hand -- the example to copy for a world of your own.

Every system is added and wired here explicitly: the plant with its models, the DMP source
fitted to the demonstration, the Hl-CMP controller (theta is its continuous state), the
task-space dynamics, the null-space terms, the J^T torque map, the wrist force sensor,
loggers and Meshcat. It runs the Hl-CMP once, saves an offline recording and the wired
diagram as Drake draws it.

    python scripts/build_insertion_diagram.py --out out/by_hand [--duration 9.5]
"""

import argparse
from pathlib import Path

import numpy as np
from pydrake.geometry import Meshcat, MeshcatVisualizer
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.io.outputs import write_diagram_graph
from hlcmp_drake.systems.arm import NullSpaceImpedance, ToolContactForce
from hlcmp_drake.systems.references import DmpSource
from hlcmp_drake.systems.task_space import TaskForceToJointTorque, TaskSpaceDynamics
from hlcmp_drake.worlds import arm
from hlcmp_drake.worlds.controllers import modular_system
from hlcmp_drake.worlds.models import add_plant


def build(scenario, setup, meshcat):
    builder = DiagramBuilder()
    plant, scene_graph = add_plant(builder, scenario)  # iiwa14 + rod + foam plank
    tip = plant.GetFrameByName("tip", plant.GetModelInstanceByName("insertion_tool"))

    dmp = builder.AddSystem(DmpSource(setup.dmp))  # x_d, x_d', x_d'', s
    task_space = builder.AddSystem(TaskSpaceDynamics(plant, tip))  # x, x', J, M, C, G
    controller = builder.AddSystem(
        modular_system(scenario.controllers["hlcmp"], scenario, setup.dmp.start)
    )
    task = scenario.task
    null_space = builder.AddSystem(
        NullSpaceImpedance(
            plant,
            tip,
            setup.tool_orientation,
            setup.q0,
            task.orientation_stiffness_Nm_per_rad,
            task.orientation_damping_Nms_per_rad,
            task.posture_stiffness_Nm_per_rad,
            task.posture_damping_Nms_per_rad,
        )
    )
    effort = [plant.get_joint_actuator(i).effort_limit() for i in plant.GetJointActuatorIndices()]
    torque_map = builder.AddSystem(TaskForceToJointTorque(3, effort, extra_torque=True))
    sensor = builder.AddSystem(ToolContactForce(plant, tip))

    builder.Connect(plant.get_state_output_port(), task_space.plant_state)
    builder.Connect(plant.get_state_output_port(), null_space.plant_state)
    for port in ("desired_position", "desired_velocity", "desired_acceleration", "phase"):
        builder.Connect(dmp.GetOutputPort(port), controller.GetInputPort(port))
    for port in ("position", "velocity", "task_inertia", "task_coriolis", "task_gravity"):
        builder.Connect(task_space.GetOutputPort(port), controller.GetInputPort(port))
    builder.Connect(task_space.GetOutputPort("null_space_projector"), null_space.projector)
    builder.Connect(task_space.GetOutputPort("joint_gravity"), null_space.gravity)
    builder.Connect(controller.GetOutputPort("force"), torque_map.force)
    builder.Connect(task_space.GetOutputPort("jacobian"), torque_map.jacobian)
    builder.Connect(null_space.get_output_port(), torque_map.extra)
    builder.Connect(torque_map.GetOutputPort("joint_torque"), plant.get_actuation_input_port())
    builder.Connect(plant.get_contact_results_output_port(), sensor.contact_results)

    logs = {
        name: LogVectorOutput(port, builder, scenario.log_period_s)
        for name, port in [
            ("x", task_space.GetOutputPort("position")),
            ("xd", dmp.GetOutputPort("desired_position")),
            ("f_ext", sensor.GetOutputPort("force")),
            ("Ks", controller.GetOutputPort("stiffness")),
            ("v", controller.GetOutputPort("feedforward")),
        ]
    }
    MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat)
    return builder.Build(), plant, logs


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("out/by_hand"))
    parser.add_argument(
        "--duration", type=float, default=None, help="seconds (default: the scenario's)"
    )
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)

    scenario, _ = load_scenario("insertion")
    setup = arm.prepare(scenario)  # fit the DMP, inverse kinematics for q0
    meshcat = Meshcat()
    diagram, plant, logs = build(scenario, setup, meshcat)
    graph = write_diagram_graph(args.out, diagram)

    simulator = Simulator(diagram)
    ApplySimulatorConfig(scenario.simulator_config, simulator)
    plant.SetPositions(plant.GetMyMutableContextFromRoot(simulator.get_mutable_context()), setup.q0)
    meshcat.StartRecording()
    simulator.AdvanceTo(args.duration or scenario.duration_s)
    meshcat.StopRecording()
    meshcat.PublishRecording()
    (args.out / "recording.html").write_text(meshcat.StaticHtml())

    context = simulator.get_context()
    f_z = logs["f_ext"].FindLog(context).data()[2]
    print(
        f"simulated {context.get_time():.2f} s; peak wrist force in z {np.max(np.abs(f_z)):.2f} N; "
        f"wrote {args.out / 'recording.html'} and {graph}"
    )


if __name__ == "__main__":
    main()
