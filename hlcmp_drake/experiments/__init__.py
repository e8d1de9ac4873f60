"""Per-experiment evaluation: metrics, the paper's claims and figures from a set of runs.

Each module offers controller_metrics(run, scenario), claims(metrics, scenario, runs),
table(metrics) and figures(runs, scenario); a scenario names its module in `experiment`.
"""

from hlcmp_drake.experiments import cutting, insertion, one_dof

EXPERIMENTS = {"one_dof": one_dof, "insertion": insertion, "cutting": cutting}
