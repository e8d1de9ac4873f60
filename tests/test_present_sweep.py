"""hlcmp_drake.present.sweep: the sweep table shows values as the README does."""

from hlcmp_drake.present.sweep import parameter_number, parameter_text, sweep_table
from hlcmp_drake.present.tables import to_markdown


def test_the_table_shows_values_as_the_readme_does():
    summary = {
        "repetitions": 1,
        "parameters": [
            {"key": "dmp.n_basis", "label": "N"},
            {"key": "controllers.hlcmp.gain_l", "label": "L"},
        ],
        "metrics": [
            {"label": "x [m]", "digits": 4, "missing": "n/a", "yes_no": False},
            {"label": "reach [s]", "digits": 2, "missing": "never", "yes_no": False},
            {"label": "C4", "digits": 2, "missing": "n/a", "yes_no": False},
        ],
        "tasks": [
            {
                "id": "a",
                "parameters": {"dmp.n_basis": "2", "controllers.hlcmp.gain_l": "[10.0]"},
                "repetition": 1,
                "status": "ok",
                "values": {"x [m]": -0.11163, "reach [s]": None, "C4": True},
            },
            {
                "id": "b",
                "parameters": {"dmp.n_basis": "30", "controllers.hlcmp.gain_l": "[1.0]"},
                "repetition": 1,
                "status": "pending",
                "values": {},
            },
        ],
    }
    assert to_markdown(sweep_table(summary), code_first_column=False) == (
        "| N | L | x [m] | reach [s] | C4 |\n|---|---|---|---|---|\n"
        "| 2 | 10 | -0.1116 | never | yes |\n"
    )
    summary["tasks"][1].update(status="unstable", values={"x [m]": 3.0})
    assert sweep_table(summary).rows[1] == ["30", "1", "3.0000", "never", "n/a", "unstable"]
    assert parameter_number("[3.0, 3.0]") == 3.0 and parameter_number("[1, 2]") is None
    assert parameter_text("abc") == "abc" and parameter_text("1.0e-3") == "0.001"
    # YAML 1.1 (PyYAML) reads an exponent without its sign as text; Drake reads a number.
    assert parameter_text("[1.0e7]") == "1e+07" and parameter_text("2e3") == "2000"
    assert parameter_number("[nan]") is None and parameter_number("[1.0e7, 2.0e7]") is None
