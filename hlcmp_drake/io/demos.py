"""Demonstration and trajectory CSV files: reading with validation, and writing.

Format: a header line `t,x,y,z` -- `t` in seconds first, then 1 to 3 position columns
named from x, y, z (metres, in that order) -- and one sample per line, time strictly
increasing, at least MIN_SAMPLES samples, never faster than MAX_SPEED_M_PER_S (see there).
Trajectory files may add velocity columns
`vx,vy,vz` after the positions. Files are UTF-8; a byte-order mark at the start (as
spreadsheet programs write "CSV UTF-8") is accepted. Every problem is an InputError
naming file and line.

Columns are recognised by name, in groups (COLUMN_GROUPS): the positions, then optional
groups of one column per position axis. A demonstration may carry the force its wrist
sensor read, `fx,fy,fz` [N] after the positions (and after the velocities of a
trajectory): the force the environment exerts on the tool during kinesthetic teaching, in
the world frame of the positions, the tool's own weight and inertia removed -- the same
quantity and sign as a run's logged `CTRL/f_ext`. A foam that resists a tool pushed down
into it reads +z. The force columns come all together, one per position axis.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from hlcmp_drake.io.errors import InputError, located

MIN_SAMPLES = 10
AXES = ("x", "y", "z")
# The column groups after `t`, in the order a file gives them, each recognised by its
# columns' names (one per axis x, y, z). The positions name one to three axes; every other
# group present has the columns of exactly those axes.
COLUMN_GROUPS = {
    "position": AXES,
    "velocity": ("vx", "vy", "vz"),
    "force": ("fx", "fy", "fz"),
}

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


def read_demonstration(
    path: str | Path, with_lines: bool = False, with_force: bool = False
) -> tuple:
    """Returns (t (T,), positions (T, M), axis names), with `with_force` also the force
    columns, and with `with_lines` also each sample's line number in the file.
    Raises InputError on bad input.

    Parameters
    ----------
    path : str or Path
        The CSV file (format in the module docstring).
    with_lines : bool
        Also return the line number of each sample.
    with_force : bool
        Also return the demonstrated force.

    Returns
    -------
    t : (T,) array
        Sample times [s], strictly increasing, T >= MIN_SAMPLES.
    positions : (T, M) array
        Positions [m], one column per axis; velocity columns are not returned.
    axes : tuple of M str
        The position columns' names, from ("x", "y", "z").
    force : (T, M) array or None
        Only with `with_force`: the force columns `fx,fy,fz` [N] (module docstring), one
        per position axis; None when the file has none.
    lines : list of T int
        Only with `with_lines`: each sample's 1-based line number in the file.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file")
    if path.is_dir():
        raise InputError(f"{path}: is a directory, not a CSV file")
    try:
        text = path.read_text(encoding="utf-8-sig")  # a BOM, invisible to the user, is dropped
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"{path}: cannot be read as text ({error.__class__.__name__})") from None
    lines = [(n, line) for n, line in enumerate(text.splitlines(), start=1) if line.strip()]
    if not lines:
        raise InputError(f"{path}: the file is empty (expected a header line 't,x,y,z')")
    header_line, header_text = lines[0]
    header = [name.strip() for name in next(csv.reader([header_text]))]
    groups = _column_groups(path, header_line, header)
    axes = tuple(groups["position"])
    rows: list[tuple[int, list[float]]] = []
    for number, line in lines[1:]:
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
                value = float(field)
            except ValueError:
                raise located(path, number, f"column '{name}' is not a number: '{field}'") from None
            if not math.isfinite(value):
                raise located(path, number, f"column '{name}' is not finite: '{field}'")
            values.append(value)
        if rows and values[0] <= rows[-1][1][0]:
            raise located(
                path,
                number,
                f"time must increase strictly: t = {values[0]} after "
                f"t = {rows[-1][1][0]} (line {rows[-1][0]})",
            )
        rows.append((number, values))
    if len(rows) < MIN_SAMPLES:
        raise InputError(
            f"{path}: {len(rows)} samples; a demonstration needs at least {MIN_SAMPLES}"
        )
    data = np.array([values for _, values in rows])
    numbers = [number for number, _ in rows]
    check_speed(path, data[:, 0], data[:, 1 : 1 + len(axes)], numbers)
    result: tuple = (data[:, 0], data[:, 1 : 1 + len(axes)], axes)
    if with_force:
        result += (_group_values(data, header, groups["force"]),)
    return result + (numbers,) if with_lines else result


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
    count = len(t)
    start = np.arange(count)
    end = np.minimum(np.searchsorted(t, t + SPEED_WINDOW_S - 1e-12), count - 1)
    start, end = start[end > start], end[end > start]
    if not len(start):
        return
    distance = np.linalg.norm(positions[end] - positions[start], axis=1)
    speed = distance / np.maximum(t[end] - t[start], SPEED_WINDOW_S)
    fastest = int(np.argmax(speed))
    if speed[fastest] <= MAX_SPEED_M_PER_S:
        return
    i, j = start[fastest], end[fastest]
    steps = np.linalg.norm(np.diff(positions[i : j + 1], axis=0), axis=1)
    k = i + int(np.argmax(steps))  # the largest step inside that window: k -> k + 1
    step = float(np.linalg.norm(positions[k + 1] - positions[k]))
    raise located(
        path,
        lines[k + 1],
        f"the demonstration moves {100 * step:.1f} cm in {1000 * (t[k + 1] - t[k]):.0f} ms "
        f"from line {lines[k]} (t = {t[k]:g} s to {t[k + 1]:g} s): "
        f"{speed[fastest]:.1f} m/s over {1000 * max(t[j] - t[i], SPEED_WINDOW_S):.0f} ms, "
        f"faster than the {MAX_SPEED_M_PER_S:g} m/s a demonstration may move "
        "(a jump in the recording?); remove or fix those samples",
    )


def _column_groups(path, line, header):
    """Each column after `t` by its group (COLUMN_GROUPS), recognised by name: {group: [column
    names]}, every group present; InputError naming the header line on anything else."""
    if not header or header[0] != "t":
        raise located(
            path,
            line,
            f"the first column must be 't' (time in seconds), found "
            f"'{header[0] if header else ''}'; expected a header like 't,x,y,z'",
        )
    groups: dict[str, list[str]] = {group: [] for group in COLUMN_GROUPS}
    order = []
    for name in header[1:]:
        group = next((g for g, names in COLUMN_GROUPS.items() if name in names), None)
        if group is None:
            allowed = ", ".join(["t", *(n for names in COLUMN_GROUPS.values() for n in names)])
            raise located(path, line, f"unknown column '{name}' (allowed: {allowed})")
        groups[group].append(name)
        order.append(list(COLUMN_GROUPS).index(group))
    positions = groups["position"]
    if not positions:
        raise located(path, line, "no position column: expected one or more of x, y, z after t")
    if len(set(header)) != len(header):
        raise located(path, line, "a column name appears twice")
    if positions != [a for a in AXES if a in positions]:
        raise located(path, line, "position columns must be in the order x, y, z")
    for group, names in COLUMN_GROUPS.items():
        expected = [names[AXES.index(axis)] for axis in positions]
        if groups[group] and groups[group] != expected:
            raise located(
                path,
                line,
                f"{group} columns must be {','.join(expected)}, one per position axis; "
                f"found {','.join(groups[group])}",
            )
    if order != sorted(order):
        raise located(path, line, f"columns must come in the order t, {', '.join(COLUMN_GROUPS)}")
    return groups


def _group_values(data, header, names):
    """The (T, len(names)) columns `names` of `data` (columns as in `header`), or None
    when `names` is empty."""
    if not names:
        return None
    return data[:, [header.index(name) for name in names]]


def write_trajectory(
    path: str | Path,
    t: np.ndarray,
    positions: np.ndarray,
    axes: Sequence[str],
    velocities: np.ndarray | None = None,
    force: np.ndarray | None = None,
) -> Path:
    """Write a trajectory CSV (same format; velocity and force columns when given),
    atomically.

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
    force : (T, M) array, optional
        The force on the tool [N] (module docstring), written as columns `f` + axis name.

    Returns
    -------
    Path
        The path written.
    """
    from hlcmp_drake.io.outputs import write_text

    header, columns = ["t", *axes], [np.asarray(t)[:, None], np.asarray(positions)]
    for group, values in (("velocity", velocities), ("force", force)):
        if values is not None:
            header += [COLUMN_GROUPS[group][AXES.index(axis)] for axis in axes]
            columns.append(np.asarray(values))
    data = np.hstack(columns)
    body = "\n".join(",".join(f"{v:.9g}" for v in row) for row in data)
    return write_text(path, ",".join(header) + "\n" + body + "\n")
