"""Make models/peg_fixture.obj: the peg-in-hole fixture's rigid surface, a square block with
a round through hole whose entrance is chamfered at 45 degrees (docs/worlds.md says why
each size).

The model frame is the centre of the hole's entrance on the top face, +z out of the block
(up), so the hole's axis is the frame's z axis. Every face is split along rays from the
axis (SEGMENTS of them, a multiple of 8 so the block's corners lie on rays), and the
triangles wind counter-clockwise seen from outside the material (outward normals).

    python scripts/make_peg_fixture.py [--out models/peg_fixture.obj]
"""

import argparse
from pathlib import Path

import numpy as np

from hlcmp_drake.worlds.peg_fixture import (
    BLOCK_HALF_WIDTH_M,
    BLOCK_HEIGHT_M,
    CHAMFER_M,
    HOLE_RADIUS_M,
)

ROOT = Path(__file__).resolve().parent.parent

SEGMENTS = 96  # 3.75 degrees: the 12.2 mm circle within 3.3 um of its polygon


def rings() -> np.ndarray:
    """(5, SEGMENTS, 3): the vertex rings, from the block's top edge inwards and down: the
    top face's square, the chamfer's top circle, its bottom circle (the bore's top), the
    bore's bottom circle, and the bottom face's square."""
    angles = 2.0 * np.pi * np.arange(SEGMENTS) / SEGMENTS
    ray = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    square = ray * (BLOCK_HALF_WIDTH_M / np.max(np.abs(ray), axis=1))[:, None]
    profile = [  # (radial points, z)
        (square, 0.0),
        (ray * (HOLE_RADIUS_M + CHAMFER_M), 0.0),
        (ray * HOLE_RADIUS_M, -CHAMFER_M),
        (ray * HOLE_RADIUS_M, -BLOCK_HEIGHT_M),
        (square, -BLOCK_HEIGHT_M),
    ]
    return np.array([np.column_stack([xy, np.full(SEGMENTS, z)]) for xy, z in profile])


def triangles() -> list[tuple[int, int, int]]:
    """Vertex indices (0-based, ring-major) of the closed surface: each pair of successive
    rings joined by quads, the last ring joined back to the first (the outer wall)."""
    faces = []
    count = 5
    for ring in range(count):
        nxt = (ring + 1) % count
        for k in range(SEGMENTS):
            k1 = (k + 1) % SEGMENTS
            a, b = ring * SEGMENTS + k, ring * SEGMENTS + k1
            c, d = nxt * SEGMENTS + k1, nxt * SEGMENTS + k
            faces += [(a, c, d), (a, b, c)]
    return faces


def signed_volume(vertices: np.ndarray, faces: list) -> float:
    """The enclosed volume [m^3], positive for outward normals (divergence theorem)."""
    v = vertices[np.array(faces)]
    return float(np.sum(np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2]))) / 6.0)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=ROOT / "models" / "peg_fixture.obj")
    args = parser.parse_args()
    vertices = rings().reshape(-1, 3)
    faces = triangles()
    volume = signed_volume(vertices, faces)
    if volume <= 0:
        raise SystemExit(f"the faces wind inwards (volume {volume:g} m^3)")
    lines = ["# hlcmp-drake peg-in-hole fixture: scripts/make_peg_fixture.py"]
    lines += [f"v {x:.7f} {y:.7f} {z:.7f}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    args.out.write_text("\n".join(lines) + "\n")
    print(f"wrote {len(vertices)} vertices, {len(faces)} triangles, {volume * 1e6:.2f} cm^3")


if __name__ == "__main__":
    main()
