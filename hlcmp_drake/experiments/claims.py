"""What the experiments' claims share: a claim as a small unit (`Claim`: its name, the
paper's sentence, the function that judges it), what a judge returns (`Verdict`) and is
given (`ClaimInputs`), `judge_claims` that makes metrics.json's entries of a list of claims,
finding the controllers by kind, the smoother-force measure of C2 (insertion and cutting),
and the claims as a Table."""

from __future__ import annotations

import dataclasses as dc
from typing import Callable, Sequence

from hlcmp_drake.config.scenario import Scenario
from hlcmp_drake.experiments.table import Table
from hlcmp_drake.worlds.controllers import CONSTANT_IMPEDANCE, labels_with_role, learners


@dc.dataclass(frozen=True)
class ClaimInputs:
    """What a claim is judged on: one learner's run against the scenario's other controllers.

    Attributes
    ----------
    metrics : dict
        Every controller's metrics, by label.
    scenario : Scenario
        Whose configs say which label plays which role (found by the controller registry).
    runs : dict of str to RunResult or None
        The runs, by label, for a claim that reads series over time (None: not given).
    learner : str or None
        The label of the learner judged (None: the scenario has none).
    """

    metrics: dict
    scenario: Scenario
    runs: dict | None
    learner: str | None

    @property
    def learner_metrics(self) -> dict | None:
        """The judged learner's metrics, or None without a learner or without its metrics.

        Returns
        -------
        dict or None
        """
        return self.metrics.get(self.learner)


@dc.dataclass(frozen=True)
class Verdict:
    """What a claim's judge found.

    Attributes
    ----------
    holds : bool or None
        Whether the claim is reproduced; None: not judged (a run it speaks of did not do
        the experiment's task).
    evidence : str
        What was measured, in a sentence or a few.
    parts : dict of str to bool, optional
        The sub-claims `holds` is the conjunction of, when it has parts.
    details : dict, optional
        Further measured values kept in metrics.json (e.g. C4's phases), by key.
    """

    holds: bool | None
    evidence: str
    parts: dict | None = None
    details: dict = dc.field(default_factory=dict)


# The order of a claim's entry in metrics.json: "details" stands for its keys, "parts" is
# left out when the verdict has none.
ENTRY_KEYS = ("holds", "parts", "evidence", "details", "paper_says")


@dc.dataclass(frozen=True)
class Claim:
    """One of the paper's claims as tested here.

    Attributes
    ----------
    name : str
        Its key in metrics.json's `claims`, e.g. "C1".
    paper_says : str
        The paper's sentence the claim tests, quoted, with its figure.
    judge : callable(ClaimInputs) -> Verdict or None
        Judges the claim; None when it cannot be judged on these inputs (e.g. without a
        learner), and the claim is then left out.
    about : callable(ClaimInputs) -> list of str
        The labels of the runs the claim speaks of (default: the learner). Each must have
        done the experiment's task (its metrics' ``task.done``); otherwise the claim is
        not judged (task not done): its `holds` is None.
    keys : tuple of str
        The order of the claim's entry in metrics.json (see ENTRY_KEYS).
    """

    name: str
    paper_says: str
    judge: Callable
    about: Callable[[ClaimInputs], list] = lambda given: [given.learner]
    keys: tuple = ENTRY_KEYS

    def not_judged(self, undone: dict[str, str], measured: Verdict) -> dict:
        """The claim's entry when a run it speaks of did not do the task: `holds` None (see
        NOT_JUDGED), the runs and why in the evidence; what was measured stays in the
        details.

        Parameters
        ----------
        undone : dict of str to str
            The runs that did not do the task, each with its task evidence.
        measured : Verdict
            The judge's findings, of which only the details are kept.

        Returns
        -------
        dict
        """
        why = "; ".join(f"{name}: {evidence}" for name, evidence in undone.items())
        return self.entry(Verdict(holds=None, evidence=why, details=measured.details))

    def entry(self, verdict: Verdict) -> dict:
        """The claim's entry of metrics.json for `verdict`: {"holds", "evidence",
        "paper_says", and "parts" and the details when the verdict has them}.

        Parameters
        ----------
        verdict : Verdict

        Returns
        -------
        dict
        """
        entry = {}
        for key in self.keys:
            if key == "holds":
                entry["holds"] = verdict.holds
            elif key == "parts":
                if verdict.parts is not None:
                    entry["parts"] = verdict.parts
            elif key == "evidence":
                entry["evidence"] = verdict.evidence
            elif key == "details":
                entry.update(verdict.details)
            elif key == "paper_says":
                entry["paper_says"] = self.paper_says
            else:
                raise ValueError(f"claim {self.name}: unknown entry key '{key}'")
        return entry


def judge_claims(
    claims: Sequence[Claim],
    metrics: dict,
    scenario: Scenario,
    runs: dict | None = None,
    learner_name: str | None = None,
) -> dict:
    """Judge each claim in turn for one learner: metrics.json's `claims` entry of it.

    Parameters
    ----------
    claims : sequence of Claim
        In the order metrics.json lists them.
    metrics : dict
        Every controller's metrics, by label.
    scenario : Scenario
    runs : dict of str to RunResult, optional
        For the claims that read series over time.
    learner_name : str, optional
        The learner to judge (default the scenario's first).

    Returns
    -------
    dict
        {claim name: its entry (see `Claim.entry`)}, without the claims not judged.
    """
    given = ClaimInputs(metrics, scenario, runs, learner_name or learner(scenario))
    result = {}
    for claim in claims:
        verdict = claim.judge(given)
        if verdict is None:
            continue
        undone = {
            name: metrics[name]["task"]["evidence"]
            for name in claim.about(given)
            if not metrics.get(name, {}).get("task", {"done": True})["done"]
        }
        result[claim.name] = claim.not_judged(undone, verdict) if undone else claim.entry(verdict)
    return result


# What a claim's verdict says when a run it speaks of did not do the experiment's task.
NOT_JUDGED = "not judged (task not done)"


def verdict_text(holds: bool | None) -> str:
    """A claim's verdict as tables say it.

    Parameters
    ----------
    holds : bool or None
        The claim's `holds`; None when it was not judged (a run did not do the task).

    Returns
    -------
    str
        "yes", "no" or NOT_JUDGED.
    """
    return NOT_JUDGED if holds is None else ("yes" if holds else "no")


def learner_and_constants(given: ClaimInputs) -> list:
    """The runs a comparison of the learner with the constant impedances speaks of.

    Parameters
    ----------
    given : ClaimInputs

    Returns
    -------
    list of str
    """
    return [given.learner, *constant_impedances(given.scenario)]


def constants_only(given: ClaimInputs) -> list:
    """The runs a claim about the constant impedances alone speaks of.

    Parameters
    ----------
    given : ClaimInputs

    Returns
    -------
    list of str
    """
    return constant_impedances(given.scenario)


def learner(scenario: Scenario) -> str | None:
    """The label of the scenario's (first) learning controller, or None.

    Parameters
    ----------
    scenario : Scenario
        Its learners are found by the controller registry, whatever their labels.

    Returns
    -------
    str or None
    """
    names = learners(scenario)
    return names[0] if names else None


def constant_impedances(scenario: Scenario) -> list[str]:
    """The labels of the constant-impedance controllers, softest first.

    Parameters
    ----------
    scenario : Scenario
        The controllers whose kind plays CONSTANT_IMPEDANCE are ordered by the sum of their
        configured per-axis stiffness [N/m].

    Returns
    -------
    list of str
    """
    return sorted(
        labels_with_role(scenario, CONSTANT_IMPEDANCE),
        key=lambda n: sum(scenario.controllers[n].stiffness_N_per_m),
    )


def smoother_force(
    metrics: dict, learner_name: str, constants: list[str], label: str
) -> Verdict | None:
    """C2: the Hl-CMP's contact force in z is smoother (smaller sum of |second
    difference|, Figs. 8 and 12b) than every constant impedance's.

    Parameters
    ----------
    metrics : dict
        {label: controller metrics}, each with force_smoothness_N per axis [N].
    learner_name : str
    constants : list of str
        The constant-impedance labels to compare with.
    label : str
        How the evidence names the measure.

    Returns
    -------
    Verdict or None
        None without a constant impedance: nothing to be smoother than.
    """
    if not constants:
        return None
    smooth = {n: metrics[n]["force_smoothness_N"]["z"] for n in [learner_name, *constants]}
    return Verdict(
        holds=all(smooth[learner_name] < smooth[n] for n in constants),
        evidence=f"{label}: " + ", ".join(f"{n} {v:.2f} N" for n, v in smooth.items()) + ".",
    )


# How each reading of Q (HlcmpConfig.q_units) is named in tables.
READINGS = {"per_second": "Q per second (Eq. 31)", "per_step": "Q per control step (Table I)"}


def reading_label(name: str, learners: dict) -> str:
    """A learner's column header: its label and its reading of Q.

    Parameters
    ----------
    name : str
        The learner's label (or the key of claims made without one).
    learners : dict
        metrics.json's `learners`: {label: {"q_units": ...}}.
    """
    units = learners.get(name, {}).get("q_units")
    return f"{name}: {READINGS[units]}" if units in READINGS else name


def verdicts_table(claims: dict, learners: dict) -> Table:
    """One row per claim, one verdict column per learner (reading of Q).

    Parameters
    ----------
    claims : dict
        metrics.json's `claims`: {learner: {claim: {"paper_says", "holds", ...}}}.
    learners : dict
        metrics.json's `learners`.
    """
    names = list(claims)
    rows = {}
    for name in names:
        for claim_name, claim in claims[name].items():
            rows.setdefault(claim_name, {"paper_says": claim["paper_says"]})[name] = claim["holds"]
    table = Table(["claim", "the paper says"] + [reading_label(n, learners) for n in names])
    for claim_name, row in rows.items():
        table.add(
            claim_name,
            row["paper_says"],
            *("–" if n not in row else verdict_text(row[n]) for n in names),
        )
    return table


def evidence_table(claims: dict, learners: dict) -> Table:
    """What was measured for each claim under each reading of Q, one row each.

    Parameters
    ----------
    claims, learners : dict
        As for `verdicts_table`; each claim's "evidence" is shown.
    """
    table = Table(["claim", "run", "we measured", "reproduced"])
    for name, by_claim in claims.items():
        for claim_name, claim in by_claim.items():
            table.add(
                claim_name,
                reading_label(name, learners),
                claim["evidence"],
                verdict_text(claim["holds"]),
            )
    return table
