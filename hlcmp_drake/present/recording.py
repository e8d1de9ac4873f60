"""Offline 3-D recordings: every controller's run replayed side by side in one Meshcat
animation, saved with StaticHtml as one self-contained HTML file (opens without network).

Runs are simulated separately (one diagram each); here each run's logged plant state is
replayed through its own copy of the world -- a plant and SceneGraph with a
MeshcatVisualizer under the prefix /drake/<controller> -- and the copies are set apart
along the world y axis, in the order the scenario lists the controllers.
"""

from __future__ import annotations

import numpy as np
from pydrake.geometry import Meshcat, MeshcatVisualizer, MeshcatVisualizerParams, Role
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlantConfig
from pydrake.systems.framework import DiagramBuilder

from hlcmp_drake.config.scenario import Scenario
from hlcmp_drake.worlds.models import add_plant


def _replay_diagram(scenario, meshcat, prefix):
    import dataclasses as dc

    builder = DiagramBuilder()
    # The replay only poses geometry: a continuous plant without contact is enough.
    replay = dc.replace(scenario, plant_config=MultibodyPlantConfig(time_step=0.0))
    plant, scene_graph = add_plant(builder, replay)
    params = MeshcatVisualizerParams(prefix=prefix, role=Role.kIllustration,
                                     delete_on_initialization_event=False)
    MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat, params)
    return builder.Build(), plant


def record_runs(scenario: Scenario, runs: dict, meshcat: Meshcat | None = None) -> str:
    """The HTML text of a recording of all `runs`.

    Parameters
    ----------
    scenario : Scenario
        The world to replay the runs in, and the recording settings.
    runs : dict of str to RunResult
        By label; each must have logged its plant state as the series "plant_state".
    meshcat : Meshcat, optional
        The Meshcat to record in (a new one by default); each run's world is drawn under
        /drake/runs/<label>.

    Returns
    -------
    str
        One self-contained HTML file (Meshcat's StaticHtml).
    """
    config = scenario.recording
    spacing_m, frames_per_second = config.spacing_m, config.frames_per_second
    meshcat = meshcat or Meshcat()
    meshcat.StartRecording(frames_per_second, set_visualizations_while_recording=False)
    for k, (name, run) in enumerate(runs.items()):
        prefix = f"runs/{name}"
        diagram, plant = _replay_diagram(scenario, meshcat, prefix)
        context = diagram.CreateDefaultContext()
        plant_context = plant.GetMyContextFromRoot(context)
        meshcat.SetTransform(f"/drake/{prefix}", RigidTransform([0.0, k * spacing_m, 0.0]))
        nq = plant.num_positions()
        for t, state in zip(_frame_times(run.t, frames_per_second), _states_at(run, frames_per_second)):
            if not np.all(np.isfinite(state)):
                break
            context.SetTime(t)
            plant.SetPositions(plant_context, state[:nq])
            diagram.ForcedPublish(context)
    middle = np.array([0.0, 0.5 * (len(runs) - 1) * spacing_m, 0.0])
    meshcat.SetCameraPose(middle + config.camera_position_m, middle + config.camera_target_m)
    meshcat.StopRecording()
    meshcat.PublishRecording()
    return meshcat.StaticHtml()


def _frame_times(t, fps):
    return np.arange(0.0, t[-1] + 1e-9, 1.0 / fps)


def _states_at(run, fps):
    times = _frame_times(run.t, fps)
    states = run.series["plant_state"]
    return np.column_stack([np.interp(times, run.t, states[:, i]) for i in range(states.shape[1])])
