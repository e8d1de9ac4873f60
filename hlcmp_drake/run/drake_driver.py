"""`hlcmp sim-driver --drake-driver`: a scenario's world driven by Drake's own simulated
iiwa driver, not the project's, over LCM and in real time.

The arm, the tool and the world (the foam and its tear) are the scenario's, built by the
World registry's `build_driven`. Everything between the plant and LCM is pydrake's:

- at Drake's status period (`kIiwaLcmStatusPeriod`, 5 ms), `BuildIiwaControl` with
  `IiwaDriver(control_mode="torque_only")`, as it is;
- at any other period, the same systems wired by hand: `SimIiwaDriver` (gravity
  compensation from the controller's plant, the effort limits, the low-pass filtered
  contact torques), `IiwaCommandReceiver` behind an LCM subscriber, and
  `IiwaStatusSender` in front of an `LcmPublisherSystem` with that period. Drake's
  `BuildIiwaControl` publishes at the constant `kIiwaLcmStatusPeriod` whatever
  `IiwaDriver.lcm_status_period` says (manipulation/kuka_iiwa/build_iiwa_control.cc;
  docs/iiwa.md).

An `LcmInterfaceSystem` hands the messages to the diagram between plant steps, and the
simulator keeps real time (target rate 1). The driver holds the last command it got, as
Drake's does; the process ends when the client has not commanded for `idle_timeout_s`,
or at `duration`.
"""

from __future__ import annotations

import dataclasses as dc
import time
from typing import Sequence

from drake import lcmt_iiwa_command, lcmt_iiwa_status
from pydrake.lcm import DrakeLcm
from pydrake.manipulation import (
    BuildIiwaControl,
    IiwaCommandReceiver,
    IiwaControlMode,
    IiwaDriver,
    IiwaStatusSender,
    SimIiwaDriver,
    kIiwaLcmStatusPeriod,
)
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.lcm import LcmInterfaceSystem, LcmPublisherSystem, LcmSubscriberSystem
from pydrake.systems.primitives import Demultiplexer, Gain

from hlcmp_drake.config.scenario import Scenario
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.iiwa_lcm import open_lcm
from hlcmp_drake.present.progress import SILENT, Progress
from hlcmp_drake.run.interrupts import StopSignals
from hlcmp_drake.run.serve import TorqueClient, without_garbage_collection
from hlcmp_drake.run.sim_driver import DriverAbort
from hlcmp_drake.run.simulate import prepared_simulator
from hlcmp_drake.worlds.build import driven_world_of
from hlcmp_drake.worlds.models import load_models

# The channels Drake's BuildIiwaControl hard-codes.
STATUS_CHANNEL, COMMAND_CHANNEL = "IIWA_STATUS", "IIWA_COMMAND"
# Simulated time advanced between two looks at the client (idle, duration).
CHECK_EVERY_S = 0.05


@dc.dataclass
class DrakeDriverSummary:
    """How a Drake-driver run ended: the status period, the commands received, the
    simulated and wall time, and why it stopped."""

    status_period_s: float
    commands: int
    sim_time_s: float
    wall_s: float
    stopped_because: str
    interrupted: bool = False  # by Ctrl-C or SIGTERM: `stopped_because` says which and when


def _iiwa_instance(plant: MultibodyPlant):
    """The model instance whose joints are actuated (the iiwa's seven)."""
    first = plant.get_joint_actuator(plant.GetJointActuatorIndices()[0])
    return first.model_instance()


def add_drake_iiwa_driver(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    *,
    lcm: DrakeLcm,
    controller_plant: MultibodyPlant,
    status_period_s: float,
) -> None:
    """Add Drake's simulated torque-only iiwa driver between `plant` and `lcm`.

    Parameters
    ----------
    builder : DiagramBuilder
        The world's, holding `plant`.
    plant : MultibodyPlant
        The simulated arm and world.
    lcm : DrakeLcm
        Where the statuses go and the commands come from.
    controller_plant : MultibodyPlant
        The driver's model of the arm and its tool (its gravity compensation and effort
        limits); it must outlive the diagram.
    status_period_s : float
        `kIiwaLcmStatusPeriod`: `BuildIiwaControl` as it is; any other: the same systems
        with a status publisher of this period.
    """
    builder.AddSystem(LcmInterfaceSystem(lcm))
    config = IiwaDriver(control_mode="torque_only")
    iiwa = _iiwa_instance(plant)
    if abs(status_period_s - kIiwaLcmStatusPeriod) < 1e-12:
        BuildIiwaControl(builder, lcm, plant, iiwa, config, controller_plant)
        return
    joints = controller_plant.num_positions()
    driver = SimIiwaDriver.AddToBuilder(builder, plant, iiwa, config, controller_plant)
    subscriber = builder.AddNamedSystem(
        "iiwa_command_subscriber",
        LcmSubscriberSystem.Make(COMMAND_CHANNEL, lcmt_iiwa_command, lcm, use_cpp_serializer=True),
    )
    receiver = builder.AddNamedSystem(
        "iiwa_command_receiver", IiwaCommandReceiver(joints, IiwaControlMode.kTorqueOnly)
    )
    builder.Connect(subscriber.get_output_port(), receiver.GetInputPort("lcmt_iiwa_command"))
    state = builder.AddNamedSystem("iiwa_state_demultiplexer", Demultiplexer(2 * joints, joints))
    builder.Connect(plant.get_state_output_port(iiwa), state.get_input_port())
    builder.Connect(state.get_output_port(0), receiver.GetInputPort("position_measured"))
    builder.Connect(receiver.GetOutputPort("torque"), driver.GetInputPort("torque"))
    sender = builder.AddNamedSystem("iiwa_status_sender", IiwaStatusSender(joints))
    publisher = builder.AddNamedSystem(
        "iiwa_status_publisher",
        LcmPublisherSystem.Make(
            STATUS_CHANNEL,
            lcmt_iiwa_status,
            lcm,
            publish_period=status_period_s,
            use_cpp_serializer=True,
        ),
    )
    builder.Connect(sender.get_output_port(), publisher.get_input_port())
    for name in ("position_commanded", "position_measured", "velocity_estimated"):
        builder.Connect(driver.GetOutputPort(name), sender.GetInputPort(name))
    # Drake's simulated iiwa reports the joint torques negated, as the hardware does
    # (manipulation/README.md); the external torques keep their sign.
    for name in ("torque_commanded", "torque_measured"):
        negate = builder.AddNamedSystem(f"sign_flip_{name}", Gain(-1.0, joints))
        builder.Connect(driver.GetOutputPort(name), negate.get_input_port())
        builder.Connect(negate.get_output_port(), sender.GetInputPort(name))
    builder.Connect(driver.GetOutputPort("torque_external"), sender.GetInputPort("torque_external"))


class DrakeDrivenWorld:
    """The scenario's world behind Drake's simulated iiwa driver, ready to run in real time.

    Parameters
    ----------
    scenario : Scenario
        An arm scenario with Drake's channel names (IIWA_STATUS, IIWA_COMMAND).
    lcm : DrakeLcm
    status_period_s : float
        A whole number of plant steps.

    Raises
    ------
    InputError
        For a scenario without an arm, other channel names, or a period that is not a
        whole number of plant steps.
    """

    def __init__(self, scenario: Scenario, lcm: DrakeLcm, status_period_s: float):
        world = driven_world_of(scenario, "Drake's iiwa driver drives an arm")
        config = scenario.iiwa_driver
        if (config.status_channel, config.command_channel) != (STATUS_CHANNEL, COMMAND_CHANNEL):
            raise InputError(
                f"{scenario.name}: Drake's iiwa driver publishes on {STATUS_CHANNEL} and listens "
                f"on {COMMAND_CHANNEL}; iiwa_driver names {config.status_channel} and "
                f"{config.command_channel}"
            )
        step = scenario.plant_config.time_step
        steps = status_period_s / step
        if status_period_s <= 0 or abs(steps - round(steps)) > 1e-9:
            raise InputError(
                f"--status-period {status_period_s:g} s must be a whole number of plant steps "
                f"(plant_config.time_step = {step} s)"
            )
        self.status_period_s = status_period_s
        # The driver's own model of the arm and the tool: the scenario's model files.
        self.controller_plant = MultibodyPlant(0.0)
        load_models(self.controller_plant, scenario)
        assert world.build_driven is not None
        built = world.build_driven(
            scenario,
            world.prepare(scenario, None),
            add_driver=lambda builder, plant: add_drake_iiwa_driver(
                builder,
                plant,
                lcm=lcm,
                controller_plant=self.controller_plant,
                status_period_s=status_period_s,
            ),
        )
        self.diagram = built.diagram
        self.simulator = prepared_simulator(built, scenario)
        self.simulator.set_target_realtime_rate(1.0)
        self.commands = 0
        self.last_command_wall: float | None = None
        lcm.Subscribe(COMMAND_CHANNEL, self._on_command)

    def _on_command(self, data: bytes) -> None:
        self.commands += 1
        self.last_command_wall = time.perf_counter()

    def run(
        self,
        duration: float | None = None,
        idle_timeout_s: float = 1.0,
        first_command_timeout_s: float = 60.0,
        reporter: Progress = SILENT,
    ) -> DrakeDriverSummary:
        """Simulate in real time until the client stops commanding (or `duration`, or
        Ctrl-C or SIGTERM: then after the simulated stretch under way, the summary
        `interrupted`).

        Parameters
        ----------
        duration : float, optional
            Stop at this simulated time [s].
        idle_timeout_s : float
            The client counts as gone after this long without a command [s].
        first_command_timeout_s : float
            Give up when no command came within this long [s].
        reporter : Progress, optional

        Returns
        -------
        DrakeDriverSummary

        Raises
        ------
        DriverAbort
            When the simulation fails, or no command came within `first_command_timeout_s`.
        """
        reporter.say(
            f"sim-driver (Drake's iiwa driver): publishing {STATUS_CHANNEL} every "
            f"{self.status_period_s * 1000:g} ms in real time; waiting for a command"
        )
        simulator = self.simulator
        simulator.Initialize()
        start = time.perf_counter()
        stopped, interrupted = None, False
        with StopSignals() as stop:
            while stopped is None:
                now = simulator.get_context().get_time()
                if stop.received:
                    interrupted = True
                    stopped = stop.stopped_at(now, bool(self.commands))
                    break
                if duration is not None and now >= duration - 1e-9:
                    stopped = f"reached --duration {duration:g} s"
                    break
                target = now + CHECK_EVERY_S
                try:
                    simulator.AdvanceTo(target if duration is None else min(target, duration))
                except RuntimeError as error:
                    message = " ".join(str(error).split())[:200]
                    raise DriverAbort(
                        f"the simulation failed at t = {now:.3f} s: {message}"
                    ) from None
                wall = time.perf_counter()
                if self.last_command_wall is None:
                    if wall - start > first_command_timeout_s:  # as the project's driver aborts
                        raise DriverAbort(
                            f"no command on {COMMAND_CHANNEL} within {first_command_timeout_s:g} s"
                        )
                elif wall - self.last_command_wall > idle_timeout_s:
                    stopped = f"no command for {idle_timeout_s:g} s (the client stopped)"
        return DrakeDriverSummary(
            self.status_period_s,
            self.commands,
            simulator.get_context().get_time(),
            time.perf_counter() - start,
            stopped,
            interrupted,
        )


def lockstep_drake(world: DrakeDrivenWorld, client: TorqueClient, lcm: DrakeLcm) -> None:
    """Serve `client` from Drake's driver in this process on one memq:// LCM, one status
    at a time: the status reaches the client, its command reaches Drake's subscriber,
    and the world advances one status period with it. The start guards pass in wall
    time, Drake's driver holding the arm with gravity compensation alone meanwhile.

    Parameters
    ----------
    world : DrakeDrivenWorld
        Built on `lcm`, not yet initialized; its real-time pacing is turned off.
    client : TorqueClient
        Subscribed on the same `lcm`.
    lcm : DrakeLcm
        memq://.
    """
    simulator = world.simulator
    simulator.set_target_realtime_rate(0.0)
    simulator.Initialize()  # publishes the status at t = 0
    period = world.status_period_s
    periods = 0
    with without_garbage_collection():
        while not client.done:
            lcm.HandleSubscriptions(0)  # the status reaches the client
            ticks = client.ticks
            client.poll()  # its command is queued for Drake's subscriber
            if client.ticks == ticks and not client.done:
                time.sleep(period)  # the start guards count wall time
            # To a whole number of periods: t + period could land a rounding error past
            # the next status, which would then be published early and skipped.
            periods += 1
            simulator.AdvanceTo(periods * period)
    client.assess()


def run_drake_driver(
    name_or_path: str,
    lcm_url: str,
    status_period_s: float = kIiwaLcmStatusPeriod,
    duration: float | None = None,
    idle_timeout_s: float = 1.0,
    overrides: Sequence[str] = (),
    reporter: Progress = SILENT,
) -> DrakeDriverSummary:
    """Load a scenario and run its world behind Drake's iiwa driver on `lcm_url`.

    Parameters
    ----------
    name_or_path : str
        A bundled arm scenario or a YAML file.
    lcm_url : str
        udpm://GROUP:PORT?ttl=0 (memq:// reaches no other process).
    status_period_s : float
        Drake's 5 ms (`BuildIiwaControl` as it is) or another whole number of plant steps.
    duration, idle_timeout_s, reporter
        As for `DrakeDrivenWorld.run`.
    overrides : sequence of str
        ``dotted.key=value`` overrides of the scenario.

    Returns
    -------
    DrakeDriverSummary
    """
    from hlcmp_drake.config.loading import load_scenario

    if lcm_url.startswith("memq://"):
        raise InputError(
            "--lcm memq:// reaches only this process: Drake's driver needs a udpm:// URL "
            "its client can reach"
        )
    scenario, _ = load_scenario(name_or_path, overrides)
    lcm = open_lcm(lcm_url)
    world = DrakeDrivenWorld(scenario, lcm, status_period_s)
    return world.run(duration, idle_timeout_s, reporter=reporter)
