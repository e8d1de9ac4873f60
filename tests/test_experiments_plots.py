"""hlcmp_drake.experiments.plots: figures made without pyplot and saved as PNG."""

from hlcmp_drake.experiments.plots import bar_chart, new_figure
from hlcmp_drake.io import outputs


def test_figures_are_made_without_pyplot_and_saved_as_png(tmp_path):
    figure, axes = new_figure(2, 3, size=(6, 4))
    assert len(axes) == 6
    chart = bar_chart({"a": [1, 2, 3], "b": [3, 2, 1]}, ("x", "y", "z"), "value")
    assert [t.get_text() for t in chart.axes[0].get_xticklabels()] == ["x axis", "y axis", "z axis"]
    path = outputs.save_figure(tmp_path / "figures" / "chart.png", chart)
    assert path.read_bytes()[:4] == b"\x89PNG"


def test_each_controller_gets_the_colour_of_its_place():
    from hlcmp_drake.experiments.plots import controller_colors

    colours = controller_colors([f"c{k}" for k in range(11)])
    assert colours["c0"] == "#1f77b4" and colours["c1"] == "#ff7f0e"  # C0, C1
    assert len(set(colours.values())) == 10 and colours["c10"] == colours["c0"]
