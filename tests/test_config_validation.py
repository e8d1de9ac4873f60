"""hlcmp_drake.config.validation: an arm scenario the fast path cannot run is refused with the
field named; the issue's cases (a misspelt frame, a short vector, an unknown controller)
exit 2 at load naming the override; a bad file names the line, a directive's its item's.
tests/test_config_fields.py breaks every field of the bundled scenarios."""

import re

import pytest
from conftest import INSERTION_DEMO, one_line_error, run_cli

from hlcmp_drake.config.loading import line_of, load_scenario
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.paths import DIAGRAMS_DIR


@pytest.mark.parametrize(
    "override, expected",
    [
        ("plant_config.use_sampled_output_ports=true", "use_sampled_output_ports"),
        ("plant_config.time_step=0.0", "discrete plant"),
        ("task.control_path=quick", "must be one of fast, modular"),
    ],
)
def test_an_arm_scenario_the_fast_path_cannot_run_is_refused_with_the_field_named(
    override, expected
):
    with pytest.raises(InputError, match=expected) as error:
        load_scenario("insertion", [override])
    assert override.split("=")[0] in str(error.value) and "\n" not in str(error.value)


@pytest.mark.parametrize(
    "override, expected",
    [
        (
            "task.tool_frame=insertion_tool::tipp",
            "tool_frame: no frame 'tipp' in model 'insertion_tool' (its frames: mount, tip, tool)",
        ),
        (
            "task.puncture.object_frame=foam_plank::plnk",
            "object_frame: no frame 'plnk' in model 'foam_plank'",
        ),
        (
            "recording.camera_position_m=[1.9, -2.2]",
            "camera_position_m: needs 3 values (x, y, z) [m], got 2",
        ),
        (
            "controllers.nope.q_k=[1,1,1]",
            "no controller 'nope' (the scenario has: hlcmp, hlcmp_per_step, const_500, "
            "const_1000, const_2000)",
        ),
        ("experiment=one_dof", "experiment: 'one_dof' needs a !SliderTask task"),
        ("controllers={}", "controllers: an empty map changes nothing: a map is merged into"),
        ("recording={ }", "recording: an empty map changes nothing"),
        ("duration_s={}", "duration_s: must be a number, got a map"),
    ],
)
def test_the_issues_cases_exit_2_at_load_naming_the_override(tmp_path, override, expected):
    out = tmp_path / "out"
    line = one_line_error(run_cli("run", "insertion", "--set", override, "--out", out))
    assert line.startswith(f"hlcmp: error: override '{override}': ") and expected in line, line
    assert not out.exists()


def test_a_problem_of_a_whole_section_blames_the_override_of_a_field_it_names():
    point = "[0.1, 0.1, 0.1]"
    overrides = [
        f"recording.camera_target_m={point}",
        f"recording.camera_position_m={point}",
        "recording.spacing_m=1",
    ]
    with pytest.raises(InputError) as error:
        load_scenario("insertion", overrides)
    assert str(error.value).startswith(
        f"override 'recording.camera_position_m={point}': recording: camera_position_m must "
        "differ from camera_target_m"
    )


def test_a_files_value_that_an_override_made_wrong_blames_the_override():
    overrides = ["duration_s=3", "task=!SliderTask {}", "recording.spacing_m=1"]
    with pytest.raises(InputError) as error:
        load_scenario("insertion", overrides)
    line = line_of((DIAGRAMS_DIR / "insertion.yaml").read_text(), "reference")
    assert str(error.value) == (
        "override 'task=!SliderTask {}': reference: the slider world follows a "
        f"!StepReferenceConfig reference (as {DIAGRAMS_DIR / 'insertion.yaml'}:{line} sets it)"
    )


def test_the_override_that_alone_makes_the_problem_is_named_not_a_later_one():
    overrides = ["duration_s=-1", "task=!SliderTask {}", "duration_s=3"]
    with pytest.raises(InputError) as error:
        load_scenario("insertion", overrides)
    assert str(error.value).startswith("override 'task=!SliderTask {}': reference: ")


def test_a_sections_problem_made_by_an_override_outside_it_names_that_override():
    overrides = ["robot_imperfection.control_period_s=0.005", "task.control_path=modular"]
    with pytest.raises(InputError) as error:
        load_scenario("insertion", overrides, variant="real_arm")
    assert str(error.value).startswith(
        "override 'task.control_path=modular': robot_imperfection: "
    ), error.value


def test_a_files_problem_behind_another_is_the_files_though_an_override_fixed_the_first(
    tmp_path,
):
    path, lines = _written(tmp_path, "duration_s: 9.5", "duration_s: -1")
    text = path.read_text().replace("  spacing_m: 1.2", "  spacing_m: -1.0")
    path.write_text(text)
    with pytest.raises(InputError) as error:
        load_scenario(path, ["duration_s=3"])
    number = next(n for n, row in enumerate(text.splitlines(), 1) if "spacing_m: -1.0" in row)
    assert str(error.value).startswith(f"{path}:{number}: spacing_m: must be")


def test_a_bad_value_of_the_file_itself_is_still_the_files_with_overrides_given(tmp_path):
    path, lines = _written(tmp_path, "duration_s: 9.5", "duration_s: -1")
    with pytest.raises(InputError) as error:
        load_scenario(path, ["recording.spacing_m=1", "controllers.hlcmp.pi=2"])
    number = next(n for n, row in enumerate(lines, 1) if row.startswith("duration_s"))
    assert str(error.value).startswith(f"{path}:{number}: duration_s: must be")


def _written(tmp_path, old, new):
    text = (DIAGRAMS_DIR / "insertion.yaml").read_text()
    assert old in text
    text = text.replace(old, new, 1).replace(
        "file: demos/insertion_demo.csv", f"file: {INSERTION_DEMO}"
    )
    path = tmp_path / "s.yaml"
    path.write_text(text)
    return path, text.splitlines()


@pytest.mark.parametrize(
    "old, new, line_with, expected",
    [
        # a directive's problem names its item's line, found by its index in the list
        (
            "parent: iiwa::flange",
            "parent: iiwa::flang",
            "- add_weld:",
            "add_weld: GetFrameByName(): There is no Frame named 'flang'",
        ),
        (
            "tool_frame: insertion_tool::tip",
            "tool_frame: tool::tip",
            "tool_frame:",
            "no model 'tool'",
        ),
        ("thickness_m: 0.03", "thickness_m: 0.01", "puncture:", "puncture: depth_m must be in"),
        ("spacing_m: 1.2", "spacing_m: .nan", "spacing_m:", "spacing_m: must be finite and >= 0"),
    ],
)
def test_a_bad_scenario_file_names_the_line(tmp_path, old, new, line_with, expected):
    path, lines = _written(tmp_path, old, new)
    with pytest.raises(InputError) as error:
        load_scenario(path)
    message = str(error.value)
    changed = next(n for n, row in enumerate(lines, 1) if new in row)
    number = max(n for n, row in enumerate(lines[:changed], 1) if line_with in row)
    assert message.startswith(f"{path}:{number}: ") and expected in message, message


@pytest.mark.parametrize(
    "old, new, expected",
    [
        ("child: iiwa::iiwa_link_0", "child: iiwa::iiwa_link_9", "no Frame named 'iiwa_link_9'"),
        ("child: insertion_tool::mount", "child: insertion_tool::mouth", "named 'mouth'"),
        ("child: foam_plank::plank", "child: foam_plank::plan", "no Frame named 'plan'"),
        ("foam_plank::plank]", "foam_plank::plan]", "body with name 'foam_plank::plan'"),
    ],
)
def test_the_directive_drake_refuses_is_the_one_named_wherever_it_is(tmp_path, old, new, expected):
    # The directives that load are found by bisection: each of the insertion's welds (its
    # directives 1, 3 and 5) and its collision filter group (6) is the one named.
    path, lines = _written(tmp_path, old, new)
    with pytest.raises(InputError) as error:
        load_scenario(path)
    changed = next(n for n, row in enumerate(lines, 1) if new in row)
    number = max(n for n, row in enumerate(lines[:changed], 1) if row.startswith("- "))
    assert str(error.value).startswith(f"{path}:{number}: ") and expected in str(error.value)


def test_a_group_ignoring_a_later_group_does_not_hide_the_directive_drake_refuses(tmp_path):
    # Drake resolves the groups after every directive, so the insertion's group may ignore
    # one made after it; the directives before that one alone fail, but not as all do.
    later = (
        "    ignored_collision_filter_groups: [arm_and_plank, tool]\n"
        "- add_collision_filter_group:\n"
        "    name: tool\n"
        "    members: [insertion_tool::tol]\n"
        "    ignored_collision_filter_groups: []\n"
    )
    alone = "    ignored_collision_filter_groups: [arm_and_plank]\n"
    path, lines = _written(tmp_path, alone, later)
    with pytest.raises(InputError) as error:
        load_scenario(path)
    number = lines.index("    name: tool")  # the later group's "- " line, counted from 1
    assert str(error.value).startswith(f"{path}:{number}: "), str(error.value)
    assert "body with name 'insertion_tool::tol' not found" in str(error.value)
    # with its member's right name, the scenario loads: the group may come later
    path.write_text(path.read_text().replace("insertion_tool::tol", "insertion_tool::tool"))
    load_scenario(path)


def test_a_directives_line_is_its_items_in_the_list():
    text = (
        "a: 1\nlist:\n# a comment\n- one: 1\n  two: 2\n-   three: 3\n- four:\n    five: 5\nb: 2\n"
    )
    assert [line_of(text, f"list.{k}") for k in range(4)] == [4, 6, 7, None]
    assert line_of(text, "list.2.four.five") == 8
    assert line_of(text, "list.1.three") == 6


@pytest.mark.parametrize(
    "overrides, expected",
    [
        (
            ["controllers.vic_fd_0.5.sample_period_s=0.002"],
            "sample_period_s: the slider's fast path updates Φ once per plant step: "
            "vic_fd_0.5's must equal plant_config.time_step (0.001 s) (or task.control_path: "
            "modular), got 0.002",
        ),
        (  # the controller named, its value's line last: not read as control_path's line
            ["plant_config.time_step=0.1"],
            "sample_period_s: the slider's fast path updates Φ once per plant step: vic_fd_0.5's "
            "must equal plant_config.time_step (0.1 s) (or task.control_path: modular), got "
            "0.001 (as ",
        ),
        (["task.control_path=fastest"], "control_path: must be one of fast, modular"),
    ],
)
def test_the_sliders_control_path_is_checked_at_load(overrides, expected):
    with pytest.raises(InputError, match=re.escape(expected)):
        load_scenario("one_dof", overrides)
    # the modular path samples Φ at any period
    load_scenario(
        "one_dof", ["task.control_path=modular", "controllers.vic_fd_0.5.sample_period_s=0.002"]
    )


def test_a_6d_controller_needs_an_arm_on_the_fast_path(tmp_path):
    """The tool's orientation is an arm's, and the 6-D tick runs only in the one-call loop:
    a 6-D controller elsewhere is refused at load, its label named, in one line."""
    with pytest.raises(InputError, match="acts on the tool's orientation") as error:
        load_scenario("peg_in_hole", ["task.control_path=modular"])
    assert re.match(
        r"override 'task.control_path=modular': hlcmp_6d: controller 'hlcmp_6d' .* \(as "
        r".*peg_in_hole\.yaml:\d+ sets it\)$",
        str(error.value),
    )
    assert "\n" not in str(error.value)
    six = (
        "controllers:\n  six: !ConstantPoseImpedanceConfig\n    stiffness_N_per_m: [100.0]\n"
        "    damping_Ns_per_m: [10.0]\n    gain_l: [1.0]\n"
        "    rotational_stiffness_Nm_per_rad: [1.0, 1.0, 1.0]\n"
        "    rotational_damping_Nms_per_rad: [0.1, 0.1, 0.1]\n    gain_l_r: [0.1, 0.1, 0.1]\n"
    )
    slider = tmp_path / "slider.yaml"
    slider.write_text((DIAGRAMS_DIR / "one_dof.yaml").read_text().replace("controllers:\n", six))
    with pytest.raises(InputError, match=r"slider\.yaml:\d+: six: .* needs an !ArmTask"):
        load_scenario(slider)


def test_a_puncture_setting_in_a_world_without_one_is_refused():
    """Without task.puncture.object_frame the puncture's settings are not used: one given
    another value (a --set, a sweep's or a library's grid) would run as if it were not,
    so it is refused naming the field; its default, written out, is no setting."""
    with pytest.raises(InputError) as error:
        load_scenario("peg_in_hole", ["task.puncture.depth_m=0.01"])
    assert "depth_m: this world has no puncture (task.puncture.object_frame is empty)" in str(
        error.value
    )
    load_scenario("peg_in_hole", ["task.puncture.depth_m=0.015"])  # its default
    load_scenario("insertion", ["task.puncture.depth_m=0.01"])  # the foam's tear


def _written_elsewhere(path, text):
    """A bundled scenario's (edited) text written to `path`, its demonstration named by its
    package URL so that it is found outside diagrams/."""
    path.write_text(text.replace("demos/", "package://hlcmp_drake/diagrams/demos/"))
    return path


def test_an_experiment_whose_metrics_read_a_frame_the_models_lack_is_refused_at_load(tmp_path):
    """The peg experiment reads the hole's frame of the fixture model by name: a copy with
    the fixture renamed ran every controller and then failed in its metrics; now it stops
    at load, naming the frame and the models there are."""
    from hlcmp_drake.run.runner import experiment_worlds

    text = (DIAGRAMS_DIR / "peg_in_hole.yaml").read_text()
    text = text.replace("name: peg_fixture", "name: fx").replace("peg_fixture::", "fx::")
    renamed = _written_elsewhere(tmp_path / "renamed.yaml", text)
    with pytest.raises(InputError) as error:
        load_scenario(renamed, [], experiment_worlds())
    assert re.match(
        rf"{re.escape(str(renamed))}:\d+: experiment: 'peg_in_hole' reads the frame "
        r"'peg_fixture::hole' of the scenario's models: no model 'peg_fixture' \(the "
        r"scenario's models: iiwa, peg_tool, fx\)$",
        str(error.value),
    ), str(error.value)
    load_scenario(renamed)  # without the experiments' needs: the models themselves load


def test_an_insertion_without_a_puncture_is_refused_at_load(tmp_path):
    """The insertion's task is the tear of the plank (task.puncture): a world without one
    counted every run as done, so its claims were judged on runs that never touched the
    plank. It is refused at load, before any simulation, naming the key."""
    from hlcmp_drake.run.runner import experiment_worlds

    text = (DIAGRAMS_DIR / "insertion.yaml").read_text()
    text = re.sub(r"\n  puncture:.*?sliding_speed_m_per_s: [^\n]*", "", text, flags=re.S)
    assert "puncture" not in text.split("reference:")[0].split("task:")[1]
    unpunctured = _written_elsewhere(tmp_path / "unpunctured.yaml", text)
    with pytest.raises(InputError) as error:
        load_scenario(unpunctured, [], experiment_worlds())
    assert re.match(
        rf"{re.escape(str(unpunctured))}:\d+: experiment: 'insertion' judges a run by the tear "
        r"of the punctured object: it needs task.puncture \(task.puncture.object_frame is "
        r"empty\)$",
        str(error.value),
    ), str(error.value)
    with pytest.raises(InputError, match=r"^override 'experiment=insertion': .* task.puncture"):
        load_scenario("cutting", ["experiment=insertion"], experiment_worlds())
    load_scenario("cutting", [], experiment_worlds())  # the cut is judged by its reference


@pytest.mark.parametrize("name", ["..", ".", "../escaped", "sub/dir"])
def test_a_scenario_name_that_is_no_plain_folder_name_is_refused_before_any_run(tmp_path, name):
    """The name becomes the run's folder (out/NAME, a report's OUT/NAME, a sweep's task's):
    one that leads out of it is refused at load, the user's files where it leads kept."""
    text = (DIAGRAMS_DIR / "one_dof.yaml").read_text().replace("name: one_dof", f"name: '{name}'")
    text = text.replace("duration_s: 20.0", "duration_s: 0.3")  # short, were it to run
    (tmp_path / "own.yaml").write_text(text)
    (tmp_path / "metrics.json").write_text("the user's own")
    line = one_line_error(run_cli("run", "own.yaml", cwd=tmp_path))
    assert f"own.yaml:{line_of(text, 'name')}: name: must be a plain folder name" in line, line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["metrics.json", "own.yaml"]
    assert (tmp_path / "metrics.json").read_text() == "the user's own"
    line = one_line_error(run_cli("run", "one_dof", "--set", f"name={name}", cwd=tmp_path))
    assert line.startswith(f"hlcmp: error: override 'name={name}': name: "), line


def test_the_models_are_parsed_once_for_loads_that_change_neither_them_nor_the_config(
    monkeypatch,
):
    """Loads of one scenario share its checked plant; a weld moved by 1e-12 m, another
    plant config, or a bundled model file that changed each parse the models anew."""
    from hlcmp_drake.config import validation

    parses = []  # of the scenario's models (a load parses the plant config alone too)
    real = validation.process_directives

    def counted(plant, directives, *args, **kwargs):
        parses.extend([1] if directives else [])
        return real(plant, directives, *args, **kwargs)

    monkeypatch.setattr(validation, "process_directives", counted)
    monkeypatch.setattr(validation, "_PARSED", type(validation._PARSED)())
    load_scenario("peg_in_hole")
    assert len(parses) == 1
    seed = "task.ik_seed_rad=[0, 0.4, 0, -1.6, 0, 1.2, 0]"
    load_scenario("peg_in_hole", ["duration_s=1.5", seed])
    assert len(parses) == 1
    scenario, _ = load_scenario("peg_in_hole")
    weld = next(d.add_weld for d in scenario.directives if d.add_weld and d.add_weld.X_PC)
    weld.X_PC.translation = weld.X_PC.translation + [1e-12, 0.0, 0.0]
    validation.scenario_plant(scenario, fail=None)
    assert len(parses) == 2
    load_scenario("peg_in_hole", ["plant_config.penetration_allowance=0.002"])
    assert len(parses) == 3
    monkeypatch.setattr(validation, "bundled_models_version", lambda directives: ("edited",))
    load_scenario("peg_in_hole")
    assert len(parses) == 4


def test_the_bundled_models_version_follows_every_file_and_only_bundled_models(
    monkeypatch, tmp_path
):
    """A model file or a mesh rewritten changes the version; a directive that reads a file
    outside the bundled models has none (its changes are not followed)."""
    import os
    import shutil

    from hlcmp_drake.config import models
    from hlcmp_drake.io.paths import MODELS_DIR

    copy = tmp_path / "models"
    shutil.copytree(MODELS_DIR, copy)
    monkeypatch.setattr(models, "MODELS_DIR", copy)
    scenario, _ = load_scenario("peg_in_hole")
    before = models.bundled_models_version(scenario.directives)
    assert before is not None and len(before) == len(list(MODELS_DIR.iterdir()))
    mesh = copy / "peg_fixture.obj"
    os.utime(mesh, ns=(mesh.stat().st_atime_ns, mesh.stat().st_mtime_ns + 1))
    assert models.bundled_models_version(scenario.directives) != before
    scenario.directives[0].add_model.file = f"file://{copy}/iiwa14.sdf"
    assert models.bundled_models_version(scenario.directives) is None
    # A bundled URL that leads out of the models' folder reads a file it does not follow.
    scenario.directives[0].add_model.file = "package://hlcmp_drake/models/../diagrams/x.sdf"
    assert models.bundled_models_version(scenario.directives) is None


def test_a_pose_that_repr_does_not_spell_out_is_parsed_anew():
    """A weld's !DeterministicVector prints as its address, which a freed value's successor
    may take: such directives are not kept (a moved fixture read the old pose)."""
    from pydrake.common.schema import DeterministicVector, Transform

    from hlcmp_drake.config import validation

    scenario, _ = load_scenario("peg_in_hole")
    weld = next(d.add_weld for d in scenario.directives if d.add_weld and d.add_weld.X_PC)
    key = validation._parsed_key(scenario.plant_config, scenario.directives, False)
    assert key is not None
    pose = Transform()
    pose.translation = DeterministicVector[3](value=[0.6005, 0.0, 0.3])
    weld.X_PC = pose
    assert validation._parsed_key(scenario.plant_config, scenario.directives, False) is None
