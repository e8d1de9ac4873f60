"""What every controller's diagram of an arm scenario shares (`worlds.arm.prepare` makes
it; the translational and the 6-D controllers read it)."""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.math import RotationMatrix

from hlcmp_drake.core.dmp import Dmp
from hlcmp_drake.core.orientation_dmp import OrientationDmp


@dc.dataclass
class ArmSetup:
    """What every controller's diagram of an arm scenario shares: the fitted DMP, the
    start posture q0 [rad] (inverse kinematics), the tool orientation there (held below
    the task by a translational controller) and, for a pose demonstration, the fitted
    orientation DMP (a 6-D controller's reference; without it a 6-D controller holds
    `tool_orientation`)."""

    dmp: Dmp
    q0: np.ndarray
    tool_orientation: RotationMatrix
    orientation_dmp: OrientationDmp | None = None
