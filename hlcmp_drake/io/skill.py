"""A compliant skill theta = {theta_p, theta_k, theta_d, theta_v} (paper Eq. 17) as one file.

The file is a NumPy .npz with a `format_version`; it holds the DMP (theta_p and its
settings, tau, start, goal, Eq. 13 amplitudes, axis names) and the learned compliant
profiles' weights (M x N each). Loading checks the version, the keys and every shape.
"""

from __future__ import annotations

import codecs
import dataclasses as dc
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from hlcmp_drake.core.dmp import Dmp, DmpSettings
from hlcmp_drake.io.errors import InputError

FORMAT_VERSION = 1
NOT_A_SKILL = "not a skill file (a .npz written by hlcmp fit/learn)"
_ZIP_MAGIC = (b"PK\x03\x04", b"PK\x05\x06")  # a .npz is a zip archive


@dc.dataclass(frozen=True)
class Skill:
    """A compliant skill theta: the DMP with theta_p and the compliant profiles' weights.

    Attributes
    ----------
    dmp : Dmp
        The fitted DMP (theta_p, tau, start, goal, amplitudes, axis names, settings).
    theta_k, theta_d, theta_v : (M, N) arrays
        Basis weights of the stiffness [N/m], damping [N s/m] and feed-forward force [N]
        profiles, one row per axis.
    """

    dmp: Dmp
    theta_k: np.ndarray
    theta_d: np.ndarray
    theta_v: np.ndarray

    @classmethod
    def untrained(cls, dmp: Dmp) -> Skill:
        """theta_k = theta_d = theta_v = 0, the paper's theta(t0).

        Parameters
        ----------
        dmp : Dmp
            The fitted DMP; its theta_p (M, N) gives the shape of the zero weights.

        Returns
        -------
        Skill
            The skill with zero compliant-profile weights.
        """
        zeros = np.zeros_like(dmp.theta_p)
        return cls(dmp, zeros, zeros.copy(), zeros.copy())


def save_skill(path: str | Path, skill: Skill) -> Path:
    """Write a skill file (.npz with `format_version`), atomically.

    beta is stored by its value (alpha / 4 when the settings leave it at None).

    Parameters
    ----------
    path : str or Path
        The file to write.
    skill : Skill
        The skill.

    Returns
    -------
    Path
        The path written.
    """
    from hlcmp_drake.io.outputs import atomic_write

    d = skill.dmp
    arrays: dict[str, Any] = dict(
        format_version=np.array(FORMAT_VERSION),
        axis_names=np.array(d.axis_names),
        n_basis=np.array(d.settings.n_basis),
        alpha=np.array(d.settings.alpha),
        beta=np.array(d.settings.beta_value),
        alpha_s=np.array(d.settings.alpha_s),
        smoothing_s=np.array(d.settings.smoothing_s),
        tau=np.array(d.tau),
        start=d.start,
        goal=d.goal,
        amplitude=d.amplitude,
        goal_scaled=d.goal_scaled,
        theta_p=d.theta_p,
        theta_k=skill.theta_k,
        theta_d=skill.theta_d,
        theta_v=skill.theta_v,
    )

    def write(temp):
        with open(temp, "wb") as stream:
            np.savez(stream, **arrays)

    return atomic_write(path, write)


def load_skill(path: str | Path) -> Skill:
    """Read a skill file; any problem is an InputError naming the file and the field.

    Parameters
    ----------
    path : str or Path
        A file written by `save_skill`.

    Returns
    -------
    Skill
        The skill, arrays as float (goal_scaled as bool); a stored beta equal to
        alpha / 4 becomes the settings' default None.
    """

    def fail(problem):
        return InputError(f"{path}: {problem}")

    _check_is_zip(Path(path), fail)
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {key: data[key] for key in data.files}
    except FileNotFoundError:
        raise fail("no such file") from None
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as error:
        if "pickle" in str(error):  # numpy's advice (allow_pickle) is not for a skill file
            raise fail(
                "not a skill file: it holds Python objects, which no skill file does"
            ) from None
        raise fail(f"not a readable skill file ({' '.join(str(error).split())[:120]})") from None
    if "format_version" not in arrays:
        raise fail("not a skill file: no 'format_version'")
    version = int(arrays["format_version"])
    if version != FORMAT_VERSION:
        raise fail(
            f"format_version {version} is not supported (this version reads {FORMAT_VERSION})"
        )
    required = (
        "axis_names",
        "n_basis",
        "alpha",
        "beta",
        "alpha_s",
        "smoothing_s",
        "tau",
        "start",
        "goal",
        "amplitude",
        "goal_scaled",
        "theta_p",
        "theta_k",
        "theta_d",
        "theta_v",
    )
    missing = [key for key in required if key not in arrays]
    if missing:
        raise fail(f"missing field(s): {', '.join(missing)}")
    axes = tuple(str(a) for a in np.atleast_1d(arrays["axis_names"]))
    m, n = len(axes), int(arrays["n_basis"])
    for key in ("start", "goal", "amplitude", "goal_scaled"):
        if arrays[key].shape != (m,):
            raise fail(
                f"field '{key}' has shape {arrays[key].shape}, expected ({m},) for axes {axes}"
            )
    for key in ("theta_p", "theta_k", "theta_d", "theta_v"):
        if arrays[key].shape != (m, n):
            raise fail(f"field '{key}' has shape {arrays[key].shape}, expected ({m}, {n})")
        if not np.all(np.isfinite(arrays[key])):
            raise fail(f"field '{key}' holds NaN or infinite values")
    try:
        alpha, beta = float(arrays["alpha"]), float(arrays["beta"])
        # The file holds beta's value; alpha / 4 is the settings' default (None), kept as such.
        settings = DmpSettings(
            n_basis=n,
            alpha=alpha,
            beta=None if beta == alpha / 4.0 else beta,
            alpha_s=float(arrays["alpha_s"]),
            smoothing_s=float(arrays["smoothing_s"]),
        )
    except ValueError as error:
        raise fail(f"invalid DMP settings: {error}") from None
    if not float(arrays["tau"]) > 0:
        raise fail(f"field 'tau' must be positive, got {float(arrays['tau'])}")
    dmp = Dmp(
        settings,
        float(arrays["tau"]),
        arrays["start"].astype(float),
        arrays["goal"].astype(float),
        arrays["theta_p"].astype(float),
        arrays["amplitude"].astype(float),
        arrays["goal_scaled"].astype(bool),
        axes,
    )
    return Skill(
        dmp,
        arrays["theta_k"].astype(float),
        arrays["theta_d"].astype(float),
        arrays["theta_v"].astype(float),
    )


def _check_is_zip(path, fail):
    """A skill file is a zip archive (.npz); anything else gets one clear message instead
    of numpy's, which would guess a pickle and advise allow_pickle."""
    if not path.exists():
        raise fail("no such file")
    if path.is_dir():
        raise fail(f"is a folder, {NOT_A_SKILL}")
    try:
        with open(path, "rb") as stream:
            head = stream.read(512)
    except OSError as error:
        raise fail(f"cannot be read ({error.strerror or error})") from None
    if head[:4] in _ZIP_MAGIC:
        return
    hint = ""
    if head and b"\0" not in head:
        try:
            codecs.getincrementaldecoder("utf-8")().decode(
                head, final=False
            )  # may end mid-character
            hint = "; this is a text file (a demonstration CSV becomes a skill with hlcmp fit)"
        except UnicodeDecodeError:
            pass
    raise fail(("the file is empty, " if not head else "") + NOT_A_SKILL + hint)
