"""Imported last by the local engine's fork server (`engines.WORKER_IMPORTS`): the set-up a
task's first run would otherwise repeat in every worker forked from it, done once there --
numba's compiler set up (`core.kernels.prepare_compiler`) and matplotlib's Figure imported
(the Agg backend does not import it)."""

import matplotlib.figure  # noqa: F401  (imported for the workers)

from hlcmp_drake.core.kernels import prepare_compiler

prepare_compiler()
