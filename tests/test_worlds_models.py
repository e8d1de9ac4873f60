"""hlcmp_drake.worlds.models: Drake's loading errors in one line."""

from hlcmp_drake.worlds.models import drake_error_line

OFFLINE = (
    "PackageMap: when downloading 'drake_models', the downloader experienced an error: All "
    "downloads failed:\n\nCandidate https://github.com/RobotLocomotion/models/archive/abc.tar.gz "
    "failed:\n<urlopen error [Errno -2] Name or service not known>\n\nCandidate "
    "https://drake-mirror.csail.mit.edu/abc.tar.gz failed:\n<urlopen error [Errno -2] Name or "
    "service not known>\n"
)


def test_a_failed_download_ends_with_its_reason_not_a_colon():
    line = drake_error_line(RuntimeError(OFFLINE))
    assert "\n" not in line and line.startswith("PackageMap: when downloading 'drake_models'")
    assert line.endswith(
        "All downloads failed: 2 candidates, the first "
        "(https://github.com/RobotLocomotion/models/archive/abc.tar.gz) with "
        "<urlopen error [Errno -2] Name or service not known>"
    )


def test_other_errors_keep_their_first_line_and_what_a_colon_announces():
    assert drake_error_line(RuntimeError("bad file\nmore detail")) == "bad file"
    assert drake_error_line(RuntimeError("could not parse:\n\n  line 3: x\n")) == (
        "could not parse: line 3: x"
    )
    assert drake_error_line(RuntimeError("")) == "RuntimeError"
