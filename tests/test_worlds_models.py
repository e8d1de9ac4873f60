"""hlcmp_drake.worlds.models: Drake's loading errors in one line; the peg world's models
as Drake parses them."""

import math
import subprocess
import sys

import numpy as np
import pytest
from pydrake.geometry import Capsule, Mesh
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.systems.framework import DiagramBuilder

from hlcmp_drake.io.paths import MODELS_DIR, register_package
from hlcmp_drake.worlds.models import drake_error_line

OFFLINE = (
    "PackageMap: when downloading 'drake_models', the downloader experienced an error: All "
    "downloads failed:\n\nCandidate https://github.com/RobotLocomotion/models/archive/abc.tar.gz "
    "failed:\n<urlopen error [Errno -2] Name or service not known>\n\nCandidate "
    "https://drake-mirror.csail.mit.edu/abc.tar.gz failed:\n<urlopen error [Errno -2] Name or "
    "service not known>\n"
)


def test_a_failed_download_ends_with_its_reason_not_a_colon():
    line = drake_error_line(RuntimeError(OFFLINE))
    assert "\n" not in line and line.startswith("PackageMap: when downloading 'drake_models'")
    assert line.endswith(
        "All downloads failed: 2 candidates, the first "
        "(https://github.com/RobotLocomotion/models/archive/abc.tar.gz) with "
        "<urlopen error [Errno -2] Name or service not known>"
    )


def test_other_errors_keep_their_first_line_and_what_a_colon_announces():
    assert drake_error_line(RuntimeError("bad file\nmore detail")) == "bad file"
    assert drake_error_line(RuntimeError("could not parse:\n\n  line 3: x\n")) == (
        "could not parse: line 3: x"
    )
    assert drake_error_line(RuntimeError("")) == "RuntimeError"


def _peg_world():
    """The peg tool and the fixture parsed by Drake into a plant with a SceneGraph."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.001)
    parser = Parser(plant)
    register_package(parser.package_map())
    for name in ("peg_tool", "peg_fixture"):
        parser.AddModels(str(MODELS_DIR / f"{name}.sdf"))
    plant.Finalize()
    return plant, scene_graph


def _collision(plant, scene_graph, body_name):
    (geometry,) = plant.GetCollisionGeometriesForBody(plant.GetBodyByName(body_name))
    inspector = scene_graph.model_inspector()
    properties = inspector.GetProximityProperties(geometry)
    assert properties.HasProperty("hydroelastic", "compliance_type")
    modulus = (  # only a compliant geometry has one
        properties.GetProperty("hydroelastic", "hydroelastic_modulus")
        if properties.HasProperty("hydroelastic", "hydroelastic_modulus")
        else None
    )
    return inspector.GetShape(geometry), modulus


def test_drake_parses_the_peg_and_the_fixture_with_their_contact_sides():
    plant, scene_graph = _peg_world()
    peg, peg_modulus = _collision(plant, scene_graph, "tool")
    fixture, fixture_modulus = _collision(plant, scene_graph, "fixture")
    assert isinstance(peg, Capsule) and peg.radius() == 0.006  # the 12.0 mm peg
    assert isinstance(fixture, Mesh)
    assert peg_modulus == 5.0e9 and fixture_modulus is None  # compliant peg, rigid fixture
    tip = plant.GetFrameByName("tip").GetFixedPoseInBodyFrame().translation()
    assert tip[2] == pytest.approx(0.07 + 0.024 + 0.006)  # the end of the rounded tip
    assert plant.HasFrameNamed("hole")


def test_the_fixture_mesh_is_the_scripts_closed_block_with_a_chamfered_hole(tmp_path):
    script = MODELS_DIR.parent / "scripts" / "make_peg_fixture.py"
    out = tmp_path / "fixture.obj"
    subprocess.run([sys.executable, str(script), "--out", str(out)], check=True)
    bundled = MODELS_DIR / "peg_fixture.obj"
    assert out.read_text() == bundled.read_text()
    lines = bundled.read_text().splitlines()
    vertices = np.array([[float(v) for v in ln.split()[1:]] for ln in lines if ln[:2] == "v "])
    faces = np.array([[int(i) - 1 for i in ln.split()[1:]] for ln in lines if ln[:2] == "f "])
    corners = vertices[faces]
    volume = np.sum(np.einsum("ij,ij->i", corners[:, 0], np.cross(corners[:, 1], corners[:, 2])))
    bore = math.pi * 0.0061**2 * 0.025
    chamfer = (
        math.pi * 0.001 / 3 * (0.0071**2 + 0.0071 * 0.0061 + 0.0061**2)
        - math.pi * 0.0061**2 * 0.001
    )
    assert volume / 6 == pytest.approx(0.06 * 0.06 * 0.025 - bore - chamfer, rel=2e-3)  # outward
    radii = np.hypot(vertices[:, 0], vertices[:, 1])
    assert np.min(radii) == pytest.approx(0.0061, abs=1e-7)  # 0.2 mm diametral clearance on the peg
