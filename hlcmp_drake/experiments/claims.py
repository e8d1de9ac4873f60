"""What the experiments' claims share: finding the controllers by kind, the smoother-force
claim C2 (insertion and cutting), and the claims as a Table."""

from __future__ import annotations

from hlcmp_drake.config.scenario import Scenario
from hlcmp_drake.experiments.table import Table
from hlcmp_drake.worlds.controllers import CONSTANT_IMPEDANCE, labels_with_role, learners


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
    metrics: dict, learner_name: str, constants: list[str], label: str, paper_says: str
) -> dict:
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
    paper_says : str
        The paper's sentence the claim tests.
    """
    smooth = {n: metrics[n]["force_smoothness_N"]["z"] for n in [learner_name, *constants]}
    return {
        "holds": all(smooth[learner_name] < smooth[n] for n in constants),
        "evidence": f"{label}: " + ", ".join(f"{n} {v:.2f} N" for n, v in smooth.items()) + ".",
        "paper_says": paper_says,
    }


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
            *("–" if n not in row else ("yes" if row[n] else "no") for n in names),
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
                "yes" if claim["holds"] else "no",
            )
    return table
