"""Writing results so that nothing already in the output folder is lost or half-written:
every file goes to a temporary name in the same folder and is moved into place."""

import json
import os
import tempfile
from pathlib import Path

import numpy as np


_UMASK = os.umask(0)
os.umask(_UMASK)
WRITTEN = []   # every path written in this process, in order (for the interrupt message)


def atomic_write(path, write):
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(handle)
    try:
        write(temp)
        os.chmod(temp, 0o666 & ~_UMASK)  # mkstemp makes 0600; results are for sharing
        os.replace(temp, path)
        WRITTEN.append(path)
    except BaseException:
        Path(temp).unlink(missing_ok=True)
        raise
    return path


def write_json(path, data):
    def write(temp):
        with open(temp, "w") as stream:
            json.dump(data, stream, indent=2, sort_keys=False)
            stream.write("\n")
    return atomic_write(path, write)


def write_npz(path, arrays):
    def write(temp):
        with open(temp, "wb") as stream:
            np.savez_compressed(stream, **arrays)
    return atomic_write(path, write)


def save_figure(path, figure):
    import matplotlib.pyplot as plt

    def write(temp):
        figure.savefig(temp, format=Path(path).suffix.lstrip(".") or "png", dpi=110)
    try:
        return atomic_write(path, write)
    finally:
        plt.close(figure)


def write_text(path, text):
    def write(temp):
        Path(temp).write_text(text)
    return atomic_write(path, write)


def write_diagram_graph(out_dir, diagram):
    """The wired diagram as Drake draws it (GetGraphvizString): diagram.svg where Graphviz's
    `dot` is installed, else diagram.dot. Returns the path written."""
    import shutil
    import subprocess

    dot = diagram.GetGraphvizString(max_depth=1)
    if shutil.which("dot"):
        svg = subprocess.run(["dot", "-Tsvg"], input=dot, capture_output=True, text=True, check=True)
        return write_text(Path(out_dir) / "diagram.svg", svg.stdout)
    return write_text(Path(out_dir) / "diagram.dot", dot)
