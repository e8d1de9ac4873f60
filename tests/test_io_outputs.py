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
