"""hlcmp_drake.io.skill: a skill file round trips, with the world it was learned in; a
format 1 file (no world) and a format 3 one (no rotational profiles) still load; a 6-D
skill is format 4; a bad, truncated, missing or non-skill file is one clear error."""

import dataclasses as dc

import numpy as np
import pytest
from conftest import DEMO_CSV, tilted_turn

from hlcmp_drake.core.dmp import Dmp, DmpSettings
from hlcmp_drake.core.orientation_dmp import OrientationDmp
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.paths import DIAGRAMS_DIR
from hlcmp_drake.io.skill import (
    FORMAT_VERSION,
    POSE_FORMAT_VERSION,
    SIX_D_FORMAT_VERSION,
    Skill,
    SkillWorld,
    load_skill,
    save_skill,
)

WORLD = SkillWorld("insertion", "ArmTask", "0123456789abcdef" * 4)


@pytest.fixture
def skill(smooth_demo):
    t, positions = smooth_demo
    dmp = Dmp.fit(t, positions, "xyz")
    rng = np.random.default_rng(0)
    return Skill(dmp, *(rng.uniform(0, 100, dmp.theta_p.shape) for _ in range(3)), world=WORLD)


def test_round_trip(tmp_path, skill):
    path = save_skill(tmp_path / "skill.npz", skill)
    loaded = load_skill(path)
    for key in ("theta_k", "theta_d", "theta_v"):
        np.testing.assert_array_equal(getattr(loaded, key), getattr(skill, key))
    for key in ("theta_p", "start", "goal", "amplitude", "goal_scaled"):
        np.testing.assert_array_equal(getattr(loaded.dmp, key), getattr(skill.dmp, key))
    assert loaded.dmp.settings == skill.dmp.settings
    assert loaded.dmp.axis_names == ("x", "y", "z")
    assert loaded.dmp.tau == skill.dmp.tau
    assert loaded.world == WORLD


def test_a_skill_without_a_world_round_trips_as_unknown(tmp_path, skill):
    path = save_skill(tmp_path / "skill.npz", Skill.untrained(skill.dmp))
    assert load_skill(path).world is None


def test_a_format_1_file_loads_with_its_world_unknown(tmp_path, skill):
    path = save_skill(tmp_path / "skill.npz", skill)
    # A file as format 1 wrote it: no world fields.
    _rewrite(
        path, format_version=np.array(1), world_scenario=None, world_kind=None, world_digest=None
    )
    loaded = load_skill(path)
    assert loaded.world is None
    np.testing.assert_array_equal(loaded.theta_k, skill.theta_k)


def test_same_world_compares_kind_and_digest_not_the_name():
    assert WORLD.same_world(SkillWorld("my_insertion", WORLD.kind, WORLD.digest))
    assert not WORLD.same_world(SkillWorld("insertion", WORLD.kind, "f" * 64))
    assert not WORLD.same_world(SkillWorld("insertion", "SliderTask", WORLD.digest))
    assert WORLD.describe() == "'insertion' (ArmTask world 0123456789ab)"


def test_the_overrides_that_made_the_world_round_trip_and_are_described(tmp_path, skill):
    world = dc.replace(WORLD, overrides=("task.puncture.depth_m=0.0125", "task.x=a b"))
    path = save_skill(tmp_path / "skill.npz", dc.replace(skill, world=world))
    assert load_skill(path).world == world
    assert world.same_world(WORLD)  # the digest says which world, not the overrides
    assert world.describe() == (
        "'insertion' with --set task.puncture.depth_m=0.0125 --set 'task.x=a b' "
        "(ArmTask world 0123456789ab)"
    )
    # A skill saved without them holds no such field (its file as before).
    with np.load(save_skill(tmp_path / "plain.npz", skill)) as data:
        assert "world_overrides" not in data.files
    for bad in ("[1, 2]", "not json", '{"a": 1}'):
        _rewrite(path, world_overrides=np.array(bad))
        with pytest.raises(InputError, match="field 'world_overrides' must be a JSON list"):
            load_skill(path)


def _rewrite(path, **changes):
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    arrays.update(changes)
    for key in [k for k, v in changes.items() if v is None]:
        del arrays[key]
    np.savez(path, **arrays)


@pytest.mark.parametrize(
    "changes, message",
    [
        (
            {"format_version": np.array(SIX_D_FORMAT_VERSION + 1)},
            "format_version 5 is not supported (this version reads 1, 2, 3, 4)",
        ),
        ({"world_digest": None}, "missing field(s): world_digest"),
        ({"world_digest": np.array("abc")}, "field 'world_digest' must be 64 hex digits"),
        ({"world_kind": np.array("")}, "field(s) world_kind empty while the others name a world"),
        ({"world_scenario": np.array(3)}, "field 'world_scenario' must be a string"),
        ({"theta_k": np.zeros((3, 7))}, "field 'theta_k' has shape (3, 7), expected (3, 30)"),
        ({"goal": np.zeros(2)}, "field 'goal' has shape (2,)"),
        ({"theta_v": None}, "missing field(s): theta_v"),
        ({"theta_d": np.full((3, 30), np.nan)}, "NaN"),
        ({"start": np.array([0.5, np.nan, 0.2])}, "field 'start' must hold finite numbers"),
        ({"goal": np.array(["a", "b", "c"])}, "field 'goal' must hold real numbers, not text"),
        (
            {"theta_k": np.full((3, 30), 1 + 2j)},
            "field 'theta_k' must hold real numbers, not complex numbers",
        ),
        (
            {"format_version": np.array("two")},
            "field 'format_version' must be an integer, got 'two'",
        ),
        (
            {"format_version": np.array([2, 2])},
            "field 'format_version' must be an integer, got [2, 2]",
        ),
        ({"format_version": np.array(2.5)}, "field 'format_version' must be an integer, got 2.5"),
        ({"format_version": np.array(b"2")}, "field 'format_version' must be an integer, got b'2'"),
        ({"n_basis": np.array("30")}, "field 'n_basis' must be an integer, got '30'"),
        ({"n_basis": np.array(-3)}, "invalid DMP settings: n_basis must be between 2 and"),
        ({"alpha": np.array([25.0, 25.0])}, "field 'alpha' must be a number, got [25.0, 25.0]"),
        ({"tau": np.array("x")}, "field 'tau' must be a number, got 'x'"),
        ({"axis_names": np.array([1, 2, 3])}, "field 'axis_names' must be a list of strings"),
        ({"goal_scaled": np.array(["a", "b", "c"])}, "field 'goal_scaled' must hold true/false"),
        ({"amplitude": np.full(3, np.inf)}, "field 'amplitude' must hold finite numbers"),
        ({"tau": np.array(np.inf)}, "field 'tau' must be positive and finite, got inf"),
        ({"tau": np.array(-1.0)}, "field 'tau' must be positive and finite, got -1.0"),
    ],
)
def test_bad_skill_files(tmp_path, skill, changes, message):
    path = save_skill(tmp_path / "skill.npz", skill)
    _rewrite(path, **changes)
    with pytest.raises(InputError, match=None) as error:
        load_skill(path)
    assert message in str(error.value)
    assert str(error.value).startswith(str(path))


def test_truncated_and_missing_files(tmp_path, skill):
    path = save_skill(tmp_path / "skill.npz", skill)
    path.write_bytes(path.read_bytes()[:200])
    with pytest.raises(InputError, match="not a readable skill file"):
        load_skill(path)
    with pytest.raises(InputError, match="no such file"):
        load_skill(tmp_path / "none.npz")


@pytest.mark.parametrize(
    "content, extra",
    [
        (DEMO_CSV.encode(), "; this is a demonstration CSV (hlcmp fit makes a skill of it)"),
        (
            (DIAGRAMS_DIR / "insertion.yaml").read_bytes(),
            "; this is a scenario file (give it to hlcmp run, or as --scenario)",
        ),
        (
            (DIAGRAMS_DIR / "sweeps" / "tiny.yaml").read_bytes(),
            "; this is a sweep file (give it to hlcmp sweep)",
        ),
        (b'{"scenario": "insertion"}', "; this is a JSON file (a run's metrics.json?)"),
        (b"some notes\n", "; this is a text file"),
        (b"\x93NUMPY\x01\x00" + b"\x00" * 40, ""),  # a .npy, not a .npz
        (b"", ""),
    ],
)
def test_a_non_skill_file_gets_its_own_message(tmp_path, content, extra):
    path = tmp_path / "skill.npz"
    path.write_bytes(content)
    with pytest.raises(InputError) as error:
        load_skill(path)
    message = str(error.value)
    assert message == (
        f"{path}: "
        + ("the file is empty, " if not content else "")
        + "not a skill file (a .npz written by hlcmp fit/learn)"
        + extra
    )
    assert "pickle" not in message


@pytest.fixture
def pose_skill():
    """A pose skill with translational profiles only (what format 3 holds)."""
    t, positions, quaternions, _ = tilted_turn(4)
    settings = DmpSettings(n_basis=20)
    dmp = Dmp.fit(t, positions, "xyz", settings)
    zeros = np.zeros_like(dmp.theta_p)
    return Skill(dmp, zeros, zeros, zeros, orientation=OrientationDmp.fit(t, quaternions, settings))


@pytest.fixture
def six_d_skill(pose_skill):
    """A 6-D skill: the pose skill with distinct rotational weights."""
    rng = np.random.default_rng(1)
    rotational = {key: rng.uniform(0, 10, (3, 20)) for key in ("theta_kr", "theta_dr", "theta_vr")}
    return dc.replace(pose_skill, world=WORLD, **rotational)


def test_a_pose_skill_round_trips_as_format_3_and_a_position_skill_stays_format_2(
    tmp_path, skill, pose_skill
):
    path = save_skill(tmp_path / "pose.npz", pose_skill)
    with np.load(path) as data:
        assert int(data["format_version"]) == POSE_FORMAT_VERSION
        assert "theta_kr" not in data.files
    assert not load_skill(path).six_d and load_skill(path).theta_kr is None
    loaded = load_skill(path).orientation
    original = pose_skill.orientation
    for key in ("start", "goal", "demonstrated_rotation", "theta"):
        np.testing.assert_array_equal(getattr(loaded, key), getattr(original, key))
    assert (loaded.amplitude, loaded.goal_scaled) == (original.amplitude, original.goal_scaled)
    assert (loaded.settings, loaded.tau) == (original.settings, original.tau)
    np.testing.assert_array_equal(loaded.rollout(dt=0.01)[1], original.rollout(dt=0.01)[1])
    with np.load(save_skill(tmp_path / "position.npz", skill)) as data:
        assert int(data["format_version"]) == FORMAT_VERSION
        assert not any(key.startswith("orientation_") for key in data.files)
    assert load_skill(tmp_path / "position.npz").orientation is None


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"orientation_theta": None}, "missing field(s): orientation_theta"),
        (
            {"orientation_theta": np.zeros((3, 7))},
            "field 'orientation_theta' has shape (3, 7), expected (3, 20)",
        ),
        ({"orientation_goal": np.array([1.0, 0, 0, 0.1])}, "'orientation_goal' is not a unit"),
        ({"orientation_rotation": np.array([np.nan, 0, 0])}, "must hold finite numbers"),
        ({"orientation_amplitude": np.array(0.0)}, "'orientation_amplitude' must be positive"),
        (
            {"orientation_amplitude": np.array(1j)},
            "field 'orientation_amplitude' must hold real numbers, not complex numbers",
        ),
        (
            {"orientation_goal_scaled": np.array("yes")},
            "field 'orientation_goal_scaled' must hold true/false values",
        ),
    ],
)
def test_bad_pose_skill_files(tmp_path, pose_skill, changes, message):
    path = save_skill(tmp_path / "skill.npz", pose_skill)
    _rewrite(path, **changes)
    with pytest.raises(InputError) as error:
        load_skill(path)
    assert message in str(error.value)
    assert str(error.value).startswith(str(path))


def test_the_orientation_must_share_the_position_dmp_phase(pose_skill):
    other = dc.replace(pose_skill.orientation, tau=2 * pose_skill.orientation.tau)
    with pytest.raises(ValueError, match="settings and tau"):
        Skill.untrained(pose_skill.dmp, other)


def test_a_6d_skill_round_trips_as_format_4_with_all_six_weights(tmp_path, six_d_skill):
    path = save_skill(tmp_path / "six.npz", six_d_skill)
    with np.load(path) as data:
        assert int(data["format_version"]) == SIX_D_FORMAT_VERSION
    loaded = load_skill(path)
    assert loaded.six_d and loaded.world == WORLD and len(loaded.theta) == 6
    for ours, theirs in zip(loaded.theta, six_d_skill.theta, strict=True):
        np.testing.assert_array_equal(ours, theirs)
    np.testing.assert_array_equal(loaded.orientation.theta, six_d_skill.orientation.theta)


def test_an_untrained_pose_skill_is_6d_with_zero_weights(pose_skill):
    untrained = Skill.untrained(pose_skill.dmp, pose_skill.orientation)
    assert untrained.six_d and [t.shape for t in untrained.theta] == [(3, 20)] * 6
    assert not any(np.any(t) for t in untrained.theta)
    assert not Skill.untrained(pose_skill.dmp).six_d


def test_rotational_weights_go_together_with_an_orientation(pose_skill, six_d_skill):
    with pytest.raises(ValueError, match="all three or none"):
        dc.replace(six_d_skill, theta_vr=None)
    with pytest.raises(ValueError, match="need the orientation DMP"):
        dc.replace(six_d_skill, orientation=None)
    with pytest.raises(ValueError, match=r"must each be \(3, 20\)"):
        dc.replace(six_d_skill, theta_dr=np.zeros((3, 7)))


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"theta_dr": None}, "missing field(s): theta_dr"),
        ({"theta_kr": np.zeros((2, 20))}, "field 'theta_kr' has shape (2, 20), expected (3, 20)"),
        ({"theta_vr": np.full((3, 20), np.inf)}, "field 'theta_vr' must hold finite numbers"),
        ({"orientation_goal": None}, "missing field(s): orientation_goal"),
    ],
)
def test_bad_6d_skill_files(tmp_path, six_d_skill, changes, message):
    path = save_skill(tmp_path / "skill.npz", six_d_skill)
    _rewrite(path, **changes)
    with pytest.raises(InputError) as error:
        load_skill(path)
    assert message in str(error.value)
    assert str(error.value).startswith(str(path))
