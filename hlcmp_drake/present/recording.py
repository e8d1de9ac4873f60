"""3-D views of runs in Meshcat: the offline recording, and a live view while simulating.

Offline: every controller's run replayed side by side in one Meshcat animation, saved with
StaticHtml as one self-contained HTML file (opens without network). Runs are simulated
separately (one diagram each); here each run's logged plant state is replayed through its
own copy of the world -- a plant and SceneGraph with a MeshcatVisualizer under the prefix
/drake/runs/<controller> -- and the copies are set apart along the world y axis by
`recording.spacing_m`, in the order the scenario lists the controllers.

In an arm world each copy draws its tool frame as a small triad at the tool point (x red,
y green, z blue: Drake's frame illustration, posed with the plant); a 6-D run's recording
also draws, fainter and thinner, the desired orientation it logged ("q_tool_d") at the
same point, at /drake/runs/<controller>/tool_desired.

Both views label every copy with a sign above it, the controller's name on the colour of
its place in the order (matplotlib's C0, C1, ...), at /drake/runs/<controller>/label, and
place the camera so that every copy is in view: it looks from the direction of
`recording.camera_position_m` seen from `recording.camera_target_m` at the middle of all
copies, from as close as keeps them all (and their signs) inside the field of view.

Live (`LiveView`, `hlcmp run --meshcat`): the same copies and signs in a Meshcat server,
each copy drawn from its run's plant positions while that run is simulated.
"""

from __future__ import annotations

import base64
import dataclasses as dc
import io
import json
import time

import numpy as np
from pydrake.common import MemoryFile
from pydrake.common.eigen_geometry import Quaternion
from pydrake.geometry import (
    Cylinder,
    InMemoryMesh,
    Mesh,
    Meshcat,
    MeshcatVisualizer,
    MeshcatVisualizerParams,
    Rgba,
    Role,
)
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.plant import MultibodyPlantConfig
from pydrake.systems.framework import DiagramBuilder

from hlcmp_drake.config.models import scoped_frame
from hlcmp_drake.config.scenario import ArmTask, RecordingConfig, Scenario
from hlcmp_drake.core import quaternion as quat
from hlcmp_drake.worlds.models import add_plant

FIELD_OF_VIEW_DEG = 75.0  # Meshcat's default perspective camera (vertical)
MIN_ASPECT = 4.0 / 3.0  # the narrowest browser window the framing allows for
MARGIN = 1.1  # room around the copies, as a factor on the camera distance
SIGN_HEIGHT = 0.04  # a sign's height per metre of camera distance (about 2.5 % of the view)
BOX_SAMPLES = 12  # plant states per run from which a copy's extent is measured
TRIAD_LENGTH_M = 0.04  # the tool frame's axes: longer than the tools are thick, small on an arm
TRIAD_RADIUS_M = 0.002
DESIRED_TRIAD = (0.001, 0.35)  # the desired orientation's axes: radius [m], opacity


@dc.dataclass
class _Copy:
    """One run's copy of the world: a replay diagram drawing into Meshcat."""

    diagram: object
    plant: object
    scene_graph: object
    context: object
    tool: object  # the arm's tool frame (drawn as a triad), None in a world without one

    @classmethod
    def build(cls, scenario, meshcat, label):
        builder = DiagramBuilder()
        # The replay only poses geometry: a continuous plant without contact is enough.
        replay = dc.replace(scenario, plant_config=MultibodyPlantConfig(time_step=0.0))
        plant, scene_graph = add_plant(builder, replay)
        tool = None
        if isinstance(scenario.task, ArmTask):
            # Imported here: pydrake.visualization imports matplotlib, which the processes
            # that record nothing (serve, sim-driver, sweep workers) need not load.
            from pydrake.visualization import AddFrameTriadIllustration

            tool = scoped_frame(plant, scenario.task.tool_frame)
            AddFrameTriadIllustration(
                scene_graph=scene_graph,
                frame=tool,
                name="tool_frame",
                length=TRIAD_LENGTH_M,
                radius=TRIAD_RADIUS_M,
                opacity=1.0,
            )
        params = MeshcatVisualizerParams(
            prefix=f"runs/{label}", role=Role.kIllustration, delete_on_initialization_event=False
        )
        MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat, params)
        diagram = builder.Build()
        return cls(diagram, plant, scene_graph, diagram.CreateDefaultContext(), tool)

    def draw(self, t, positions):
        self.context.SetTime(t)
        self.plant.SetPositions(self.plant.GetMyContextFromRoot(self.context), positions)
        self.diagram.ForcedPublish(self.context)

    def tool_point(self):
        """The tool point in the world [m] at the positions last drawn."""
        return self.tool.CalcPoseInWorld(
            self.plant.GetMyContextFromRoot(self.context)
        ).translation()

    def extent(self, samples):
        """(lo, hi): the world box around the illustration geometry over the positions
        `samples`, or None when there is nothing to measure."""
        plant_context = self.plant.GetMyContextFromRoot(self.context)
        scene_context = self.scene_graph.GetMyContextFromRoot(self.context)
        ids = self.scene_graph.model_inspector().GetAllGeometryIds(Role.kIllustration)
        signs = np.array(
            [[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float
        )
        points = []
        for positions in samples:
            self.plant.SetPositions(plant_context, positions)
            query = self.scene_graph.get_query_output_port().Eval(scene_context)
            for geometry in ids:
                obb = query.ComputeObbInWorld(geometry)
                if obb is not None:  # None: a half space, which has no extent
                    points.append(obb.pose().multiply((signs * obb.half_width()).T).T)
        if not points:
            return None
        points = np.vstack(points)
        return points.min(axis=0), points.max(axis=0)


def _union(boxes):
    boxes = [box for box in boxes if box is not None]
    if not boxes:
        return np.array([-0.2, -0.2, 0.0]), np.array([0.2, 0.2, 0.4])
    return np.min([lo for lo, _ in boxes], axis=0), np.max([hi for _, hi in boxes], axis=0)


def _samples(positions, count=BOX_SAMPLES):
    positions = positions[np.all(np.isfinite(positions), axis=1)]
    if len(positions) == 0:
        return positions
    return positions[np.unique(np.linspace(0, len(positions) - 1, count).round().astype(int))]


def _camera_axes(config):
    toward_camera = np.asarray(config.camera_position_m, float) - np.asarray(
        config.camera_target_m, float
    )
    norm = np.linalg.norm(toward_camera)
    u = (
        toward_camera / norm
        if norm > 1e-9
        else np.array([1.0, -1.0, 0.6]) / np.linalg.norm([1.0, -1.0, 0.6])
    )
    right = np.cross(-u, [0.0, 0.0, 1.0])
    if np.linalg.norm(right) < 1e-6:  # looking straight down or up
        right = np.array([0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    return u, right, np.cross(right, -u)


def _camera_distance(corners, center, axes):
    """The least distance from `center` along the view direction at which every corner is
    inside the field of view (vertical FIELD_OF_VIEW_DEG, horizontal for MIN_ASPECT)."""
    u, right, up = axes
    tan_v = np.tan(np.radians(FIELD_OF_VIEW_DEG / 2.0))
    tan_h = tan_v * MIN_ASPECT
    r = corners - center
    needed = np.maximum(r @ u + np.abs(r @ right) / tan_h, r @ u + np.abs(r @ up) / tan_v)
    return MARGIN * max(float(np.max(needed)), 0.1)


def _corners(lo, hi):
    return np.array(
        [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
    )


def _sign_image(text, color):
    """The PNG bytes of a sign: `text` in white on `color`, and its width / height."""
    from matplotlib.figure import Figure

    height_in = 0.4
    figure = Figure(figsize=(0.16 * len(text) + 0.3, height_in), dpi=100)
    figure.patch.set_facecolor(color)
    figure.text(
        0.5,
        0.5,
        text,
        ha="center",
        va="center",
        color="white",
        fontsize=16,
        weight="bold",
        family="DejaVu Sans",
    )
    stream = io.BytesIO()
    figure.savefig(stream, format="png", facecolor=color)
    width_in, height_in = figure.get_size_inches()
    return stream.getvalue(), width_in / height_in


def _sign_mesh(text, color, width, height):
    """A double-sided glTF quad (width x height [m], facing -y, bottom edge on the origin)
    textured with the sign's image, every byte embedded, as a Drake Mesh."""
    image, _ = _sign_image(text, color)
    # glTF is y-up; Drake turns it z-up, so the quad in glTF's x-y plane stands upright.
    positions = np.array(
        [[-width / 2, 0, 0], [width / 2, 0, 0], [width / 2, height, 0], [-width / 2, height, 0]],
        np.float32,
    )
    uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)
    indices = np.array([0, 1, 2, 0, 2, 3], np.uint16)
    blob = positions.tobytes() + uv.tobytes() + indices.tobytes()
    gltf = {
        "asset": {"version": "2.0", "generator": "hlcmp_drake"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [
            {
                "primitives": [
                    {"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}
                ]
            }
        ],
        "materials": [
            {
                "doubleSided": True,
                "emissiveTexture": {"index": 0},
                "emissiveFactor": [0.4, 0.4, 0.4],
                "pbrMetallicRoughness": {
                    "baseColorTexture": {"index": 0},
                    "metallicFactor": 0.0,
                    "roughnessFactor": 1.0,
                },
            }
        ],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{}],
        "images": [{"uri": "data:image/png;base64," + base64.b64encode(image).decode()}],
        "buffers": [
            {
                "byteLength": len(blob),
                "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode(),
            }
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 32},
            {"buffer": 0, "byteOffset": 80, "byteLength": 12},
        ],
        "accessors": [
            {
                "bufferView": 0,
                "componentType": 5126,
                "count": 4,
                "type": "VEC3",
                "min": positions.min(axis=0).tolist(),
                "max": positions.max(axis=0).tolist(),
            },
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"},
        ],
    }
    return Mesh(InMemoryMesh(mesh_file=MemoryFile(json.dumps(gltf), ".gltf", f"sign {text}")))


def _color(k):
    import matplotlib.colors

    return matplotlib.colors.to_hex(f"C{k % 10}")


def frame_copies(
    meshcat: Meshcat,
    config: RecordingConfig,
    labels: list[str],
    extent: tuple[np.ndarray, np.ndarray],
) -> None:
    """Place the runs' copies along +y, put a sign above each, and aim the camera at them all.

    Parameters
    ----------
    meshcat : Meshcat
        Where the copies are drawn, under /drake/runs/<label>.
    config : RecordingConfig
        `spacing_m` between the copies; the camera's direction from
        `camera_position_m` - `camera_target_m`.
    labels : list of str
        The controllers' labels, in the order of their copies along +y.
    extent : ((3,) array, (3,) array)
        The world box [m] around one copy's geometry (as the plant puts it, before the
        copy is moved along y).
    """
    lo, hi = (np.asarray(v, float) for v in extent)
    n = max(len(labels), 1)
    span = np.array([0.0, (n - 1) * config.spacing_m, 0.0])
    axes = _camera_axes(config)
    center = 0.5 * (lo + hi + span)
    distance = _camera_distance(_corners(lo, hi + span), center, axes)
    aspects = [_sign_image(label, _color(k))[1] for k, label in enumerate(labels)]
    for _ in range(2):  # the signs stand above the copies: frame them too
        height = SIGN_HEIGHT * distance
        if config.spacing_m > 0 and aspects:
            height = min(height, 0.9 * config.spacing_m / max(aspects))
        bottom = hi[2] + 0.5 * height
        top = np.array([hi[0], hi[1], bottom + height])
        center = 0.5 * (lo + top + span)
        distance = _camera_distance(_corners(lo, top + span), center, axes)
    u = axes[0]
    facing = RollPitchYaw(0.0, 0.0, float(np.arctan2(u[0], -u[1])))
    middle = 0.5 * (lo[:2] + hi[:2])
    for k, (label, aspect) in enumerate(zip(labels, aspects)):
        meshcat.SetTransform(
            f"/drake/runs/{label}", RigidTransform([0.0, k * config.spacing_m, 0.0])
        )
        meshcat.SetObject(
            f"/drake/runs/{label}/label", _sign_mesh(label, _color(k), aspect * height, height)
        )
        meshcat.SetTransform(
            f"/drake/runs/{label}/label", RigidTransform(facing, [middle[0], middle[1], bottom])
        )
    meshcat.SetCameraPose(center + distance * u, center)


def record_runs(scenario: Scenario, runs: dict, meshcat: Meshcat | None = None) -> str:
    """The HTML text of a recording of all `runs`.

    Parameters
    ----------
    scenario : Scenario
        The world to replay the runs in, and the recording settings.
    runs : dict of str to RunResult
        By label; each must have logged its plant state as the series "plant_state"; a
        6-D run's desired orientation "q_tool_d" (w, x, y, z) is drawn at its tool point.
    meshcat : Meshcat, optional
        The Meshcat to record in (a new one by default); each run's world is drawn under
        /drake/runs/<label>, its sign at /drake/runs/<label>/label.

    Returns
    -------
    str
        One self-contained HTML file (Meshcat's StaticHtml).
    """
    config = scenario.recording
    frames_per_second = config.frames_per_second
    meshcat = meshcat or Meshcat()
    copies = {name: _Copy.build(scenario, meshcat, name) for name in runs}
    nq = next(iter(copies.values())).plant.num_positions() if copies else 0
    extent = _union(
        copy.extent(_samples(run.series["plant_state"][:, :nq]))
        for copy, run in zip(copies.values(), runs.values())
    )
    frame_copies(meshcat, config, list(runs), extent)
    meshcat.StartRecording(frames_per_second, set_visualizations_while_recording=False)
    for name, run in runs.items():
        copy, times = copies[name], _frame_times(run.t, frames_per_second)
        states = _at_frames(run.t, run.series["plant_state"], frames_per_second)
        desired = None
        if "q_tool_d" in run.series and copy.tool is not None:
            # Linear between the logged samples (a log period apart), then renormalized.
            desired = _at_frames(
                run.t, quat.hemisphere_continuous(run.series["q_tool_d"]), frames_per_second
            )
            desired /= np.linalg.norm(desired, axis=1, keepdims=True)
            _add_triad(meshcat, f"/drake/runs/{name}/tool_desired", *DESIRED_TRIAD)
        for k, (t, state) in enumerate(zip(times, states)):
            if not np.all(np.isfinite(state)):
                break
            copy.draw(t, state[:nq])
            if desired is not None and np.all(np.isfinite(desired[k])):
                meshcat.SetTransform(
                    f"/drake/runs/{name}/tool_desired",
                    RigidTransform(Quaternion(desired[k]), copy.tool_point()),
                    t,
                )
    meshcat.StopRecording()
    meshcat.PublishRecording()
    return meshcat.StaticHtml()


class LiveView:
    """The runs of a scenario drawn in a live Meshcat while they are simulated.

    Each controller gets its copy of the world under /drake/runs/<label>, set apart along
    +y and signed as in the recording; the copies, their signs and the camera are placed
    when the first run is drawn. Drawing is throttled to `frames_per_second` per run (by
    the wall clock), so the simulation barely slows down.

    Parameters
    ----------
    scenario : Scenario
        The world, its controllers (the order of the copies) and the recording settings.
    meshcat : Meshcat
        The live Meshcat (its web_url is what the user opens).
    frames_per_second : float
        At most this many drawings per run per wall-clock second (the last state of a run
        is always drawn).
    """

    def __init__(self, scenario: Scenario, meshcat: Meshcat, frames_per_second: float = 30.0):
        self._scenario, self._meshcat = scenario, meshcat
        self._labels = list(scenario.controllers)
        self._period = 1.0 / frames_per_second
        self._copies, self._last_drawn = {}, {}

    def show(self, label: str, t: float, positions: np.ndarray, final: bool = False) -> None:
        """Draw run `label`'s copy with the plant at `positions` (skipped when the last
        drawing of this run is more recent than one frame, unless `final`).

        Parameters
        ----------
        label : str
            The controller's label (a label the scenario does not list gets the next place
            along +y).
        t : float
            Simulated time [s].
        positions : (nq,) array
            The plant's generalized positions; non-finite ones are not drawn.
        final : bool
            The run's last state: drawn whatever the time since the last drawing.
        """
        now = time.perf_counter()
        if not final and now - self._last_drawn.get(label, -np.inf) < self._period:
            return
        if not np.all(np.isfinite(positions)):
            return
        copy = self._copies.get(label)
        if copy is None:
            copy = self._copies[label] = _Copy.build(self._scenario, self._meshcat, label)
            if len(self._copies) == 1:  # everything placed once, from the first run's start
                extent = _union([copy.extent([np.asarray(positions, float)])])
                frame_copies(self._meshcat, self._scenario.recording, self._labels, extent)
            if label not in self._labels:
                self._labels.append(label)
                offset = (len(self._labels) - 1) * self._scenario.recording.spacing_m
                self._meshcat.SetTransform(
                    f"/drake/runs/{label}", RigidTransform([0.0, offset, 0.0])
                )
        copy.draw(t, positions)
        self._last_drawn[label] = time.perf_counter()


def _frame_times(t, fps):
    return np.arange(0.0, t[-1] + 1e-9, 1.0 / fps)


def _at_frames(t, values, fps):
    """The logged `values` (T, n), linear between their samples, at the frames' times."""
    times = _frame_times(t, fps)
    return np.column_stack([np.interp(times, t, values[:, i]) for i in range(values.shape[1])])


def _add_triad(meshcat, path, radius, opacity):
    """Axes x, y, z (red, green, blue) of TRIAD_LENGTH_M as cylinders from the origin of
    `path`, which is then posed as the frame they show."""
    length = TRIAD_LENGTH_M
    along = {  # a Cylinder's axis is its z: turned onto each axis, its base at the origin
        "x-axis": (RotationMatrix.MakeYRotation(np.pi / 2), [length / 2, 0.0, 0.0]),
        "y-axis": (RotationMatrix.MakeXRotation(-np.pi / 2), [0.0, length / 2, 0.0]),
        "z-axis": (RotationMatrix.Identity(), [0.0, 0.0, length / 2]),
    }
    for k, (axis, (rotation, center)) in enumerate(along.items()):
        color = np.eye(3)[k]
        meshcat.SetObject(f"{path}/{axis}", Cylinder(radius, length), Rgba(*color, opacity))
        meshcat.SetTransform(f"{path}/{axis}", RigidTransform(rotation, center))
