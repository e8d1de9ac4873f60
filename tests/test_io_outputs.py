"""hlcmp_drake.io.outputs: output paths checked before any work is done, and atomic writes."""

import os
import re

import pytest

from hlcmp_drake.io import outputs
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.outputs import check_output_file, check_output_folder


def test_output_folders_that_can_be_written_pass_and_nothing_is_created(tmp_path):
    assert check_output_folder(tmp_path) == tmp_path  # exists: its files are replaced
    new = tmp_path / "a" / "b"
    assert check_output_folder(new) == new and not (tmp_path / "a").exists()
    assert check_output_file(tmp_path / "c" / "skill.npz").name == "skill.npz"
    (tmp_path / "old.npz").write_bytes(b"x")
    check_output_file(tmp_path / "old.npz")  # an existing file is replaced
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.npz"]  # the probe file is gone


def test_a_file_where_a_folder_is_needed_and_the_reverse(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("keep")
    with pytest.raises(InputError, match=r"^--out .*a_file: is a file, not a folder$"):
        check_output_folder(blocker)
    with pytest.raises(
        InputError, match=rf"^--out .*: {re.escape(str(blocker))} is a file, not a folder$"
    ):
        check_output_folder(blocker / "sub" / "deeper")
    with pytest.raises(InputError, match=rf"{re.escape(str(blocker))} is a file, not a folder"):
        check_output_file(blocker / "skill.npz")
    with pytest.raises(InputError, match="is a folder, not a file"):
        check_output_file(tmp_path)
    with pytest.raises(InputError, match="is a folder, not a file"):
        check_output_file(f"{tmp_path / 'new'}/")
    assert blocker.read_text() == "keep"


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux's /proc")
def test_a_folder_nobody_can_write_in_is_refused():
    with pytest.raises(InputError, match=r"cannot write in /proc \("):
        check_output_folder("/proc/hlcmp_out")


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root may write anywhere")
def test_a_read_only_parent_is_refused(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        with pytest.raises(InputError, match="cannot write in"):
            check_output_folder(locked / "out")
    finally:
        locked.chmod(0o700)


def test_atomic_write_replaces_whole_or_not_at_all(tmp_path):
    path = tmp_path / "deep" / "metrics.json"
    outputs.write_json(path, {"a": 1})
    assert path.read_text() == '{\n  "a": 1\n}\n'
    assert oct(path.stat().st_mode & 0o777) == oct(0o666 & ~outputs._UMASK)

    def broken(temp):
        with open(temp, "w") as stream:
            stream.write("half")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError):
        outputs.atomic_write(path, broken)
    assert path.read_text() == '{\n  "a": 1\n}\n'  # the old file is intact
    assert os.listdir(path.parent) == ["metrics.json"]  # no temporary left behind


def _manifest(folder):
    import json

    return json.loads((folder / outputs.MANIFEST).read_text())["files"]


def test_a_reused_folder_keeps_only_the_listed_files_the_last_command_wrote(tmp_path):
    with outputs.replacing_outputs(tmp_path):  # the first command: an insertion's files
        outputs.write_text(tmp_path / "metrics.json", "{}")
        outputs.write_text(tmp_path / "figures" / "fig4_profiles_z.png", "png")
        outputs.write_text(tmp_path / "skill.npz", "npz")
    assert _manifest(tmp_path) == ["figures/fig4_profiles_z.png", "metrics.json", "skill.npz"]
    (tmp_path / "notes.txt").write_text("mine")  # the user's, whatever the names
    (tmp_path / "figures" / "mine.png").write_text("mine")
    (tmp_path / "timeseries.npz").write_text("a file of ours the manifest does not list")
    with outputs.replacing_outputs(tmp_path):  # the second command writes less
        outputs.write_text(tmp_path / "metrics.json", "{}")
    files = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*"))
    assert files == [
        outputs.MANIFEST,
        "figures",
        "figures/mine.png",
        "metrics.json",
        "notes.txt",
        "timeseries.npz",
    ]
    assert _manifest(tmp_path) == ["metrics.json"]
    with outputs.replacing_outputs(tmp_path):
        outputs.write_text(tmp_path / "figures" / "one_dof.png", "png")
    with outputs.replacing_outputs(tmp_path):
        outputs.write_text(tmp_path / "metrics.json", "{}")
    (tmp_path / "figures" / "mine.png").unlink()
    with outputs.replacing_outputs(tmp_path):  # figures/ was left empty by the next removal
        outputs.write_text(tmp_path / "figures" / "a.png", "png")
    with outputs.replacing_outputs(tmp_path):
        outputs.write_text(tmp_path / "metrics.json", "{}")
    assert not (tmp_path / "figures").exists()


def test_a_failed_command_removes_nothing_and_lists_old_and_new(tmp_path):
    with outputs.replacing_outputs(tmp_path):
        outputs.write_text(tmp_path / "old.png", "png")
    with pytest.raises(KeyboardInterrupt), outputs.replacing_outputs(tmp_path):
        outputs.write_text(tmp_path / "new.json", "{}")
        raise KeyboardInterrupt
    assert (tmp_path / "old.png").exists()
    assert _manifest(tmp_path) == ["new.json", "old.png"]
    with outputs.replacing_outputs(tmp_path):  # a command that writes nothing removes nothing
        pass
    assert (tmp_path / "old.png").exists()


def test_only_regular_files_inside_the_folder_are_removed_and_kept_inputs_stay(tmp_path):
    import json

    out, outside = tmp_path / "out", tmp_path / "outside"
    outside.mkdir()
    (outside / "precious.txt").write_text("mine")
    (outside / "x.png").write_text("mine")
    out.mkdir()
    (out / "link.txt").symlink_to(outside / "precious.txt")
    (out / "figures").symlink_to(outside)
    (out / "skill.npz").write_text("the input")
    listed = ["../outside/precious.txt", str(outside / "precious.txt"), "link.txt"]
    listed += ["figures/x.png", "skill.npz"]
    (out / outputs.MANIFEST).write_text(json.dumps({"tool": "hlcmp", "files": listed}))
    with outputs.replacing_outputs(out, keep=[out / "skill.npz"]):
        outputs.write_text(out / "metrics.json", "{}")
    assert (outside / "precious.txt").read_text() == "mine" and (outside / "x.png").exists()
    assert (out / "link.txt").is_symlink() and (out / "skill.npz").exists()
    (out / outputs.MANIFEST).write_text(json.dumps({"tool": "other", "files": ["metrics.json"]}))
    with outputs.replacing_outputs(out):  # not this tool's list: nothing is ours
        outputs.write_text(out / "a.json", "{}")
    assert (out / "metrics.json").exists()


def test_listing_a_commands_own_files_removes_what_it_listed_before_alone(tmp_path):
    """A sweep lists its tables and plots, not its tasks' folders: the next list removes
    the files of the last that it does not name, and nothing else."""
    folder = tmp_path / "sweep"
    old = [outputs.write_text(folder / name, name) for name in ("t.csv", "plots/a.png")]
    outputs.write_text(folder / "tasks" / "x" / "metrics.json", "{}")
    (folder / "plots" / "mine.png").write_text("mine")
    outputs.list_outputs(folder, [*old, tmp_path / "elsewhere.csv"])
    assert outputs.listed_outputs(folder) == {"t.csv", "plots/a.png"}
    outputs.list_outputs(folder, [outputs.write_text(folder / "plots" / "b.png", "b"), old[0]])
    assert outputs.listed_outputs(folder) == {"t.csv", "plots/b.png"}
    assert not (folder / "plots" / "a.png").exists()
    assert (folder / "plots" / "mine.png").is_file()
    assert (folder / "tasks" / "x" / "metrics.json").is_file()
