"""hlcmp_drake.io.demos: reading a demonstration CSV (a byte-order mark, fuzzed bytes)."""

import random

import numpy as np
import pytest
from conftest import DEMO_CSV, mutations

from hlcmp_drake.core import quaternion as quat
from hlcmp_drake.io import demos
from hlcmp_drake.io.demos import read_demonstration, write_trajectory
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.paths import DIAGRAMS_DIR


def test_a_byte_order_mark_is_invisible_to_the_reader(tmp_path):
    plain, bom = tmp_path / "plain.csv", tmp_path / "bom.csv"
    plain.write_text(DEMO_CSV)
    bom.write_bytes(b"\xef\xbb\xbf" + DEMO_CSV.encode())
    for got, expected in zip(read_demonstration(bom), read_demonstration(plain)):
        np.testing.assert_array_equal(got, expected)
    bad = tmp_path / "bad.csv"
    bad.write_bytes(b"\xef\xbb\xbfx,y\n1,2\n")  # a real header problem is still named plainly
    with pytest.raises(InputError, match=r":1: the first column must be 't' .*, found 'x';"):
        read_demonstration(bad)


def test_fuzzed_demonstrations_never_crash(tmp_path):
    rng = random.Random(1234)
    good = "t,x,y,z\n" + "".join(
        f"{k * 0.1:.1f},{0.5 + k * 0.01:.3f},0.0,{0.4 - k * 0.005:.4f}\n" for k in range(15)
    )
    path = tmp_path / "demo.csv"
    outcomes = {"ok": 0, "error": 0}
    for text in mutations(good, rng, 300):
        data = text.encode()
        if rng.random() < 0.1:  # now and then a byte that is not UTF-8 at all
            cut = rng.randrange(len(data) + 1)
            data = data[:cut] + b"\xff" + data[cut:]
        path.write_bytes(data)
        try:
            t, positions, axes = read_demonstration(path)
            assert np.all(np.diff(t) > 0) and np.all(np.isfinite(positions)) and len(t) >= 10
            outcomes["ok"] += 1
        except InputError as error:
            assert "\n" not in str(error) and str(error).startswith(str(path))
            outcomes["error"] += 1
    assert outcomes["ok"] > 0 and outcomes["error"] > 0


def _write(path, t, x):
    path.write_text("t,x,y,z\n" + "".join(f"{a:.6f},{b:.6f},0,0.2\n" for a, b in zip(t, x)))
    return path


def test_a_jump_faster_than_the_bound_is_refused_with_its_line(tmp_path):
    from hlcmp_drake.io.demos import MAX_SPEED_M_PER_S

    t = 0.01 * np.arange(30)
    x = 0.001 * np.arange(30)
    x[15:] += 0.1  # 10 cm between two 10 ms samples: 10 m/s
    path = _write(tmp_path / "jump.csv", t, x)
    with pytest.raises(InputError) as error:
        read_demonstration(path)
    message = str(error.value)
    assert message.startswith(f"{path}:17: the demonstration moves 10.1 cm in 10 ms from line 16")
    assert f"faster than the {MAX_SPEED_M_PER_S:g} m/s" in message and "\n" not in message
    # the same jump spread over five samples of a 1 kHz recording is just as fast
    t = 0.001 * np.arange(300)
    x = np.where(t < 0.1, 0.0, np.minimum((t - 0.1) / 0.005, 1.0) * 0.1)
    with pytest.raises(InputError, match=r"jump.csv:10[2-6]: the demonstration moves 2.0 cm"):
        read_demonstration(_write(path, t, x))


def test_fast_moves_and_a_noisy_1khz_recording_are_not_jumps(tmp_path):
    rng = np.random.default_rng(0)
    t = 0.001 * np.arange(2000)
    x = 1.0 * t + rng.normal(0.0, 0.001, len(t))  # 1 m/s, 1 mm of noise per sample
    read_demonstration(_write(tmp_path / "noisy.csv", t, x))
    t = 0.01 * np.arange(100)
    read_demonstration(_write(tmp_path / "fast.csv", t, 2.5 * t))  # 2.5 m/s throughout
    with pytest.raises(InputError, match=r"fast.csv:\d+: .* 3.5 m/s over 10 ms"):
        read_demonstration(_write(tmp_path / "fast.csv", t, 3.5 * t))


def test_a_time_column_in_milliseconds_is_refused_where_it_passes_an_hour(tmp_path):
    t = 10.0 * np.arange(1000)  # 10 ms samples written in ms: 9990 "s"
    path = _write(tmp_path / "ms.csv", t, 1e-5 * t)
    with pytest.raises(InputError) as error:
        read_demonstration(path)
    assert str(error.value).startswith(
        f"{path}:363: t = 3610 s is more than 3600 s after the first sample: t is in seconds "
        "(a time in milliseconds?)"
    )
    t = 0.01 * np.arange(1000)
    read_demonstration(_write(path, t, 0.01 * t))


def test_a_short_recording_with_its_time_in_milliseconds_is_refused_by_its_sample_period(
    tmp_path,
):
    t = 4.0 * np.arange(626)  # 2.5 s at 250 Hz written in ms: under an hour, a 2500 s run
    path = _write(tmp_path / "ms.csv", t, 1e-5 * t)
    with pytest.raises(InputError) as error:
        read_demonstration(path)
    assert str(error.value) == (
        f"{path}: its samples are 4 s apart (the median; t from 0 to 2500 s): a demonstration "
        "is sampled more often than every 0.5 s; t is in seconds (a time in milliseconds?)"
    )
    t = 0.4 * np.arange(12)  # 2.5 Hz, sparse but in seconds
    assert len(read_demonstration(_write(path, t, 0.01 * t))[0]) == 12


def test_numpys_commented_header_is_read_and_a_row_index_is_named(tmp_path):
    t = 0.01 * np.arange(20)
    data = np.column_stack([t, 0.5 + 0.01 * t, 0 * t, 0.2 + 0 * t])
    plain, commented = tmp_path / "plain.csv", tmp_path / "savetxt.csv"
    np.savetxt(plain, data, delimiter=",", header="t,x,y,z", comments="")
    np.savetxt(commented, data, delimiter=",", header="t,x,y,z")  # "# t,x,y,z"
    assert commented.read_text().startswith("# t,x,y,z\n")
    for got, expected in zip(read_demonstration(commented), read_demonstration(plain)):
        np.testing.assert_array_equal(got, expected)
    indexed = tmp_path / "indexed.csv"
    indexed.write_text(
        ",t,x,y,z\n" + "".join(f"{k},{row[0]},{row[1]},0,0.2\n" for k, row in enumerate(data))
    )
    with pytest.raises(InputError, match=r"indexed.csv:1: column 1 has no name \(a row index\?"):
        read_demonstration(indexed)


@pytest.mark.parametrize(
    "text, line",
    [
        ("# recorded 2024-03-01 by the FRI logger\n" + DEMO_CSV, 1),
        ("#\n" + DEMO_CSV, 1),
        (DEMO_CSV.replace("\n0.3,", "\n# paused here\n0.3,"), 5),
    ],
    ids=["before the header", "an empty one", "between samples"],
)
def test_a_comment_line_is_refused_with_its_line(tmp_path, text, line):
    path = tmp_path / "demo.csv"
    path.write_text(text)
    with pytest.raises(InputError) as error:
        read_demonstration(path)
    comment = text.splitlines()[line - 1]
    assert str(error.value) == (
        f"{path}:{line}: '{comment}': comment lines are not allowed (a '#' is read only "
        "before the header's names, as numpy's savetxt writes '# t,x,y,z')"
    )


def test_the_bundled_demonstrations_pass_the_speed_bound():
    from hlcmp_drake.io.paths import DIAGRAMS_DIR

    for path in sorted((DIAGRAMS_DIR / "demos").glob("*.csv")):
        assert len(read_demonstration(path, with_orientation=True)[0]) > 100


def _pose_text(quaternions, header="t,x,y,z,qw,qx,qy,qz"):
    rows = [
        f"{0.01 * k:.2f},{0.001 * k:.3f},0,0.2," + ",".join(f"{v:.9g}" for v in q)
        for k, q in enumerate(quaternions)
    ]
    return header + "\n" + "\n".join(rows) + "\n"


def _turn(count=20):
    angles = np.linspace(0.0, 1.0, count)[:, None] * np.array([0.0, 0.0, 1.0])
    return quat.from_rotation_vector(angles)


def test_a_pose_is_read_unit_and_hemisphere_continuous(tmp_path):
    q = _turn()
    signs = np.where(np.arange(len(q)) % 3 == 1, -1.0, 1.0)[:, None]
    path = tmp_path / "pose.csv"
    path.write_text(_pose_text(q * signs * 1.005))  # within the norm tolerance
    t, positions, axes, read = read_demonstration(path, with_orientation=True)
    np.testing.assert_allclose(read, q, atol=1e-9)
    assert axes == ("x", "y", "z") and positions.shape == (20, 3)
    plain = tmp_path / "plain.csv"
    plain.write_text(
        "t,x,y,z\n" + "".join(f"{0.01 * k:.2f},{0.001 * k:.3f},0,0.2\n" for k in range(20))
    )
    assert read_demonstration(plain, with_orientation=True)[3] is None
    np.testing.assert_array_equal(read_demonstration(plain)[1], positions)


@pytest.mark.parametrize(
    "row, values, message",
    [
        (5, [0, 0, 0, 0], ":7: the orientation (0,0,0,0) is zero, which is no rotation"),
        (8, [1.05, 0, 0, 0], ":10: the orientation (1.05,0,0,0) has norm 1.05; a unit quaternion"),
        (3, [0.3, 0.2, 0.1, 0.1], ":5: the orientation (0.3,0.2,0.1,0.1) has norm 0.3873"),
        (4, [1, 0, float("nan"), 0], ":6: column 'qy' is not finite"),
        (6, [1e200, 1e200, 0, 0], ":8: the orientation (1e+200,1e+200,0,0) has norm inf"),
    ],
)
@pytest.mark.filterwarnings("error")  # the one line is all: no numpy warning before it
def test_a_bad_quaternion_is_refused_with_its_line(tmp_path, row, values, message):
    q = _turn().astype(object)
    q[row] = values
    path = tmp_path / "pose.csv"
    path.write_text(_pose_text(q))
    with pytest.raises(InputError) as error:
        read_demonstration(path, with_orientation=True)
    assert str(error.value).startswith(f"{path}{message}")


@pytest.mark.parametrize(
    "header, message",
    [
        ("t,x,y,z,qx,qw,qy,qz", "orientation columns must be qw,qx,qy,qz, in that order"),
        ("t,qw,qx,qy,qz,x,y,z", "right after the positions"),
        ("t,x,y,z,qw,qx,qy", "orientation columns must be qw,qx,qy,qz"),
        ("t,x,y,z,wx,wy,wz", "angular velocity columns wx,wy,wz need qw,qx,qy,qz"),
        (
            "t,x,y,z,qw,qx,qy,qz,wx,wy,wz,vx,vy,vz",
            "angular velocity columns must be wx,wy,wz, last",
        ),
    ],
)
def test_misplaced_orientation_columns_are_named(tmp_path, header, message):
    path = tmp_path / "pose.csv"
    path.write_text(header + "\n")
    with pytest.raises(InputError, match=":1: ") as error:
        read_demonstration(path, with_orientation=True)
    assert message in str(error.value)


def test_a_reader_of_positions_refuses_a_pose(tmp_path):
    path = tmp_path / "pose.csv"
    path.write_text(_pose_text(_turn()))
    with pytest.raises(InputError, match=r":1: columns qw,qx,qy,qz: an orientation is not used"):
        read_demonstration(path)


def test_a_pose_trajectory_round_trips(tmp_path):
    q = _turn()
    t = 0.01 * np.arange(20)
    positions = np.column_stack([t, 0 * t, 0.2 + 0 * t])
    omega = np.tile([0.0, 0.0, 1.0 / 0.19], (20, 1))
    path = write_trajectory(
        tmp_path / "traj.csv",
        t,
        positions,
        "xyz",
        np.gradient(positions, t, axis=0),
        quaternions=q,
        angular_velocities=omega,
    )
    assert path.read_text().splitlines()[0] == "t,x,y,z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz"
    _, read_positions, _, read_q = read_demonstration(path, with_orientation=True)
    np.testing.assert_allclose(read_q, q, atol=1e-8)
    np.testing.assert_allclose(read_positions, positions, atol=1e-9)


def test_a_turn_faster_than_the_bound_is_refused_with_its_line(tmp_path):
    from hlcmp_drake.io.demos import MAX_TURN_RATE_RAD_PER_S

    q = _turn(30)
    q[15:] = quat.multiply(quat.from_rotation_vector([np.pi / 2, 0.0, 0.0]), q[15:])
    path = tmp_path / "flip.csv"
    path.write_text(_pose_text(q))
    with pytest.raises(InputError) as error:
        read_demonstration(path, with_orientation=True)
    message = str(error.value)
    assert message.startswith(f"{path}:17: the demonstration turns 90.0 deg in 10 ms from line 16")
    assert f"faster than the {MAX_TURN_RATE_RAD_PER_S:g} rad/s" in message
    # 1 deg of noise at 1 kHz on a brisk turn (2 rad/s), and every sign switched: no jump.
    rng = np.random.default_rng(5)
    t = 0.001 * np.arange(2000)
    smooth = quat.from_rotation_vector(2.0 * t[:, None] * np.array([0.0, 0.6, 0.8]))
    noise = quat.from_rotation_vector(rng.normal(0.0, np.radians(1.0), (2000, 3)))
    noisy = quat.multiply(noise, smooth) * rng.choice([-1.0, 1.0], 2000)[:, None]
    rows = "".join(
        f"{a:.3f},0,0,0," + ",".join(f"{v:.9g}" for v in b) + "\n" for a, b in zip(t, noisy)
    )
    path.write_text("t,x,y,z,qw,qx,qy,qz\n" + rows)
    read_demonstration(path, with_orientation=True)


@pytest.mark.parametrize(
    "content, says",
    [
        ((DIAGRAMS_DIR / "insertion.yaml").read_bytes(), "a scenario file (give it to hlcmp run"),
        ((DIAGRAMS_DIR / "sweeps" / "tiny.yaml").read_bytes(), "a sweep file (give it to hlcmp"),
        (b'{"scenario": "insertion", "status": "ok"}\n', "a JSON file (a run's metrics.json?)"),
        (b"PK\x03\x04" + bytes(range(128, 256)), "an .npz archive (a skill, which hlcmp repro"),
    ],
    ids=["scenario", "sweep", "json", "npz"],
)
def test_a_file_of_another_kind_is_named_as_what_it_is(tmp_path, content, says):
    path = tmp_path / "demo.csv"
    path.write_bytes(content)
    with pytest.raises(InputError) as error:
        read_demonstration(path)
    message = str(error.value)
    assert message.startswith(f"{path}: {says}") and "\n" not in message
    assert "not a demonstration CSV" in message


def test_a_csv_that_is_not_utf8_is_told_to_be_saved_as_utf8(tmp_path):
    """A spreadsheet's "ANSI" export (Latin-1: a µ in a comment) is a CSV all the same."""
    path = tmp_path / "demo.csv"
    path.write_bytes(DEMO_CSV.encode() + "# 5 µm noise\n".encode("latin-1"))
    with pytest.raises(InputError) as error:
        read_demonstration(path)
    assert str(error.value).startswith(f"{path}: not UTF-8 text (invalid start byte at byte ")
    assert str(error.value).endswith("); save the CSV as UTF-8")


def test_a_bundled_demonstration_is_read_by_its_package_url():
    bundled = read_demonstration("package://hlcmp_drake/diagrams/demos/insertion_demo.csv")
    for got, expected in zip(
        bundled, read_demonstration(DIAGRAMS_DIR / "demos/insertion_demo.csv")
    ):
        np.testing.assert_array_equal(got, expected)


def test_a_replay_in_another_duration_is_held_to_the_speed_bounds_scaled(tmp_path):
    """Replayed in less time every speed grows by the ratio of the durations: the fastest
    must stay within the bounds a demonstration may move and turn, so a replay just below
    the shortest allowed duration is refused, one just above it is not, and a scenario's
    reference.duration_s is checked at load."""
    from hlcmp_drake.config.loading import load_scenario
    from hlcmp_drake.io.demos import (
        MAX_SPEED_M_PER_S,
        MAX_TURN_RATE_RAD_PER_S,
        replay_speed_problem,
    )

    path = tmp_path / "demo.csv"
    path.write_text(DEMO_CSV)  # 1.9 s; 1 cm in x and in z every 0.1 s
    shortest = 1.9 * np.hypot(0.1, 0.1) / MAX_SPEED_M_PER_S
    assert replay_speed_problem(path, 1.001 * shortest) is None
    problem = replay_speed_problem(path, 0.999 * shortest)
    assert problem.startswith("replays the 1.9 s demonstration demo.csv in ") and " m/s " in problem
    assert problem.endswith(f"give at least {shortest:.3g} s (0: as demonstrated)")
    pose = tmp_path / "pose.csv"  # 1 rad evenly in 0.29 s and 2.9 cm: its turn binds first
    pose.write_text(_pose_text(_turn(30)))
    turning = 1.0 / MAX_TURN_RATE_RAD_PER_S
    assert replay_speed_problem(pose, 1.001 * turning) is None
    assert "rad/s at its fastest" in replay_speed_problem(pose, 0.999 * turning)
    with pytest.raises(
        InputError, match=r"duration_s: replays the 1.9 s demonstration demo.csv in 0.01 s"
    ):
        load_scenario("insertion", [f"reference.file={path}", "reference.duration_s=0.01"])
    load_scenario("insertion", [f"reference.file={path}", "reference.duration_s=0.5"])


# Line breaks to str.splitlines, whitespace to float, a digit to float, none of them ASCII's.
WEIRD_MARKS = ("\x0b", "\x0c", "\x1c", "\x85", "\u2028", "\u00a0", "\u3000", "\u0663")


def _full_precision_demo(rng, samples=40):
    """t,x,y,z with every digit a float has (repr), and a force."""
    rows = ["t,x,y,z,fx,fy,fz"]
    for k in range(samples):
        values = [k * 0.01 + rng.uniform(0, 1e-3)] + [
            0.3 + k * 1e-4 + rng.uniform(-1e-5, 1e-5) for _ in range(3)
        ]
        values += [rng.uniform(-50, 50) for _ in range(3)]
        rows.append(",".join(repr(v) for v in values))
    return "\n".join(rows) + "\n"


def _outcome(path):
    """What reading `path` gives: its arrays and lines, or the error's message."""
    try:
        return read_demonstration(path, with_lines=True, with_force=True)
    except InputError as error:
        return str(error)


def test_a_file_read_at_once_reads_as_it_does_line_by_line(tmp_path, monkeypatch):
    """numpy's one pass over a file gives the values, line numbers and messages of the
    line-by-line reading, or leaves the file to it: on files of full-precision values,
    CRLF line ends, numpy's commented header, blank lines, and fuzzed ones."""
    rng = random.Random(2024)
    good = _full_precision_demo(rng)
    lines = good.split("\n")
    texts = [
        good,
        good.replace("\n", "\r\n"),
        "# " + good,
        "\n\n" + good + "\n\n  \n",
        good.replace("\n", "\n\n", 5),
        "\n".join(lines[:20] + [""] + lines[20:]),  # a blank line between samples
        *(good.replace(lines[9].split(",")[2], word) for word in ("nan", "inf", '"0.3"', "0.3_1")),
        good.replace(lines[9], "# " + lines[9]),
        *(good.replace(lines[9], lines[9].replace(",", mark + ",", 1)) for mark in WEIRD_MARKS),
        *(good.replace(lines[9], lines[9] + "\n" + mark) for mark in WEIRD_MARKS),
        good.replace("\n", "\r"),
        *mutations(good, rng, 200),
    ]
    path = tmp_path / "demo.csv"
    for text in texts:
        path.write_text(text, newline="")
        at_once = _outcome(path)
        with monkeypatch.context() as patched:
            patched.setattr(demos, "_rows_at_once", lambda *args: None)
            one_by_one = _outcome(path)
        if isinstance(one_by_one, str):
            assert at_once == one_by_one, text
        else:
            assert not isinstance(at_once, str), at_once
            for got, expected in zip(at_once, one_by_one):
                np.testing.assert_array_equal(got, expected)


def test_a_plain_file_is_read_in_one_pass(tmp_path, monkeypatch):
    """An hour at 1 kHz line by line took about 17 s and 2.4 GB here: a file with nothing
    unusual in it (CRLF line ends, numpy's commented header) never goes line by line."""

    def line_by_line(*args):
        raise AssertionError("read line by line")

    monkeypatch.setattr(demos, "_rows_one_by_one", line_by_line)
    path = tmp_path / "demo.csv"
    path.write_text("# " + _full_precision_demo(random.Random(7)).replace("\n", "\r\n"))
    t, positions, axes, lines = read_demonstration(path, with_lines=True)
    assert len(t) == 40 and axes == ("x", "y", "z") and lines == list(range(2, 42))
