"""Is the Hl-CMP's slow learning in the insertion a matter of the learning rates' scale?

The paper gives Q_k = 3000, Q_d = 90, Q_v = 9 but not the units of the positions nor
whether Eq. 31 is integrated in time or applied once per control step (which would make
the rates 1000x larger at 1 kHz). This sweep multiplies all three by 1, 10, 100 and 1000,
runs the insertion with each (the constant-stiffness runs once, for C1/C2), and prints a
markdown table of the numbers behind the claims.

    python scripts/insertion_learning_rate.py [--update-readme]
"""

import dataclasses as dc

import numpy as np

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.experiments import insertion
from hlcmp_drake.run.runner import run_controllers

import readme_table  # scripts/readme_table.py, beside this file

PLANK_BOTTOM_Z = 0.30   # diagrams/insertion.yaml: top face at 0.33, 3 cm thick


def sweep(scales=(1, 10, 100, 1000)):
    scenario, _ = load_scenario("insertion")
    paper = scenario.controllers["hlcmp"]
    constants = {n: c for n, c in scenario.controllers.items() if n != "hlcmp"}
    constant_runs = run_controllers(dc.replace(scenario, controllers=constants))
    rows = []
    for scale in scales:
        config = dc.replace(paper, q_k=[q * scale for q in paper.q_k], q_d=[q * scale for q in paper.q_d],
                            q_v=[q * scale for q in paper.q_v])
        variant = dc.replace(scenario, controllers={"hlcmp": config, **constants})
        runs = {**run_controllers(dc.replace(variant, controllers={"hlcmp": config})), **constant_runs}
        metrics = {n: insertion.controller_metrics(r, variant.controllers[n], variant) for n, r in runs.items()}
        claims = insertion.claims(metrics, variant, runs)
        rows.append((scale, runs["hlcmp"], metrics["hlcmp"], claims))
    return rows


def markdown(rows):
    lines = ["| Q × | tip through the plank | mean abs(e_z) [mm] | max abs(f_z) [N] | smoothness z [N] | "
             "peak K_s,z [N/m] | peak v_z [N] | v/(u+v) in z | C2 | C3 | C4 |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for scale, run, m, claims in rows:
        through = "yes" if np.min(run.series["x"][:, 2]) < PLANK_BOTTOM_Z else "no"
        ratio = m["ff_to_commanded_force_ratio_z"]
        lines.append(
            f"| {scale} | {through} | {m['mean_abs_position_error_m']['z'] * 1000:.2f} | "
            f"{m['max_abs_force_N']['z']:.2f} | {m['force_smoothness_N']['z']:.2f} | "
            f"{m['max_stiffness_N_per_m']['z']:.1f} | {m['max_abs_feedforward_N']['z']:.2f} | "
            f"{'n/a' if ratio is None else f'{ratio:.2f}'} | "
            + " | ".join("yes" if claims[c]["holds"] else "no" for c in ("C2", "C3", "C4")) + " |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    readme_table.main(__doc__.splitlines()[0], lambda: markdown(sweep()), "insertion learning rate")
