"""Per-experiment evaluation: metrics, the paper's claims and figures from a set of runs."""
