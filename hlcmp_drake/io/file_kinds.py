"""What kind of the project's files a file is, told from its first bytes or its keys, so
that a file given to the wrong command is named as what it is: a scenario, sweep or
library YAML, a skill or a run's timeseries (.npz), a metrics.json, a demonstration CSV."""

from __future__ import annotations

import re

# The top-level keys that only one kind of the project's YAML files has, and the command
# that takes that kind.
FILE_KINDS = {
    "scenario": ({"directives", "plant_config", "simulator_config", "task"}, "hlcmp run"),
    "sweep": ({"metrics", "cases", "repetitions", "labels"}, "hlcmp sweep"),
    "library": ({"trials", "demo_force"}, "hlcmp library"),
}
ZIP_MAGIC = (b"PK\x03\x04", b"PK\x05\x06")  # a .npz is a zip archive


def top_level_keys(text: str) -> set[str]:
    """The keys at the start of a line of a YAML text (its top-level mapping's).

    Parameters
    ----------
    text : str

    Returns
    -------
    set of str
    """
    return set(re.findall(r"^([A-Za-z_]\w*)[ \t]*:", text, flags=re.MULTILINE))


def yaml_kind(text: str) -> str | None:
    """Which of FILE_KINDS a YAML text is, by the keys only that kind has; None for none
    or more than one.

    Parameters
    ----------
    text : str

    Returns
    -------
    str or None
    """
    keys = top_level_keys(text)
    kinds = [kind for kind, (marks, _) in FILE_KINDS.items() if keys & marks]
    return kinds[0] if len(kinds) == 1 else None


def what_it_is(head: bytes) -> str | None:
    """A phrase naming one of the project's files from its first bytes (up to a few KB):
    "an .npz archive (a skill, or a run's timeseries)", "a scenario file (give it to hlcmp
    run, or as --scenario)", "a JSON file (a run's metrics.json?)", "a demonstration CSV
    (hlcmp fit makes a skill of it)"; None when it is none of these.

    Parameters
    ----------
    head : bytes
        The file's first bytes.

    Returns
    -------
    str or None
    """
    if head[:4] in ZIP_MAGIC:
        return "an .npz archive (a skill, which hlcmp reproduce replays, or a run's timeseries.npz)"
    text = head.decode("utf-8", errors="ignore").lstrip("\ufeff")
    kind = yaml_kind(text)
    if kind is not None:
        where = ", or as --scenario" if kind == "scenario" else ""
        return f"a {kind} file (give it to {FILE_KINDS[kind][1]}{where})"
    first = next((line.strip() for line in text.splitlines() if line.strip()), "")
    if first.startswith(("{", "[")):
        return "a JSON file (a run's metrics.json?)"
    columns = [name.strip().lstrip("#").strip() for name in first.split(",")]
    if len(columns) > 1 and columns[0] == "t":
        return "a demonstration CSV (hlcmp fit makes a skill of it)"
    return None
