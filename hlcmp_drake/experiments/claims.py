"""What the experiments' claims share: finding the controllers by kind, the smoother-force
claim C2 (insertion and cutting), and the claims as a Table."""

from __future__ import annotations

from hlcmp_drake.config.scenario import ConstantImpedanceConfig, HlcmpConfig, Scenario
from hlcmp_drake.experiments.table import Table


def learner(scenario: Scenario) -> str | None:
    """The label of the scenario's (first) learning controller, an Hl-CMP, or None.

    Parameters
    ----------
    scenario : Scenario
        Its controllers are found by config kind (!HlcmpConfig), whatever their labels.

    Returns
    -------
    str or None
    """
    names = scenario.controllers_of(HlcmpConfig)
    return names[0] if names else None


def constant_impedances(scenario: Scenario) -> list[str]:
    """The labels of the constant-impedance controllers, softest first.

    Parameters
    ----------
    scenario : Scenario
        The controllers of kind !ConstantImpedanceConfig are ordered by the sum of their
        configured per-axis stiffness [N/m].

    Returns
    -------
    list of str
    """
    return sorted(scenario.controllers_of(ConstantImpedanceConfig),
                  key=lambda n: sum(scenario.controllers[n].stiffness_N_per_m))


def smoother_force(metrics: dict, learner_name: str, constants: list[str], label: str,
                   paper_says: str) -> dict:
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


def claims_table(claims: dict) -> Table:
    """The claims as a Table, one row per claim.

    Parameters
    ----------
    claims : dict
        {claim name: {"paper_says", "evidence", "holds", ...}}, as in metrics.json.

    Returns
    -------
    Table
        Columns claim, the paper says, we measured, reproduced ("yes"/"no").
    """
    table = Table(["claim", "the paper says", "we measured", "reproduced"])
    for name, claim in claims.items():
        table.add(name, claim["paper_says"], claim["evidence"], "yes" if claim["holds"] else "no")
    return table
