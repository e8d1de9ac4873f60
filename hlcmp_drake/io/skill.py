"""A compliant skill theta = {theta_p, theta_k, theta_d, theta_v} (paper Eq. 17) as one file,
and for a 6-D skill the orientation DMP and the rotational profiles' weights as well.

The file is a NumPy .npz; each file is written as the lowest `format_version` that holds
the skill, so an older reader refuses what it would otherwise read in part:

- format 2, a position skill: ``format_version``; the DMP (theta_p and its settings):
  ``axis_names`` (M,), ``n_basis``, ``alpha``, ``beta``, ``alpha_s``, ``smoothing_s``,
  ``tau``, ``start``, ``goal``, ``amplitude``, ``goal_scaled`` (M,), ``theta_p`` (M, N);
  the compliant profiles' weights ``theta_k``, ``theta_d``, ``theta_v`` (M, N); the world
  it was learned in (`SkillWorld`) as the strings ``world_scenario``, ``world_kind``,
  ``world_digest`` (all empty when unknown), and optionally ``world_overrides`` (a JSON
  list of the `--set` overrides of the task and the models that made that world from its
  scenario, as `SkillWorld.overrides`; readers that do not know it ignore it); optionally
  ``demo_force`` (M, N), the
  demonstration's wrist force on the phase basis (`hlcmp_drake.core.demo_force`; readers
  that do not know the field ignore it, and a file without it is a skill whose
  demonstration carried no force).
- format 3, a pose skill with translational profiles only: format 2's fields and the
  orientation DMP (`core.orientation_dmp`, sharing the position DMP's settings and tau):
  ``orientation_start``, ``orientation_goal`` (4,), ``orientation_rotation`` (3,),
  ``orientation_theta`` (3, N), ``orientation_amplitude``, ``orientation_goal_scaled``.
- format 4, a 6-D skill (what `hlcmp fit` makes of a pose demonstration and `hlcmp learn`
  of a 6-D Hl-CMP's trials): format 3's fields and the rotational profiles' weights
  ``theta_kr`` [N m/rad], ``theta_dr`` [N m s/rad], ``theta_vr`` [N m], (3, N) each.

Loading checks the version, the keys, and every field's shape and type. Older files still
load: a format 1 file (written before skills recorded their world) has its world unknown
(`Skill.world` None), as has a skill `hlcmp fit` made from a demonstration alone; a format
3 file has no rotational profiles (`Skill.theta_kr` None).
"""

from __future__ import annotations

import codecs
import dataclasses as dc
import json
import re
import shlex
import zipfile
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from hlcmp_drake.core.dmp import Dmp, DmpSettings
from hlcmp_drake.core.orientation_dmp import OrientationDmp
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.file_kinds import ZIP_MAGIC, what_it_is

FORMAT_VERSION = 2
# A skill with an orientation DMP.
POSE_FORMAT_VERSION = 3
# A skill with an orientation DMP and the rotational profiles' weights (a 6-D skill).
SIX_D_FORMAT_VERSION = 4
# The versions this one reads: 1 is a skill without its world (Skill.world None).
READABLE_VERSIONS = (1, 2, 3, 4)
# Format 3's orientation DMP: key -> the shape it must have (N: the basis functions).
ORIENTATION_FIELDS = {
    "orientation_start": (4,),
    "orientation_goal": (4,),
    "orientation_rotation": (3,),
    "orientation_theta": (3, "N"),
    "orientation_amplitude": (),
    "orientation_goal_scaled": (),
}
# Format 4's rotational profiles' weights, (3, N) each.
ROTATIONAL_FIELDS = ("theta_kr", "theta_dr", "theta_vr")
# How far from 1 a stored quaternion's norm may be (it was written normalised).
UNIT_NORM_TOLERANCE = 1e-9
# Format 2's record of the world (SkillWorld's fields), all empty when it is unknown.
WORLD_FIELDS = ("world_scenario", "world_kind", "world_digest")
WORLD_OVERRIDES_FIELD = "world_overrides"
# Optional from format 2 on: the demonstration's force as feed-forward weights.
DEMO_FORCE_FIELD = "demo_force"
NOT_A_SKILL = "not a skill file (a .npz written by hlcmp fit/learn)"


@dc.dataclass(frozen=True)
class SkillWorld:
    """The world a skill was learned in, as a replay compares it.

    Two worlds are the same when their `kind` and `digest` are (`same_world`); the
    scenario's name is kept to say where the skill comes from, so a copy of a scenario
    under another name with the same world replays without complaint.

    Attributes
    ----------
    scenario : str
        The name of the scenario the skill was learned in (e.g. "insertion").
    kind : str
        The world's kind: the scenario's task class, "ArmTask" or "SliderTask".
    digest : str
        64 hex digits: the SHA-256 of what defines the world (the scenario's model
        directives, with each model file's content, and its task), made by
        `hlcmp_drake.config.world.world_of_scenario`.
    overrides : tuple of str
        The ``key=value`` overrides of the scenario's task and models that made this
        world, where known (a skill learned or generalized with them): what a replay
        must `--set` again. Not compared: the digest says whether two worlds are one.
    """

    scenario: str
    kind: str
    digest: str
    overrides: tuple[str, ...] = ()

    def same_world(self, other: SkillWorld) -> bool:
        """Whether `other` is the same world (kind and digest; the name may differ).

        Parameters
        ----------
        other : SkillWorld

        Returns
        -------
        bool
        """
        return (self.kind, self.digest) == (other.kind, other.digest)

    def describe(self) -> str:
        """The scenario, its overrides and a short form of the world, e.g. "'insertion'
        with --set task.puncture.depth_m=0.0125 (ArmTask world 3f2a9c1b07d4)", for
        messages.

        Returns
        -------
        str
        """
        sets = "".join(f" --set {shlex.quote(o)}" for o in self.overrides)
        return (
            f"'{self.scenario}'{' with' * bool(sets)}{sets} ({self.kind} world {self.digest[:12]})"
        )


@dc.dataclass(frozen=True)
class Skill:
    """A compliant skill theta: the DMP with theta_p and the compliant profiles' weights,
    and the world they were learned in.

    Attributes
    ----------
    dmp : Dmp
        The fitted DMP (theta_p, tau, start, goal, amplitudes, axis names, settings).
    theta_k, theta_d, theta_v : (M, N) arrays
        Basis weights of the stiffness [N/m], damping [N s/m] and feed-forward force [N]
        profiles, one row per axis.
    world : SkillWorld or None
        Where the profiles were learned; None when unknown (a skill of `hlcmp fit`, which
        learned nothing, or a format 1 file).
    orientation : OrientationDmp or None
        A pose skill's orientation DMP, with the position DMP's settings and tau; None
        for a skill of positions only.
    demo_force : (M, N) array or None
        The demonstration's wrist force encoded on the phase basis, as feed-forward
        weights [N] (`hlcmp_drake.core.demo_force.fit_feedforward_weights`): what
        `hlcmp learn --demo-force` starts theta_v from. None when the demonstration
        carried no force.
    theta_kr, theta_dr, theta_vr : (3, N) arrays or None
        A 6-D skill's rotational profiles' weights: stiffness [N m/rad], damping
        [N m s/rad] and feed-forward torque [N m], one row per tool axis (what a 6-D
        Hl-CMP learns, `core.rotation_law.RotationalHlcmp`). All three or none; only
        with an orientation DMP, which is their reference.
    """

    dmp: Dmp
    theta_k: np.ndarray
    theta_d: np.ndarray
    theta_v: np.ndarray
    world: SkillWorld | None = None
    orientation: OrientationDmp | None = None
    demo_force: np.ndarray | None = None
    theta_kr: np.ndarray | None = None
    theta_dr: np.ndarray | None = None
    theta_vr: np.ndarray | None = None

    def __post_init__(self):
        o = self.orientation
        if o is not None and (o.settings != self.dmp.settings or o.tau != self.dmp.tau):
            raise ValueError("the orientation DMP must share the position DMP's settings and tau")
        rotational = [getattr(self, key) for key in ROTATIONAL_FIELDS]
        if any(theta is None for theta in rotational) and not all(
            theta is None for theta in rotational
        ):
            raise ValueError("theta_kr, theta_dr and theta_vr go together: all three or none")
        if rotational[0] is not None:
            if o is None:
                raise ValueError("rotational profiles need the orientation DMP they follow")
            shape = (3, self.dmp.settings.n_basis)
            if any(np.shape(theta) != shape for theta in rotational):
                raise ValueError(f"theta_kr, theta_dr and theta_vr must each be {shape}")

    @property
    def learned(self) -> bool:
        """Whether its profiles were learned (by `hlcmp learn` or `reproduce`, or generalized
        from a library's): those record the world they were learned in, which `hlcmp fit`'s
        zero weights have none of."""
        return self.world is not None

    @property
    def six_d(self) -> bool:
        """Whether it holds the rotational profiles (a 6-D Hl-CMP's skill)."""
        return self.theta_kr is not None

    @property
    def theta(self) -> tuple[np.ndarray, ...]:
        """The weights a learner starts from, in the order `RunResult.theta` holds them:
        (theta_k, theta_d, theta_v), then (theta_kr, theta_dr, theta_vr) for a 6-D skill.

        Returns
        -------
        tuple of three (M, N) arrays, and three (3, N) arrays for a 6-D skill
        """
        translational = (self.theta_k, self.theta_d, self.theta_v)
        if not self.six_d:
            return translational
        return translational + tuple(getattr(self, key) for key in ROTATIONAL_FIELDS)

    @classmethod
    def untrained(
        cls,
        dmp: Dmp,
        orientation: OrientationDmp | None = None,
        demo_force: np.ndarray | None = None,
    ) -> Skill:
        """theta_k = theta_d = theta_v = 0, the paper's theta(t0); with an orientation DMP a
        6-D skill, theta_kr = theta_dr = theta_vr = 0 too.

        Parameters
        ----------
        dmp : Dmp
            The fitted DMP; its theta_p (M, N) gives the shape of the zero weights.
        orientation : OrientationDmp, optional
            A pose skill's orientation DMP.
        demo_force : (M, N) array, optional
            The demonstration's encoded force (`Skill.demo_force`).

        Returns
        -------
        Skill
            The skill with zero compliant-profile weights.
        """
        zeros = np.zeros_like(dmp.theta_p)
        rotational = None if orientation is None else np.zeros((3, dmp.settings.n_basis))
        return cls(
            dmp,
            zeros,
            zeros.copy(),
            zeros.copy(),
            orientation=orientation,
            demo_force=demo_force,
            theta_kr=rotational,
            theta_dr=None if rotational is None else rotational.copy(),
            theta_vr=None if rotational is None else rotational.copy(),
        )


def save_skill(
    path: str | Path, skill: Skill, extra: Mapping[str, np.ndarray] | None = None
) -> Path:
    """Write a skill file (.npz with `format_version`), atomically.

    beta is stored by its value (alpha / 4 when the settings leave it at None); the world
    as three strings world_scenario, world_kind, world_digest (all empty when unknown); an
    orientation DMP as the ORIENTATION_FIELDS, in format 3, and with the rotational
    profiles (ROTATIONAL_FIELDS) in format 4; `demo_force` only when the skill has one.

    Parameters
    ----------
    path : str or Path
        The file to write.
    skill : Skill
        The skill.
    extra : mapping of str to array, optional
        Further arrays stored beside the skill's (e.g. a generalized skill's predictive
        standard deviations); `load_skill` ignores them. A name of the skill's own is
        refused (ValueError).

    Returns
    -------
    Path
        The path written.
    """
    from hlcmp_drake.io.outputs import atomic_write

    d = skill.dmp
    o = skill.orientation
    arrays: dict[str, Any] = dict(
        format_version=np.array(_version_of(skill)),
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
    world = skill.world or SkillWorld("", "", "")
    for key in ("scenario", "kind", "digest"):
        arrays[f"world_{key}"] = np.array(getattr(world, key))
    if world.overrides:
        arrays[WORLD_OVERRIDES_FIELD] = np.array(json.dumps(list(world.overrides)))
    if skill.demo_force is not None:
        arrays[DEMO_FORCE_FIELD] = skill.demo_force
    if o is not None:
        arrays.update(
            orientation_start=o.start,
            orientation_goal=o.goal,
            orientation_rotation=o.demonstrated_rotation,
            orientation_theta=o.theta,
            orientation_amplitude=np.array(o.amplitude),
            orientation_goal_scaled=np.array(o.goal_scaled),
        )
    if skill.six_d:
        arrays.update({key: getattr(skill, key) for key in ROTATIONAL_FIELDS})
    clashes = sorted(set(extra or {}) & set(arrays))
    if clashes:
        raise ValueError(f"extra arrays may not replace the skill's own: {', '.join(clashes)}")
    arrays.update(extra or {})

    def write(temp):
        with open(temp, "wb") as stream:
            np.savez(stream, **arrays)

    return atomic_write(path, write)


def _version_of(skill: Skill) -> int:
    """The lowest format that holds the skill."""
    if skill.six_d:
        return SIX_D_FORMAT_VERSION
    return FORMAT_VERSION if skill.orientation is None else POSE_FORMAT_VERSION


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
        alpha / 4 becomes the settings' default None; its world None when the file records
        none (format 1, or empty strings).
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
    version = _number(arrays, "format_version", fail, integer=True)
    if version not in READABLE_VERSIONS:
        raise fail(
            f"format_version {version} is not supported (this version reads "
            f"{', '.join(map(str, READABLE_VERSIONS))})"
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
    ) + (WORLD_FIELDS if version >= 2 else ())
    missing = [key for key in required if key not in arrays]
    if missing:
        raise fail(f"missing field(s): {', '.join(missing)}")
    if arrays["axis_names"].ndim > 1 or arrays["axis_names"].dtype.kind != "U":
        raise fail("field 'axis_names' must be a list of strings")
    axes = tuple(str(a) for a in np.atleast_1d(arrays["axis_names"]))
    m, n = len(axes), _number(arrays, "n_basis", fail, integer=True)
    alpha, beta, alpha_s, smoothing_s, tau = (
        _number(arrays, key, fail) for key in ("alpha", "beta", "alpha_s", "smoothing_s", "tau")
    )
    try:
        # The file holds beta's value; alpha / 4 is the settings' default (None), kept as such.
        settings = DmpSettings(
            n_basis=n,
            alpha=alpha,
            beta=None if beta == alpha / 4.0 else beta,
            alpha_s=alpha_s,
            smoothing_s=smoothing_s,
        )
    except ValueError as error:
        raise fail(f"invalid DMP settings: {error}") from None
    for key in ("start", "goal", "amplitude", "goal_scaled"):
        if arrays[key].shape != (m,):
            raise fail(
                f"field '{key}' has shape {arrays[key].shape}, expected ({m},) for axes {axes}"
            )
        if key != "goal_scaled":
            _check_finite_numbers(arrays, key, fail)
    _check_true_false(arrays, "goal_scaled", fail)
    has_force = DEMO_FORCE_FIELD in arrays
    for key in ("theta_p", "theta_k", "theta_d", "theta_v") + (DEMO_FORCE_FIELD,) * has_force:
        if arrays[key].shape != (m, n):
            raise fail(f"field '{key}' has shape {arrays[key].shape}, expected ({m}, {n})")
        _check_finite_numbers(arrays, key, fail)
    if not (np.isfinite(tau) and tau > 0):
        raise fail(f"field 'tau' must be positive and finite, got {tau}")
    dmp = Dmp(
        settings,
        tau,
        arrays["start"].astype(float),
        arrays["goal"].astype(float),
        arrays["theta_p"].astype(float),
        arrays["amplitude"].astype(float),
        arrays["goal_scaled"].astype(bool),
        axes,
    )
    rotational = _rotational(arrays, n, fail) if version >= SIX_D_FORMAT_VERSION else {}
    return Skill(
        dmp,
        arrays["theta_k"].astype(float),
        arrays["theta_d"].astype(float),
        arrays["theta_v"].astype(float),
        _world(arrays, fail) if version >= 2 else None,
        _orientation(arrays, dmp, fail) if version >= POSE_FORMAT_VERSION else None,
        arrays[DEMO_FORCE_FIELD].astype(float) if has_force else None,
        **rotational,
    )


# What a stored array of another kind than real numbers holds, for messages (dtype.kind).
_KIND_NAMES = {"b": "true/false values", "c": "complex numbers", "S": "bytes", "U": "text"}


def _check_finite_numbers(arrays: dict, key: str, fail) -> None:
    """Field `key` holds real numbers, all finite; else an InputError saying which not."""
    kind = arrays[key].dtype.kind
    if kind not in "fiu":
        held = _KIND_NAMES.get(kind, f"{arrays[key].dtype} values")
        raise fail(f"field '{key}' must hold real numbers, not {held}")
    if not np.all(np.isfinite(arrays[key])):
        raise fail(f"field '{key}' must hold finite numbers, not NaN or infinite values")


def _check_true_false(arrays: dict, key: str, fail) -> None:
    """Field `key` holds true/false values (booleans, or numbers 0 and 1)."""
    value = arrays[key]
    if value.dtype.kind not in "biuf" or not np.isin(value, (0, 1)).all():
        raise fail(f"field '{key}' must hold true/false values")


def _number(arrays: dict, key: str, fail, integer: bool = False) -> Any:
    """Field `key` as one real number (float), or one integer (int) where `integer`;
    anything else (text, bytes, complex, several values, a fraction for an integer) is an
    InputError naming the field and what it holds."""
    value = arrays[key]
    if value.shape != () or value.dtype.kind not in ("iu" if integer else "fiu"):
        shown = repr(value.tolist())
        shown = shown if len(shown) <= 40 else shown[:37] + "..."
        raise fail(f"field '{key}' must be {'an integer' if integer else 'a number'}, got {shown}")
    return int(value) if integer else float(value)


def _rotational(arrays, n, fail):
    """Format 4's rotational profiles' weights, each checked to be (3, N) and finite."""
    missing = [key for key in ROTATIONAL_FIELDS if key not in arrays]
    if missing:
        raise fail(f"missing field(s): {', '.join(missing)}")
    for key in ROTATIONAL_FIELDS:
        if arrays[key].shape != (3, n):
            raise fail(f"field '{key}' has shape {arrays[key].shape}, expected (3, {n})")
        _check_finite_numbers(arrays, key, fail)
    return {key: arrays[key].astype(float) for key in ROTATIONAL_FIELDS}


def _orientation(arrays, dmp, fail):
    """The OrientationDmp of a format 3 file, every field checked."""
    missing = [key for key in ORIENTATION_FIELDS if key not in arrays]
    if missing:
        raise fail(f"missing field(s): {', '.join(missing)}")
    n = dmp.settings.n_basis
    for key, shape in ORIENTATION_FIELDS.items():
        expected = tuple(n if size == "N" else size for size in shape)
        if arrays[key].shape != expected:
            raise fail(f"field '{key}' has shape {arrays[key].shape}, expected {expected}")
        if key == "orientation_goal_scaled":
            _check_true_false(arrays, key, fail)
        else:
            _check_finite_numbers(arrays, key, fail)
    for key in ("orientation_start", "orientation_goal"):
        if abs(np.linalg.norm(arrays[key]) - 1.0) > UNIT_NORM_TOLERANCE:
            raise fail(f"field '{key}' is not a unit quaternion")
    if not float(arrays["orientation_amplitude"]) > 0:
        raise fail("field 'orientation_amplitude' must be positive")
    return OrientationDmp(
        dmp.settings,
        dmp.tau,
        arrays["orientation_start"].astype(float),
        arrays["orientation_goal"].astype(float),
        arrays["orientation_rotation"].astype(float),
        arrays["orientation_theta"].astype(float),
        float(arrays["orientation_amplitude"]),
        bool(arrays["orientation_goal_scaled"]),
    )


def _world(arrays, fail):
    """The SkillWorld of a format 2 file: three strings, all empty (None) or all set."""
    values = {}
    for key in WORLD_FIELDS:
        value = arrays[key]
        if value.shape != () or value.dtype.kind != "U":
            raise fail(f"field '{key}' must be a string")
        values[key] = str(value)
    if not any(values.values()):
        return None
    if not all(values.values()):
        empty = [key for key, value in values.items() if not value]
        raise fail(f"field(s) {', '.join(empty)} empty while the others name a world")
    if not re.fullmatch(r"[0-9a-f]{64}", values["world_digest"]):
        raise fail("field 'world_digest' must be 64 hex digits (a SHA-256)")
    overrides: Any = []
    if WORLD_OVERRIDES_FIELD in arrays:
        value = arrays[WORLD_OVERRIDES_FIELD]
        try:
            overrides = json.loads(str(value)) if value.shape == () else None
        except json.JSONDecodeError:
            overrides = None
        if not (isinstance(overrides, list) and all(isinstance(o, str) for o in overrides)):
            raise fail(f"field '{WORLD_OVERRIDES_FIELD}' must be a JSON list of strings")
    return SkillWorld(
        values["world_scenario"], values["world_kind"], values["world_digest"], tuple(overrides)
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
            head = stream.read(4096)
    except OSError as error:
        raise fail(f"cannot be read ({error.strerror or error})") from None
    if head[:4] in ZIP_MAGIC:
        return
    hint = ""
    if head and b"\0" not in head:
        try:
            codecs.getincrementaldecoder("utf-8")().decode(
                head, final=False
            )  # may end mid-character
            hint = f"; this is {what_it_is(head) or 'a text file'}"
        except UnicodeDecodeError:
            pass
    raise fail(("the file is empty, " if not head else "") + NOT_A_SKILL + hint)
