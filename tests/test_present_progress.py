"""hlcmp_drake.present.progress: progress lines only on a terminal."""

import io

from conftest import run_cli, short_one_dof

from hlcmp_drake.present.progress import Progress


def test_progress_only_on_a_terminal(tmp_path):
    class Terminal(io.StringIO):
        def isatty(self):
            return True

    terminal, pipe = Terminal(), io.StringIO()
    for stream in (terminal, pipe):
        progress = Progress(stream=stream)
        progress.step("hlcmp", 2.0, 9.5, 1.6)
        progress.say("hlcmp: done")
    assert "hlcmp:   2.0 / 9.5 s simulated (1.25x real time)" in terminal.getvalue()
    assert pipe.getvalue() == ""
    assert Progress(quiet=True, stream=Terminal()).enabled is False
    result = run_cli("run", *short_one_dof(1.0), "--out", tmp_path / "o")
    assert result.returncode == 0 and result.stderr == ""  # stderr is a pipe here
