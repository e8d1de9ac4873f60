"""Demonstration and trajectory CSV files: reading with validation, and writing.

Format: a header line `t,x,y,z` -- `t` in seconds first, then 1 to 3 position columns
named from x, y, z (metres, in that order) -- and one sample per line, time strictly
increasing over at most MAX_DURATION_S, at least MIN_SAMPLES samples, less than
MAX_SAMPLE_PERIOD_S apart (the median), never faster than MAX_SPEED_M_PER_S (see there). A
'#' before the header's first name is ignored (numpy's `savetxt` writes one); any other
line beginning with '#' (a comment) is refused, naming its line.
A pose adds the tool frame's orientation in the world frame after the positions,
`t,x,y,z,qw,qx,qy,qz`: a unit quaternion, scalar first (Drake's `Quaternion(w, x, y, z)`
order), either sign (see `read_orientation`). Trajectory files may add velocity columns
`vx,vy,vz` after these, and with an orientation the angular velocity `wx,wy,wz` [rad/s,
world frame] after those. Files are UTF-8; a byte-order mark at the start (as
spreadsheet programs write "CSV UTF-8") is accepted. Every problem is an InputError
naming file and line.

A demonstration may carry the force its wrist sensor read, `fx,fy,fz` [N], the last
columns (`t,x,y,z,fx,fy,fz`; after the orientation of a pose, and after the velocities of
a trajectory), one per position axis: the force the environment exerts on the tool during
kinesthetic teaching, in the world frame of the positions, the tool's own weight and
inertia removed -- the same quantity and sign as a run's logged `CTRL/f_ext`. A foam that
resists a tool pushed down into it reads +z.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from hlcmp_drake.core.dmp import Dmp
from hlcmp_drake.core.orientation_dmp import OrientationDmp
from hlcmp_drake.core.quaternion import geodesic_angle, hemisphere_continuous
from hlcmp_drake.io.errors import InputError, located
from hlcmp_drake.io.file_kinds import ZIP_MAGIC, what_it_is
from hlcmp_drake.io.paths import data_file

MIN_SAMPLES = 10
# The longest demonstration, and the longest run a scenario may ask for [s]: an hour. A
# run's DMP forcing is sampled every few ms over the run in memory (1.8 million samples an
# hour), and half an hour or more of wall time goes into an hour of an arm world.
MAX_DURATION_S = 3600.0
# The median time between samples [s] from which a demonstration is refused. Kinesthetic
# teaching is recorded at tens to a thousand samples per second (the iiwa's FRI at up to
# 1 kHz, motion capture at 100-250 Hz), and the DMP's fit differentiates it, smoothed over
# tens of ms. Samples this far apart are time in another unit: a recording at up to 2 kHz
# with its time in milliseconds steps by 0.5 or more, and a short one stays under
# MAX_DURATION_S, so that bound alone lets it through as a run of an hour.
MAX_SAMPLE_PERIOD_S = 0.5
AXES = ("x", "y", "z")

# The fastest a demonstration may move [m/s], measured from each sample to the first one
# SPEED_WINDOW_S or more later. Faster than a hand moves a tool in a demonstration (quick
# reaches peak near 2 m/s; the bundled demonstrations stay below 0.15 m/s) and than the
# iiwa's tool can follow (its seven joints at their speed limits add up to at most about
# 5 m/s at the tip, and only in no single direction): what is faster is a jump -- a dropped
# marker, a switch of units or frame, a pasted segment -- which the DMP fit's smoothing
# would otherwise turn into a fast sweep without a word. A 10 cm jump between two 10 ms
# samples is 10 m/s.
MAX_SPEED_M_PER_S = 3.0
# Over 10 ms a sensor's sample-to-sample noise averages out (1 mm of noise at 1 kHz reads as
# 1 m/s from one sample to the next, 0.1 m/s over 10 ms); a jump does not.
SPEED_WINDOW_S = 0.01

# The farthest a demonstrated position may be from the world origin [m]: an arm's tool (the
# iiwa14 reaches 0.82 m from its base) is never near; a larger number is another unit (mm)
# or no position at all, and its speed would overflow.
MAX_ABS_POSITION_M = 100.0
# The largest force a demonstration's force column may hold [N]: far beyond what a wrist
# force sensor on an arm reads; a larger number is another unit (mN) or no force at all.
MAX_ABS_FORCE_N = 1e4

QUATERNION_COLUMNS = ("qw", "qx", "qy", "qz")
ANGULAR_VELOCITY_COLUMNS = ("wx", "wy", "wz")
# The force on the tool, by position axis (x, y, z).
FORCE_COLUMNS = ("fx", "fy", "fz")
# A column's largest magnitude and what a value beyond it says, for the columns that have one.
_COLUMN_BOUNDS = {
    **{
        axis: (
            MAX_ABS_POSITION_M,
            f"positions are in metres, within {MAX_ABS_POSITION_M:g} m of the world origin",
        )
        for axis in AXES
    },
    **{
        force: (MAX_ABS_FORCE_N, f"forces are in newtons, within {MAX_ABS_FORCE_N:g} N")
        for force in FORCE_COLUMNS
    },
}
# The fastest a demonstration may turn [rad/s], measured as MAX_SPEED_M_PER_S is. The
# iiwa's seven joints at their speed limits (models/iiwa14.sdf) add up to 13 rad/s at the
# tool, a bound no direction reaches; a hand turning a tool in a demonstration stays far
# below. Faster is a jump: a marker's frame flipping, swapped columns, a pasted segment.
# Sign changes (q to -q) are no turn. 1 deg of noise per sample reads as 3 rad/s over 10 ms.
MAX_TURN_RATE_RAD_PER_S = 15.0
# How far from 1 a quaternion's norm may be; it is normalised. Values rounded to 3 decimals
# stay within 0.2 % of a unit norm; 1 % off is no rounding but another convention (angles,
# a scaled or partly overwritten row), which normalising would silently turn into some
# other rotation.
MAX_QUATERNION_NORM_ERROR = 0.01


def bound_problem(column: str, value: float) -> str | None:
    """What is wrong with `value` in a demonstration's `column` (x, y, z: a position beyond
    MAX_ABS_POSITION_M; fx, fy, fz: a force beyond MAX_ABS_FORCE_N), or None.

    Parameters
    ----------
    column : str
        The column's name; one without a bound (t, a quaternion's) has no problem.
    value : float

    Returns
    -------
    str or None
        e.g. "positions are in metres, within 100 m of the world origin".
    """
    bound, unit = _COLUMN_BOUNDS.get(column, (math.inf, ""))
    return unit if abs(value) > bound else None


def read_demonstration(
    path: str | Path,
    with_lines: bool = False,
    with_orientation: bool = False,
    with_force: bool = False,
) -> tuple:
    """Returns (t (T,), positions (T, M), axis names), with `with_orientation` also the
    orientations, with `with_force` also the force columns, and with `with_lines` also each
    sample's line number in the file. Raises InputError on bad input.

    Parameters
    ----------
    path : str or Path
        The CSV file (format in the module docstring); a bundled one may be named
        package://hlcmp_drake/diagrams/demos/NAME.csv.
    with_lines : bool
        Also return the line number of each sample.
    with_orientation : bool
        Accept a pose (qw,qx,qy,qz columns) and return its orientations; without it a pose
        file is refused, naming the columns (the caller would ignore them).
    with_force : bool
        Also return the demonstrated force (a file's force columns are read either way).

    Returns
    -------
    t : (T,) array
        Sample times [s], strictly increasing, T >= MIN_SAMPLES.
    positions : (T, M) array
        Positions [m], one column per axis; velocity columns are not returned.
    axes : tuple of M str
        The position columns' names, from ("x", "y", "z").
    quaternions : (T, 4) array or None
        Only with `with_orientation`: unit, hemisphere-continuous (`read_orientation`);
        None for a file of positions only.
    force : (T, M) array or None
        Only with `with_force`: the columns `fx,fy,fz` [N] (module docstring), one per
        position axis; None when the file has none.
    lines : list of T int
        Only with `with_lines`: each sample's 1-based line number in the file.
    """
    path = data_file(str(path), Path())  # package://hlcmp_drake/... names a bundled one
    if not path.exists():
        raise InputError(f"{path}: no such file")
    if path.is_dir():
        raise InputError(f"{path}: is a directory, not a CSV file")
    try:
        text = path.read_text(encoding="utf-8-sig")  # a BOM, invisible to the user, is dropped
    except OSError as error:
        raise InputError(f"{path}: cannot be read as text ({error.__class__.__name__})") from None
    except UnicodeDecodeError as error:
        with open(path, "rb") as stream:
            head = stream.read(4)
        if head in ZIP_MAGIC:
            raise InputError(f"{path}: {what_it_is(head)}, not a demonstration CSV") from None
        raise InputError(
            f"{path}: not UTF-8 text ({error.reason} at byte {error.start}); save the CSV as UTF-8"
        ) from None
    kind = what_it_is(text[:4096].encode())
    if kind is not None and not kind.startswith("a demonstration"):
        raise InputError(f"{path}: {kind}, not a demonstration CSV 't,x,y,z'")
    header_line, header_text, body = _header_and_body(text)
    if header_text is None:
        raise InputError(f"{path}: the file is empty (expected a header line 't,x,y,z')")
    header = [name.strip() for name in next(csv.reader([header_text.lstrip().removeprefix("#")]))]
    if header_text.lstrip().startswith("#") and header[:1] != ["t"]:
        raise _comment_refused(path, header_line, header_text)
    if "" in header:
        column = header.index("") + 1
        hint = (
            " (a comma at the end of the line?)"
            if column == len(header)
            else " (a row index? write the file without it, e.g. pandas' index=False)"
            if column == 1
            else ""
        )
        raise located(path, header_line, f"column {column} has no name{hint}")
    kinematics, force_columns = _without_force(path, header_line, header)
    axes = _check_header(path, header_line, _without_orientation(path, header_line, kinematics))
    has_orientation = QUATERNION_COLUMNS[0] in header
    if has_orientation and not with_orientation:
        raise located(
            path,
            header_line,
            f"columns {','.join(QUATERNION_COLUMNS)}: an orientation is not used here; "
            "give positions only (t,x,y,z)",
        )
    data = _rows_at_once(path, body, header_line, header)
    if data is not None:
        numbers: Sequence[int] = range(header_line + 1, header_line + 1 + len(data))
    else:
        numbered = _numbered_lines(body, header_line + 1)
        data, numbers = _rows_one_by_one(path, numbered, header)
    problem = sampling_problem(data[:, 0])  # its duration is held to the bound line by line
    if problem:
        sparse = len(data) >= MIN_SAMPLES  # sampled too seldom: t in another unit
        raise InputError(
            f"{path}: {problem}" + ("; t is in seconds (a time in milliseconds?)" if sparse else "")
        )
    check_speed(path, data[:, 0], data[:, 1 : 1 + len(axes)], numbers)
    result: tuple = (data[:, 0], data[:, 1 : 1 + len(axes)], axes)
    if with_orientation:
        first = 1 + len(axes)
        result += (
            read_orientation(path, data[:, 0], data[:, first : first + 4], numbers)
            if has_orientation
            else None,
        )
    if with_force:
        force = data[:, [header.index(name) for name in force_columns]]
        result += (force if force_columns else None,)
    return result + (list(numbers),) if with_lines else result


def sampling_problem(t: np.ndarray) -> str | None:
    """What keeps samples at times `t` from being a demonstration's, or None: fewer than
    MIN_SAMPLES, a median period of MAX_SAMPLE_PERIOD_S or more, or longer than
    MAX_DURATION_S. `read_demonstration` refuses such a file; `hlcmp rollout` refuses to
    write one.

    Parameters
    ----------
    t : (T,) array
        Sample times [s], strictly increasing.

    Returns
    -------
    str or None
    """
    if len(t) < MIN_SAMPLES:
        return f"{len(t)} samples; a demonstration needs at least {MIN_SAMPLES}"
    period = float(np.median(np.diff(t)))
    if period >= MAX_SAMPLE_PERIOD_S:
        return (
            f"its samples are {period:g} s apart (the median; t from {t[0]:g} to {t[-1]:g} s): "
            f"a demonstration is sampled more often than every {MAX_SAMPLE_PERIOD_S:g} s"
        )
    if t[-1] - t[0] > MAX_DURATION_S:
        return f"it lasts {t[-1] - t[0]:g} s; a demonstration lasts at most {MAX_DURATION_S:g} s"
    return None


# What str.splitlines ends a line at, besides "\n" (and "\r\n").
_OTHER_LINE_BREAKS = ("\r", "\x0b", "\x0c", "\x1c", "\x1d", "\x1e", "\x85", "\u2028", "\u2029")


def _header_and_body(text: str) -> tuple[int, str | None, str]:
    """(the first non-blank line's number, that line, the text after it with its lines
    ended by "\n" alone), the lines as `str.splitlines` finds them; (_, None, "") for a
    file without one."""
    if "\r\n" in text:
        text = text.replace("\r\n", "\n")
    if any(mark in text for mark in _OTHER_LINE_BREAKS):
        text = "\n".join(text.splitlines())
    number, start = 1, 0
    while start < len(text):
        end = text.find("\n", start)
        end = len(text) if end < 0 else end
        if text[start:end].strip():
            return number, text[start:end], text[end + 1 :]
        number, start = number + 1, end + 1
    return number, None, ""


def _numbered_lines(body: str, first: int) -> list[tuple[int, str]]:
    """(number, text) of each non-blank line of `body`, its first line numbered `first`."""
    return [(n, line) for n, line in enumerate(body.split("\n"), start=first) if line.strip()]


def _rows_at_once(path: Path, body: str, header_line: int, header: list[str]) -> np.ndarray | None:
    """The samples after the header (`body`, from `_header_and_body`) read from the file in
    one pass of numpy's, where that reads what `_rows_one_by_one` would and every sample
    passes its checks; None otherwise (then `_rows_one_by_one` reads them, and names the
    line of a problem). An hour at 1 kHz reads in about a second, where line by line took
    tens of seconds and gigabytes of Python rows.

    Left to the line-by-line reading: what numpy does not read as a number (a quoted field,
    a comment, 0.5_5, which float reads as 0.55, an Arabic-Indic digit, which float reads
    too), a line str.splitlines splits where numpy does not, and blank lines before or
    between samples (numpy skips them, so the line numbers would shift); all of which
    tests/test_io_demos.py checks against the line-by-line reading."""
    last = len(body.rstrip())
    if not last:
        return None
    try:
        data = np.loadtxt(
            path,
            delimiter=",",
            comments=None,
            skiprows=header_line,
            ndmin=2,
            encoding="utf-8-sig",
        )
    except ValueError:
        return None
    t = data[:, 0]
    if (
        data.shape[1] != len(header)
        or len(data) != body.count("\n", 0, last) + 1
        or not np.isfinite(data).all()
        or np.any(np.diff(t) <= 0)
        or t[-1] - t[0] > MAX_DURATION_S
    ):
        return None
    for column, name in enumerate(header):
        bound, _ = _COLUMN_BOUNDS.get(name, (math.inf, ""))
        if np.any(np.abs(data[:, column]) > bound):
            return None
    return data


def _rows_one_by_one(path, lines, header) -> tuple[np.ndarray, list[int]]:
    """The samples of `lines` ((number, text) of the non-blank lines after the header),
    each field checked and any problem raised naming its line: (the (T, columns) array,
    each sample's line number)."""
    rows: list[tuple[int, list[float]]] = []
    for number, line in lines:
        if line.lstrip().startswith("#"):
            raise _comment_refused(path, number, line)
        fields = [f.strip() for f in next(csv.reader([line]))]
        if len(fields) != len(header):
            raise located(
                path,
                number,
                f"expected {len(header)} values ({','.join(header)}), found {len(fields)}",
            )
        values = []
        for name, field in zip(header, fields):
            try:
                if "_" in field or not field.isascii():  # float() reads 0.5_5 as 0.55, and ٣ as 3
                    raise ValueError(field)
                value = float(field)
            except ValueError:
                raise located(path, number, f"column '{name}' is not a number: '{field}'") from None
            if not math.isfinite(value):
                raise located(path, number, f"column '{name}' is not finite: '{field}'")
            problem = bound_problem(name, value)
            if problem:
                raise located(path, number, f"column '{name}' is {field}: {problem}")
            values.append(value)
        if rows and values[0] <= rows[-1][1][0]:
            raise located(
                path,
                number,
                f"time must increase strictly: t = {values[0]} after "
                f"t = {rows[-1][1][0]} (line {rows[-1][0]})",
            )
        if rows and values[0] - rows[0][1][0] > MAX_DURATION_S:
            raise located(
                path,
                number,
                f"t = {values[0]:g} s is more than {MAX_DURATION_S:g} s after the first sample: "
                "t is in seconds (a time in milliseconds?), and a run lasts at most that long",
            )
        rows.append((number, values))
    return np.array([values for _, values in rows]).reshape(-1, len(header)), [
        number for number, _ in rows
    ]


def read_orientation(
    path: str | Path, t: np.ndarray, quaternions: np.ndarray, lines: Sequence[int]
) -> np.ndarray:
    """Check, normalise and make hemisphere-continuous a demonstration's quaternions.

    Parameters
    ----------
    path : str or Path
        The file, for the message.
    t : (T,) array
        Sample times [s], strictly increasing.
    quaternions : (T, 4) array
        The qw, qx, qy, qz columns (finite: the reader has checked).
    lines : sequence of T int
        Each sample's line in the file.

    Returns
    -------
    (T, 4) array
        Unit quaternions, each sign chosen so that neighbours lie in one hemisphere
        (q and -q are one rotation; the first sample keeps its sign).

    Raises
    ------
    InputError
        ``FILE:LINE: ...`` at the first quaternion that is zero or whose norm is off 1 by
        more than MAX_QUATERNION_NORM_ERROR, or where it turns too fast (`check_turn_rate`).
    """
    with np.errstate(over="ignore"):  # a component like 1e200: its norm is inf, refused below
        norms = np.linalg.norm(quaternions, axis=1)
    bad = np.flatnonzero(np.abs(norms - 1.0) > MAX_QUATERNION_NORM_ERROR)
    if len(bad):
        k = int(bad[0])
        values = ",".join(f"{v:g}" for v in quaternions[k])
        problem = (
            "is zero, which is no rotation"
            if norms[k] == 0
            else f"has norm {norms[k]:.4g}; a unit quaternion is expected (norm within "
            f"1 ± {MAX_QUATERNION_NORM_ERROR:g}, scalar first: qw,qx,qy,qz)"
        )
        raise located(path, lines[k], f"the orientation ({values}) {problem}")
    unit = quaternions / norms[:, None]
    check_turn_rate(path, t, unit, lines)
    return hemisphere_continuous(unit)


def check_speed(
    path: str | Path, t: np.ndarray, positions: np.ndarray, lines: Sequence[int]
) -> None:
    """Refuse a demonstration that moves faster than MAX_SPEED_M_PER_S anywhere: the
    distance from each sample to the first one at least SPEED_WINDOW_S later, over that
    time (over SPEED_WINDOW_S at the very end, where no sample is that much later).

    Parameters
    ----------
    path : str or Path
        The file, for the message.
    t : (T,) array
        Sample times [s], strictly increasing.
    positions : (T, M) array
        Positions [m].
    lines : sequence of T int
        Each sample's line in the file.

    Raises
    ------
    InputError
        ``FILE:LINE: ...`` naming the sample that jumps (the one after the largest step
        inside the fastest window) and the line before it.
    """
    _refuse_jumps(
        path,
        t,
        lines,
        lambda a, b: np.linalg.norm(positions[b] - positions[a], axis=-1),
        (MAX_SPEED_M_PER_S, "m/s", "move"),
        lambda step: f"moves {100 * step:.1f} cm",
    )


def check_turn_rate(
    path: str | Path, t: np.ndarray, quaternions: np.ndarray, lines: Sequence[int]
) -> None:
    """Refuse a demonstration that turns faster than MAX_TURN_RATE_RAD_PER_S anywhere,
    measured as `check_speed` measures speed, with the geodesic angle between orientations
    (q and -q are no turn).

    Parameters
    ----------
    path : str or Path
        The file, for the message.
    t : (T,) array
        Sample times [s], strictly increasing.
    quaternions : (T, 4) array
        Unit quaternions.
    lines : sequence of T int
        Each sample's line in the file.

    Raises
    ------
    InputError
        ``FILE:LINE: ...`` naming the sample that jumps and the line before it.
    """
    _refuse_jumps(
        path,
        t,
        lines,
        lambda a, b: geodesic_angle(quaternions[b], quaternions[a]),
        (MAX_TURN_RATE_RAD_PER_S, "rad/s", "turn"),
        lambda step: f"turns {np.degrees(step):.1f} deg",
    )


def _refuse_jumps(path, t, lines, distance, limit, describe_step):
    """The fastest motion over windows of at least SPEED_WINDOW_S (from each sample to the
    first one that much later), refused at the largest step inside it when it exceeds the
    bound. `distance(a, b)`: the distances between the samples of index arrays a and b;
    `limit`: (bound, its unit, the verb); `describe_step(step)`: the step in words."""
    bound, unit, verb = limit
    rate, i, j = _fastest_window(t, distance)
    if rate <= bound:
        return
    steps = distance(np.arange(i, j), np.arange(i + 1, j + 1))
    k = i + int(np.argmax(steps))  # the largest step inside that window: k -> k + 1
    raise located(
        path,
        lines[k + 1],
        f"the demonstration {describe_step(float(steps[k - i]))} in "
        f"{1000 * (t[k + 1] - t[k]):.0f} ms from line {lines[k]} (t = {t[k]:g} s to "
        f"{t[k + 1]:g} s): {rate:.1f} {unit} over "
        f"{1000 * max(t[j] - t[i], SPEED_WINDOW_S):.0f} ms, faster than the {bound:g} {unit} "
        f"a demonstration may {verb} (a jump in the recording?); remove or fix those samples",
    )


def _fastest_window(t, distance) -> tuple[float, int, int]:
    """(the fastest rate, its window's first and last sample) over the windows from each
    sample to the first one SPEED_WINDOW_S or more later (the distance over at least
    SPEED_WINDOW_S); (0, 0, 0) for a single sample. `distance(a, b)` as for
    `_refuse_jumps`."""
    count = len(t)
    start = np.arange(count)
    end = np.minimum(np.searchsorted(t, t + SPEED_WINDOW_S - 1e-12), count - 1)
    start, end = start[end > start], end[end > start]
    if not len(start):
        return 0.0, 0, 0
    rate = distance(start, end) / np.maximum(t[end] - t[start], SPEED_WINDOW_S)
    fastest = int(np.argmax(rate))
    return float(rate[fastest]), int(start[fastest]), int(end[fastest])


def fastest_speed(t: np.ndarray, positions: np.ndarray) -> float:
    """The fastest a trajectory moves [m/s], measured as `check_speed` measures a
    demonstration's (to be held to MAX_SPEED_M_PER_S).

    Parameters
    ----------
    t : (T,) array
        Sample times [s], strictly increasing.
    positions : (T, M) array
        Positions [m].

    Returns
    -------
    float
    """
    return _fastest_window(t, lambda a, b: np.linalg.norm(positions[b] - positions[a], axis=-1))[0]


def fastest_turn_rate(t: np.ndarray, quaternions: np.ndarray) -> float:
    """The fastest a trajectory turns [rad/s], measured as `check_turn_rate` measures a
    demonstration's (to be held to MAX_TURN_RATE_RAD_PER_S).

    Parameters
    ----------
    t : (T,) array
        Sample times [s], strictly increasing.
    quaternions : (T, 4) array
        Unit quaternions.

    Returns
    -------
    float
    """
    return _fastest_window(t, lambda a, b: geodesic_angle(quaternions[b], quaternions[a]))[0]


def replay_speed_problem(path: str | Path, duration_s: float) -> str | None:
    """What is wrong with replaying a demonstration in `duration_s` instead of its own
    duration (a scenario's `reference.duration_s`), or None (`path_replay_problem`).

    Parameters
    ----------
    path : str or Path
        The demonstration CSV.
    duration_s : float
        The replay's duration [s], > 0.

    Returns
    -------
    str or None

    Raises
    ------
    InputError
        From `read_demonstration`, for a file it refuses.
    """
    t, positions, _, quaternions = read_demonstration(path, with_orientation=True)
    return path_replay_problem(
        f"demonstration {Path(path).name}", t, positions, quaternions, duration_s
    )


# The sample period of a DMP's path when its replay is checked [s]: at the plant's 1 ms
# step, ten samples to SPEED_WINDOW_S.
ROLLOUT_STEP_S = 0.001


def rollout_replay_problem(
    what: str, dmp: Dmp, orientation_dmp: OrientationDmp | None, duration_s: float
) -> str | None:
    """What is wrong with replaying a DMP (a skill's) in `duration_s` instead of its own
    tau, or None: `path_replay_problem` on the path it rolls out at its tau (and the
    orientation its orientation DMP rolls out).

    Parameters
    ----------
    what : str
        What the DMP is, for the message (e.g. "skill skill.npz").
    dmp : Dmp
    orientation_dmp : OrientationDmp or None
        A pose skill's.
    duration_s : float
        The replay's duration [s], > 0.

    Returns
    -------
    str or None
    """
    t, positions, *_ = dmp.rollout(dt=ROLLOUT_STEP_S)
    quaternions = (
        None
        if orientation_dmp is None
        else orientation_dmp.rollout(duration=dmp.tau, dt=ROLLOUT_STEP_S)[1]
    )
    return path_replay_problem(what, t, positions, quaternions, duration_s)


def path_replay_problem(
    what: str,
    t: np.ndarray,
    positions: np.ndarray,
    quaternions: np.ndarray | None,
    duration_s: float,
) -> str | None:
    """What is wrong with replaying a path in `duration_s` instead of its own duration, or
    None: every speed and turn rate scales by its duration over `duration_s`, and the
    fastest must stay within what a demonstration may move and turn (MAX_SPEED_M_PER_S,
    MAX_TURN_RATE_RAD_PER_S; the bounds `check_speed` and `check_turn_rate` apply to a
    demonstration file itself).

    Parameters
    ----------
    what : str
        What the path is, for the message (e.g. "demonstration demo.csv").
    t : (T,) array
        Sample times [s], increasing.
    positions : (T, M) array
        Positions [m].
    quaternions : (T, 4) array or None
        Orientations (w, x, y, z), for a pose.
    duration_s : float
        The replay's duration [s], > 0.

    Returns
    -------
    str or None
    """
    demonstrated = float(t[-1] - t[0])
    scale = demonstrated / duration_s
    moves = [(fastest_speed(t, positions), MAX_SPEED_M_PER_S, "m/s", "move")]
    if quaternions is not None:
        moves.append((fastest_turn_rate(t, quaternions), MAX_TURN_RATE_RAD_PER_S, "rad/s", "turn"))
    for rate, bound, unit, verb in moves:
        if rate * scale > bound:
            return (
                f"replays the {demonstrated:g} s {what} in {duration_s:g} s, "
                f"{scale:.3g} times as fast: it would {verb} at {rate * scale:.3g} {unit} at its "
                f"fastest, more than the {bound:g} {unit} a demonstration may {verb}; give at "
                f"least {demonstrated * rate / bound:.3g} s (0: as demonstrated)"
            )
    return None


def _without_force(path, line, header):
    """(the header without its force columns, those columns): `fx,fy,fz` last, one per
    position axis, or none at all; anything else is refused naming the header line."""
    names = [name for name in header if name in FORCE_COLUMNS]
    if not names:
        return header, []
    expected = [FORCE_COLUMNS[AXES.index(axis)] for axis in header if axis in AXES]
    if not expected:  # no position column, which _check_header names
        return [name for name in header if name not in FORCE_COLUMNS], []
    if names != expected:
        raise located(
            path,
            line,
            f"force columns must be {','.join(expected)}, one per position axis; "
            f"found {','.join(names)}",
        )
    if header[-len(names) :] != names:
        raise located(path, line, f"force columns {','.join(names)} must be the last columns")
    return header[: -len(names)], names


def _without_orientation(path, line, header):
    """The header without its orientation columns, after checking where they are:
    qw,qx,qy,qz together right after the positions, wx,wy,wz (only with them) last."""
    names = [name for name in header if name in QUATERNION_COLUMNS]
    if not names:
        if any(name in ANGULAR_VELOCITY_COLUMNS for name in header):
            raise located(path, line, "angular velocity columns wx,wy,wz need qw,qx,qy,qz")
        return header
    first = header.index(names[0])
    if (
        len(names) != len(QUATERNION_COLUMNS)
        or header[first : first + 4] != list(QUATERNION_COLUMNS)
        or header[1:first] != [name for name in header if name in AXES]
    ):
        raise located(
            path,
            line,
            "the orientation columns must be qw,qx,qy,qz, in that order, right after the "
            "positions (e.g. t,x,y,z,qw,qx,qy,qz)",
        )
    rest = header[:first] + header[first + 4 :]
    angular = [name for name in rest if name in ANGULAR_VELOCITY_COLUMNS]
    if angular and rest[-3:] != list(ANGULAR_VELOCITY_COLUMNS):
        raise located(path, line, "angular velocity columns must be wx,wy,wz, last")
    return rest[:-3] if angular else rest


def _comment_refused(path, line, text):
    """The error for a comment line: a demonstration CSV has none (numpy's commented header
    aside, which is no comment)."""
    shown = text.strip() if len(text.strip()) <= 40 else text.strip()[:37] + "..."
    return located(
        path,
        line,
        f"'{shown}': comment lines are not allowed (a '#' is read only before the header's "
        "names, as numpy's savetxt writes '# t,x,y,z')",
    )


def _check_header(path, line, header):
    if not header or header[0] != "t":
        raise located(
            path,
            line,
            f"the first column must be 't' (time in seconds), found "
            f"'{header[0] if header else ''}'; expected a header like 't,x,y,z'",
        )
    positions = [name for name in header[1:] if not name.startswith("v")]
    velocities = header[1 + len(positions) :]
    for name in header[1:]:
        if name not in AXES and name not in tuple("v" + a for a in AXES):
            raise located(
                path,
                line,
                f"unknown column '{name}' "
                "(allowed: t, x, y, z, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz, fx, fy, fz)",
            )
    if not positions:
        raise located(path, line, "no position column: expected one or more of x, y, z after t")
    if len(set(header)) != len(header):
        raise located(path, line, "a column name appears twice")
    if positions != [a for a in AXES if a in positions]:
        raise located(path, line, "position columns must be in the order x, y, z")
    if velocities and velocities != ["v" + a for a in positions]:
        raise located(
            path,
            line,
            f"velocity columns must be {','.join('v' + a for a in positions)} after the positions",
        )
    return tuple(positions)


# How `write_trajectory` writes each number: nine significant digits.
WRITTEN = ".9g"


def as_written(values: np.ndarray) -> np.ndarray:
    """`values` as a file `write_trajectory` wrote reads them back (nine significant digits).

    Parameters
    ----------
    values : array

    Returns
    -------
    array
        Of the same shape, float.
    """
    values = np.asarray(values, dtype=float)
    return np.array([float(f"{v:{WRITTEN}}") for v in values.ravel()]).reshape(values.shape)


def write_trajectory(
    path: str | Path,
    t: np.ndarray,
    positions: np.ndarray,
    axes: Sequence[str],
    velocities: np.ndarray | None = None,
    quaternions: np.ndarray | None = None,
    angular_velocities: np.ndarray | None = None,
    force: np.ndarray | None = None,
) -> Path:
    """Write a trajectory CSV (same format; velocity columns, an orientation and a force
    when given), atomically.

    Parameters
    ----------
    path : str or Path
        The file to write; its folder is created when missing.
    t : (T,) array
        Sample times [s].
    positions : (T, M) array
        Positions [m].
    axes : sequence of M str
        Column names of the positions, e.g. ("x", "y", "z").
    velocities : (T, M) array, optional
        Velocities [m/s], written as columns `v` + axis name.
    quaternions : (T, 4) array, optional
        Orientations (w, x, y, z), written as qw,qx,qy,qz after the positions.
    angular_velocities : (T, 3) array, optional
        Angular velocities [rad/s, world frame], written as wx,wy,wz.
    force : (T, M) array, optional
        The force on the tool [N] (module docstring), written as `f` + axis name, last.

    Returns
    -------
    Path
        The path written.
    """
    from hlcmp_drake.io.outputs import write_text

    groups = [
        (list(axes), positions),
        (list(QUATERNION_COLUMNS), quaternions),
        ([f"v{a}" for a in axes], velocities),
        (list(ANGULAR_VELOCITY_COLUMNS), angular_velocities),
        ([f"f{a}" for a in axes], force),
    ]
    header = ["t"] + [name for names, values in groups if values is not None for name in names]
    columns = [np.asarray(t)[:, None]]
    columns += [np.asarray(values) for _, values in groups if values is not None]
    data = np.hstack(columns)
    body = "\n".join(",".join(f"{v:{WRITTEN}}" for v in row) for row in data)
    return write_text(path, ",".join(header) + "\n" + body + "\n")
