"""The peg-in-hole fixture's sizes: scripts/make_peg_fixture.py makes
models/peg_fixture.obj from them (docs/worlds.md says why each), and the peg task reads
from them where the hole is (`experiments.peg_in_hole`)."""

HOLE_RADIUS_M = 0.0061  # 12.2 mm: a 12.0 mm peg with 0.2 mm diametral clearance
CHAMFER_M = 0.001  # 1 mm x 45 degrees at the entrance
BLOCK_HALF_WIDTH_M = 0.03  # a 60 mm square block
BLOCK_HEIGHT_M = 0.025  # the bore's length: a 25 mm through hole
# The entrance's radius, its chamfer included: the chamfer's top circle.
ENTRANCE_RADIUS_M = HOLE_RADIUS_M + CHAMFER_M
