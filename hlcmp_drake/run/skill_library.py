"""Generalising learned compliance over task parameters (`hlcmp generalize`): the paper's
proposal (Sec. VI) to regress theta_k, theta_d and theta_v -- and the DMP, when the task
parameters move it -- on the task parameters (queries) of a skill library.

Regression: Gaussian-process regression (scikit-learn's `GaussianProcessRegressor`), one
per array of the skill (theta_k, theta_d, theta_v, and each DMP array that differs across
the library), each array's weights the outputs of one GP with shared hyperparameters.
Inputs: each task parameter normalised to [0, 1] over the library's range; one that all
the skills share (its other values' skills went unstable, say) tells nothing and is left
out. Outputs:
normalised per weight to zero mean and unit variance over the library (`normalize_y`).
Kernel (`KERNEL_DESCRIPTION`)::

    k(x, x') = c * exp(-0.5 * sum_j (x_j - x'_j)^2 / l_j^2) + w * [x == x']

a constant times an RBF with one length scale per task parameter (ARD), plus white noise
w for what the trials' learning does not repeat. c, l_j and w are fitted by maximising the
log marginal likelihood (L-BFGS-B from the initial values and `RESTARTS` random starts,
seeded, so a fit is deterministic). The predictive standard deviation of each weight
(including w) is saved beside the weights; it is 0 for a weight that every skill of the
library holds at the same value.

Nearest: the library skill whose query is nearest in the normalised parameters.

A query must give every task parameter of the library and no other key; a value outside
the library's range by more than `EXTRAPOLATION_MARGIN` of that range (for a parameter all
the skills share, any other value) is refused unless extrapolation is asked for (then a
warning).
"""

from __future__ import annotations

import dataclasses as dc
import json
import math
import warnings
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from hlcmp_drake.config.library import AS_DEMONSTRATED_AT_0, SKILLS_DIR
from hlcmp_drake.config.loading import OptionOverride, load_scenario, override_read_from
from hlcmp_drake.config.world import world_of_scenario
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.paths import DIAGRAMS_DIR
from hlcmp_drake.io.skill import Skill, load_skill, save_skill
from hlcmp_drake.run.library import LIBRARY_FILE

METHODS = ("regression", "nearest")
# How far outside the library's range a query may lie, as a fraction of the range: a
# tenth of the span between the extreme grid values (so 0.5 mm for a 10-15 mm range).
EXTRAPOLATION_MARGIN = 0.1
RESTARTS = 4  # random restarts of the marginal-likelihood optimisation
KERNEL_DESCRIPTION = (
    "ConstantKernel * RBF (one length scale per task parameter, on [0, 1]-normalised "
    "inputs) + WhiteKernel; hyperparameters by maximum marginal likelihood"
)
# The skill's arrays a library regresses: the learned profiles always, the DMP's where
# the library's skills differ (a query that moves the goal, or its tau: a skill is saved
# at the tau it learned at, e.g. a grid over reference.duration_s).
PROFILE_FIELDS = ("theta_k", "theta_d", "theta_v")
DMP_FIELDS = ("theta_p", "start", "goal", "amplitude", "tau")
# The array a generalized skill's file holds beside the skill (`save_generalized`), which
# tells it from a trained one (`is_generalized`).
GENERALIZED_MARK = "generalized_method"
# scikit-learn's normalize_y treats a weight whose standard deviation over the library is
# below this as constant (sklearn.preprocessing's _handle_zeros_in_scale).
NO_SPREAD = 10 * np.finfo(float).eps


@dc.dataclass(frozen=True)
class Prediction:
    """A skill's arrays at a query.

    Attributes
    ----------
    mean : dict of str to array
        Field name ("theta_k", "theta_d", "theta_v", and any regressed DMP array) ->
        the predicted array, shaped as the skill's ((M, N) for the weights, (M,) for the
        DMP's start, goal and amplitude).
    std : dict of str to array or None
        The predictive standard deviation of each regressed field, same shapes (None
        for the nearest skill).
    method : str
        "regression" or "nearest".
    nearest : str
        The id of the library skill nearest to the query (normalised parameters).
    """

    mean: dict
    std: dict | None
    method: str
    nearest: str


class SkillLibrary:
    """A skill library as `hlcmp library` wrote it (DIR/library.json and one skill per
    query), and regression of its skills over the task parameters.

    Parameters
    ----------
    folder : Path
        The library's folder.
    record : dict
        library.json's content.
    skills : list of Skill
        One per entry of record["skills"], in that order.

    Attributes
    ----------
    parameters : list of str
        The task parameters (override keys), in the library's order.
    queries : (S, P) array
        Each skill's task parameters.
    lower, upper : (P,) arrays
        The library's range of each parameter.
    regressed : list of str
        The parameters the skills differ in (`lower` < `upper`): the regression's inputs.
    ids : list of str
        Each skill's id.
    """

    def __init__(self, folder: Path, record: dict, skills: list[Skill]):
        self.folder, self.record, self.skills = Path(folder), record, skills
        self.parameters = list(record["parameters"])
        self.ids = [entry["id"] for entry in record["skills"]]
        self.queries = np.array(
            [[float(entry["query"][key]) for key in self.parameters] for entry in record["skills"]]
        )
        self.lower, self.upper = self.queries.min(axis=0), self.queries.max(axis=0)
        self._varied = self.upper > self.lower
        self.regressed = [key for key, varied in zip(self.parameters, self._varied) if varied]
        self.fields = list(PROFILE_FIELDS) + [
            field for field in DMP_FIELDS if _varies([_array(s, field) for s in skills])
        ]
        self._models: dict | None = None

    @classmethod
    def load(cls, folder: str | Path) -> SkillLibrary:
        """Read DIR/library.json and every skill it lists.

        Parameters
        ----------
        folder : str or Path
            A folder written by `hlcmp library`.

        Returns
        -------
        SkillLibrary

        Raises
        ------
        InputError
            One line naming the file: no library.json, not JSON, a missing key or one of
            another type (`_check_record`), a skill file that cannot be read, fewer than
            two skills, two skills at one query, pose skills. (Skills whose DMPs cannot
            be regressed together are refused by `fit`: the nearest skill is used as it is.)
        """
        folder = Path(folder)
        path = folder / LIBRARY_FILE
        record = _read_record(folder)
        skills = [load_skill(folder / entry["skill"]) for entry in record["skills"]]
        if any(skill.orientation is not None for skill in skills):
            raise InputError(
                f"{path}: its skills are pose skills (a 6-D learner's); generalising regresses "
                "theta_k, theta_d, theta_v and the position DMP only, and would drop their "
                "orientation DMP and rotational profiles"
            )
        return cls(folder, record, skills)

    def normalized(self, queries: np.ndarray) -> np.ndarray:
        """The regressed task parameters (`regressed`) mapped to [0, 1] over the library's
        range.

        Parameters
        ----------
        queries : (Q, P) array

        Returns
        -------
        (Q, R) array
        """
        varied = self._varied
        span = self.upper[varied] - self.lower[varied]
        return (np.atleast_2d(queries)[:, varied] - self.lower[varied]) / span

    def fit(self) -> SkillLibrary:
        """Fit one Gaussian process per regressed field (see the module's docstring).

        Returns
        -------
        SkillLibrary
            This library, fitted.

        Raises
        ------
        InputError
            One line naming library.json and the DMP setting, axes or goal scaling two of
            its skills differ in, which the regression cannot take (`_check_same_dmp`).
        """
        _check_same_dmp(self.skills, self.ids, self.folder / LIBRARY_FILE)
        _require_sklearn()
        from sklearn.exceptions import ConvergenceWarning
        from sklearn.gaussian_process import GaussianProcessRegressor
        from threadpoolctl import threadpool_limits

        inputs = self.normalized(self.queries)
        self._models = {}
        for field in self.fields:
            outputs = np.array([_array(skill, field).ravel() for skill in self.skills])
            model = GaussianProcessRegressor(
                kernel=gp_kernel(len(self.regressed)),
                normalize_y=True,
                n_restarts_optimizer=RESTARTS,
                random_state=0,
            )
            # A length scale at its bound is a result, not news; and matrices this small
            # are slower on several BLAS threads than on one (5x on 2 busy cores).
            with warnings.catch_warnings(), threadpool_limits(1):
                warnings.simplefilter("ignore", ConvergenceWarning)
                model.fit(inputs, outputs)
            self._models[field] = model
        return self

    def kernels(self) -> dict:
        """The fitted kernel of each regressed field, as text (after `fit`).

        Returns
        -------
        dict of str to str
        """
        return {field: str(model.kernel_) for field, model in (self._models or {}).items()}

    def length_scales(self) -> dict:
        """The fitted RBF length scale of each regressed field, per regressed task parameter
        (`regressed`), on the [0, 1]-normalised range (after `fit`): how far a skill's
        influence reaches (at the bounds 0.1 or 100: none beyond the skill itself, or the
        same everywhere).

        Returns
        -------
        dict of str to (R,) array
        """
        return {
            field: np.broadcast_to(model.kernel_.k1.k2.length_scale, (len(self.regressed),))
            for field, model in (self._models or {}).items()
        }

    def trends_not_found(self) -> list[str]:
        """A warning line per task parameter along which a regressed field's length scale
        sits at its lower bound (after `fit`): the marginal likelihood found no trend that
        carries from one grid value to the next, so between and beyond them the prediction
        falls back toward the library's mean. Two values of a parameter along which the
        skills differ tend to end so: a weight that only moves with it is, normalised to
        zero mean, +1 at one and -1 at the other, best explained as uncorrelated.

        Returns
        -------
        list of str
        """
        notes = []
        scales = self.length_scales()
        for j, key in enumerate(self.regressed):
            fields = [f for f in self.fields if scales[f][j] <= LENGTH_SCALE_BOUNDS[0] * 1.001]
            if not fields:
                continue
            values = len(np.unique(self.queries[:, self.parameters.index(key)]))
            advice = (
                f"the library has only {values} values of it: give it three or more"
                if values < 3
                else "a finer grid along it may find one"
            )
            notes.append(
                f"the regression found no trend along {key} for {', '.join(fields)} (length "
                f"scale at its lower bound {LENGTH_SCALE_BOUNDS[0]:g}): away from the "
                f"library's skills the prediction falls back toward their mean; {advice}, "
                "or use --method nearest"
            )
        return notes

    def query_vector(self, query: Mapping[str, float], extrapolate: bool = False) -> tuple:
        """Check a query against the library and order its values as `parameters`.

        Parameters
        ----------
        query : mapping of str to float
            Every task parameter of the library, and no other key.
        extrapolate : bool
            Allow values outside the range by more than EXTRAPOLATION_MARGIN.

        Returns
        -------
        ((P,) array, list of str)
            The values, and a warning line per value outside the range (extrapolated).

        Raises
        ------
        InputError
            One line: a key the library does not vary, a missing key, a value that is not
            a finite number, or one beyond the margin without `extrapolate` (for a
            parameter all the skills share: another value).
        """
        varied = ", ".join(self.parameters)
        for key in query:
            if key not in self.parameters:
                raise InputError(
                    f"--query {key}: the library does not vary it (it varies: {varied})"
                )
        missing = [key for key in self.parameters if key not in query]
        if missing:
            raise InputError(
                f"--query: missing {', '.join(missing)} (the library varies: {varied})"
            )
        values, notes = [], []
        for j, key in enumerate(self.parameters):
            value = query[key]
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                raise InputError(f"--query {key}={value}: expected one finite number")
            low, high = float(self.lower[j]), float(self.upper[j])
            margin = EXTRAPOLATION_MARGIN * (high - low)
            if not low - margin <= value <= high + margin:
                where = (
                    f"--query {key}={value:g}: every skill of the library was learned at "
                    f"{low:g}: nothing is known of other values (the regression leaves it out)"
                    if low == high
                    else f"--query {key}={value:g}: outside the library's range [{low:g}, "
                    f"{high:g}] by more than {EXTRAPOLATION_MARGIN:.0%} of it ({margin:g})"
                )
                if not extrapolate:
                    raise InputError(where + "; pass --extrapolate to predict there all the same")
                notes.append(where + "; extrapolated (--extrapolate)")
            values.append(float(value))
        return np.array(values), notes

    def predict(self, query: Mapping[str, float], method: str = "regression") -> Prediction:
        """The skill's arrays at a query (checked first: `query_vector` with extrapolation
        allowed).

        Parameters
        ----------
        query : mapping of str to float
        method : str
            "regression" (the fitted GPs' mean and standard deviation; fitted on first
            use) or "nearest" (the nearest library skill's arrays, no std).

        Returns
        -------
        Prediction
        """
        if method not in METHODS:
            raise InputError(f"--method: must be one of {', '.join(METHODS)}, got '{method}'")
        x, _ = self.query_vector(query, extrapolate=True)
        distances = np.linalg.norm(self.normalized(self.queries) - self.normalized(x), axis=1)
        nearest = int(np.argmin(distances))
        if method == "nearest":
            skill = self.skills[nearest]
            mean = {field: _array(skill, field).copy() for field in self.fields}
            return Prediction(mean, None, method, self.ids[nearest])
        if self._models is None:
            self.fit()
        assert self._models is not None
        mean, std = {}, {}
        for field, model in self._models.items():
            shape = _array(self.skills[0], field).shape
            mu, sigma = model.predict(self.normalized(x), return_std=True)
            # A weight every skill of the library holds at one value, up to round-off, is
            # known exactly: normalize_y takes a spread below ten machine epsilons for none
            # and substitutes a unit scale, in which the GP's std of it would come out.
            spread = np.std([_array(s, field) for s in self.skills], axis=0)
            varies = spread >= NO_SPREAD
            mean[field] = np.asarray(mu).reshape(shape)
            std[field] = np.asarray(sigma).reshape(shape) * varies
        return Prediction(mean, std, method, self.ids[nearest])

    def generalize(
        self, query: Mapping[str, float], method: str = "regression", extrapolate: bool = False
    ) -> tuple[Skill, Prediction, list]:
        """The skill at a query, recording the world of the library's scenario with the
        library's fixed overrides and the query's values (so `learn --skill`,
        `reproduce` and `serve` with those --set values accept it).

        Parameters
        ----------
        query : mapping of str to float
            A value the world refuses is named `--query KEY=VALUE` (`overrides`).
        method : str
            "regression" or "nearest".
        extrapolate : bool
            Allow a query beyond the range's margin (with a warning).

        Returns
        -------
        (Skill, Prediction, list of str)
            The skill, the prediction it was made of, and warning lines.
        """
        _, notes = self.query_vector(query, extrapolate)
        prediction = self.predict(query, method)
        if method == "regression":
            notes = notes + self.trends_not_found()
        # The nearest skill is taken as it is, its DMP's settings with it; a regression's
        # skills share theirs (`_check_same_dmp`).
        base = self.skills[self.ids.index(prediction.nearest) if method == "nearest" else 0]
        dmp_arrays = {f: prediction.mean[f] for f in DMP_FIELDS if f in prediction.mean}
        if "tau" in dmp_arrays:
            dmp_arrays["tau"] = float(dmp_arrays["tau"])
        # A skill is saved at the tau it ran at, which over reference.duration_s is that
        # task parameter itself: the query's value, where a regression only comes near it.
        if AS_DEMONSTRATED_AT_0 in self.parameters:
            dmp_arrays["tau"] = float(query[AS_DEMONSTRATED_AT_0])
        dmp = dc.replace(base.dmp, **dmp_arrays) if dmp_arrays else base.dmp
        # A query's value the world refuses is named as the query (`overrides`).
        scenario, _ = load_scenario(self.scenario_argument(), self.overrides(query))
        skill = Skill(
            dmp,
            prediction.mean["theta_k"],
            prediction.mean["theta_d"],
            prediction.mean["theta_v"],
            world=world_of_scenario(scenario, self.overrides(query)),
            demo_force=self._demonstration_force(),
        )
        return skill, prediction, notes

    def _demonstration_force(self) -> np.ndarray | None:
        """The force of the demonstration the library's skills were learned from (their
        `demo_force`, one for all of them: a library follows one demonstration), None
        where a skill has none or they differ."""
        forces = [skill.demo_force for skill in self.skills]
        if any(force is None for force in forces) or _varies(forces):
            return None
        return forces[0]

    def overrides(self, query: Mapping[str, float]) -> list[str]:
        """The --set overrides of the world at a query: the library's fixed ones (a relative
        path in them read beside the library file, as `hlcmp library` read it), then one
        per task parameter, each an `OptionOverride` that a message names as the query
        (`--query KEY=VALUE`, the value as typed: `_as_typed`).

        Parameters
        ----------
        query : mapping of str to float
            A value with a `text` (the command line's) is named as that text, any other
            by its shortest repr.

        Returns
        -------
        list of str
        """
        fixed = [f"{key}={value}" for key, value in self.record["set"].items()]
        library_file = self.record.get("library_file")
        if isinstance(library_file, str) and library_file:
            # A relative path (reference.file) was read beside the library file when the
            # skills were learned (`config.sweep.task_overrides`): so it is here.
            folder, name = Path(library_file).parent, Path(library_file).name
            why = f"a relative path in {name} is read beside it"
            fixed = [override_read_from(override, folder, why) for override in fixed]
        return fixed + [
            OptionOverride(f"{key}={float(query[key])!r}", f"--query {key}={_as_typed(query[key])}")
            for key in self.parameters
        ]

    def scenario_argument(self) -> str:
        """The library's scenario as the commands take it: its bundled name for a bundled
        scenario (or when the file is gone), else its file's path.

        Returns
        -------
        str
        """
        path = Path(self.record["scenario_path"])
        if not path.is_file() or path.resolve() == (DIAGRAMS_DIR / f"{path.stem}.yaml").resolve():
            return self.record["scenario"]
        return str(path)


def _as_typed(value: float) -> str:
    """A query's value as the user typed it (the command line's keeps its text, `text`),
    else its shortest repr."""
    return getattr(value, "text", None) or repr(float(value))


def owned_by_library(folder: str | Path, path: str | Path) -> bool:
    """Whether a file is the library's own, which writing would change: its library.json,
    anything in its skills/ folder, or a skill file its library.json lists.

    Parameters
    ----------
    folder : str or Path
        The library's folder (not necessarily a library: then only the first two).
    path : str or Path
        The file, which need not exist.

    Returns
    -------
    bool
    """
    folder, target = Path(folder).resolve(), Path(path).resolve()
    if target == folder / LIBRARY_FILE or target.is_relative_to(folder / SKILLS_DIR):
        return True
    try:
        listed = [folder / entry["skill"] for entry in _read_record(folder)["skills"]]
    except InputError:  # no library to change (`SkillLibrary.load` refuses it)
        return False
    return any(target == skill.resolve() for skill in listed)


def gp_kernel(n_parameters: int) -> Any:
    """The regression's kernel before fitting (`KERNEL_DESCRIPTION`): a constant times an
    RBF with one length scale per task parameter, plus white noise, with the bounds the
    marginal likelihood is maximised within (inputs on [0, 1], outputs normalised).

    Parameters
    ----------
    n_parameters : int

    Returns
    -------
    sklearn.gaussian_process.kernels.Kernel
    """
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

    return ConstantKernel(1.0, (1e-2, 1e2)) * RBF(
        length_scale=np.full(n_parameters, 0.5), length_scale_bounds=LENGTH_SCALE_BOUNDS
    ) + WhiteKernel(1e-2, (1e-6, 1.0))


# The RBF's length scales on the [0, 1]-normalised task parameters: from a tenth of the
# library's range (a skill's influence ends near it) to a hundred ranges (none varies).
LENGTH_SCALE_BOUNDS = (0.1, 100.0)


def save_generalized(
    path: str | Path, skill: Skill, prediction: Prediction, query: Mapping
) -> Path:
    """Write a generalized skill: the skill, and beside its weights `std_<field>` (the
    predictive standard deviation of each regressed field), `generalized_query` (JSON),
    `generalized_method` and `generalized_nearest`.

    Parameters
    ----------
    path : str or Path
    skill : Skill
    prediction : Prediction
    query : mapping of str to float

    Returns
    -------
    Path
    """
    extra = {
        "generalized_query": np.array(json.dumps(dict(query))),
        GENERALIZED_MARK: np.array(prediction.method),
        "generalized_nearest": np.array(prediction.nearest),
    }
    for field, std in (prediction.std or {}).items():
        extra[f"std_{field}"] = std
    return save_skill(path, skill, extra)


def is_generalized(path: str | Path) -> bool:
    """Whether a skill file is one `save_generalized` wrote (a prediction over a library,
    marked by its `generalized_method`), not one trained by `hlcmp learn` or `reproduce`.

    Parameters
    ----------
    path : str or Path
        A skill file `load_skill` reads.

    Returns
    -------
    bool
    """
    with np.load(path, allow_pickle=False) as data:
        return GENERALIZED_MARK in data.files


def _read_record(folder: Path) -> dict:
    """A library folder's library.json, checked (`_check_record`).

    Raises
    ------
    InputError
        One line: the folder is a file, or its library.json is missing, unreadable or
        not as `hlcmp library` writes it.
    """
    path = folder / LIBRARY_FILE
    if folder.exists() and not folder.is_dir():
        raise InputError(f"{folder}: is a file, not a folder written by hlcmp library")
    try:
        record = json.loads(path.read_text())
    except FileNotFoundError:
        raise InputError(f"{path}: no such file (a folder written by hlcmp library)") from None
    except (OSError, UnicodeDecodeError, ValueError) as error:
        raise InputError(f"{path}: not a library.json ({type(error).__name__})") from None
    _check_record(record, path)
    return record


# library.json's keys that generalising reads, and their JSON types.
RECORD_KEYS = {"scenario": str, "scenario_path": str, "set": dict, "parameters": list}
ENTRY_KEYS = {"id": str, "skill": str, "query": dict}
# Python's types of JSON's kinds, as a message names them (bool before int: it is one).
_JSON_KINDS = ((bool, "a boolean"), (dict, "an object"), (list, "an array"), (str, "a string"))


def _json_kind(value: Any) -> str:
    """What kind of JSON value `value` is: "an object", "a number", "null" ..."""
    kind = next((name for kind, name in _JSON_KINDS if isinstance(value, kind)), None)
    return kind or ("null" if value is None else "a number")


def _check_record(record: Any, path: Path) -> None:
    """What generalising reads of library.json, as `hlcmp library` writes it; a hand-edited
    one is refused in one line naming the key, or the skill's entry and its key.

    Parameters
    ----------
    record : object
        library.json's content.
    path : Path
        library.json (for the message).

    Raises
    ------
    InputError
    """

    def check_types(mapping: dict, kinds: dict, where: str) -> None:
        for key, kind in kinds.items():
            if key not in mapping:
                raise InputError(f"{where}: missing key '{key}'")
            if not isinstance(mapping[key], kind):
                wanted, got = dict(_JSON_KINDS)[kind], _json_kind(mapping[key])
                raise InputError(f"{where}: '{key}' must be {wanted}, got {got}")

    if not isinstance(record, dict):
        raise InputError(f"{path}: not a library.json (a JSON object written by hlcmp library)")
    check_types(record, {**RECORD_KEYS, "skills": list}, str(path))
    if not isinstance(record.get("controller") or "", str):  # the learner's label, optional
        raise InputError(f"{path}: 'controller' must be a string")
    parameters = record["parameters"]
    if not parameters or not all(isinstance(key, str) for key in parameters):
        raise InputError(f"{path}: 'parameters' must list the task parameters' keys")
    if len(record["skills"]) < 2:
        raise InputError(
            f"{path}: {len(record['skills'])} skill(s) learned; generalising needs at "
            "least two (run hlcmp library again to learn the rest)"
        )
    seen: dict = {}
    for n, entry in enumerate(record["skills"]):
        where = f"{path}: skills[{n}]"
        if not isinstance(entry, dict):
            raise InputError(f"{where}: must be an object, got {_json_kind(entry)}")
        check_types(entry, ENTRY_KEYS, where)
        for key in parameters:
            value = entry["query"].get(key)
            if key not in entry["query"]:
                problem = "missing"
            elif _json_kind(value) != "a number":
                problem = f"must be a number, got {json.dumps(value)}"
            elif not math.isfinite(value):
                problem = "must be finite"
            else:
                continue
            raise InputError(f"{where} ('{entry['id']}'): query {key}: {problem}")
        query = tuple(float(entry["query"][key]) for key in parameters)
        if query in seen:
            raise InputError(
                f"{where}: '{entry['id']}' has the query of '{seen[query]}'; a library holds "
                "one skill per query"
            )
        seen[query] = entry["id"]


def _require_sklearn() -> None:
    """The regression needs scikit-learn (the `generalize` extra); say so in one line."""
    try:
        import sklearn  # noqa: F401
    except ImportError:
        raise InputError(
            "--method regression needs scikit-learn, which is not installed: "
            "pip install -e '.[generalize]' (--method nearest works without it)"
        ) from None


def _array(skill: Skill, field: str) -> np.ndarray:
    return np.asarray(
        getattr(skill, field) if field in PROFILE_FIELDS else getattr(skill.dmp, field)
    )


def _varies(arrays: list) -> bool:
    return any(not np.array_equal(arrays[0], other) for other in arrays[1:])


def _check_same_dmp(skills: list, ids: list, path: Path) -> None:
    """The skills' DMPs must share what is not regressed: settings, axes, scaling. A skill
    that differs from the first is refused in one line naming what differs and how."""
    first = skills[0].dmp
    for skill, identifier in zip(skills[1:], ids[1:]):
        dmp = skill.dmp
        pairs = {
            f"DMP's {field.name}": (
                getattr(first.settings, field.name),
                getattr(dmp.settings, field.name),
            )
            for field in dc.fields(first.settings)
        }
        pairs["DMP's axes"] = (",".join(first.axis_names), ",".join(dmp.axis_names))
        pairs["DMP's goal scaling"] = (first.goal_scaled.tolist(), dmp.goal_scaled.tolist())
        for what, (theirs, its) in pairs.items():
            if theirs != its:
                raise InputError(
                    f"{path}: the skills '{ids[0]}' and '{identifier}' differ in their {what} "
                    f"({theirs} and {its}), which cannot be regressed: the regression takes "
                    "skills of one DMP's settings, axes and goal scaling (--method nearest "
                    "takes a skill as it is)"
                )
