"""hlcmp_drake.config.shapes: a value whose YAML shape does not fit its field's type is found
at its line and key; every bundled file fits (nothing valid is refused)."""

import dataclasses as dc

import pytest
from pydrake.common.yaml import yaml_load_typed

from hlcmp_drake.config.loading import check_unique_keys, load_scenario
from hlcmp_drake.config.scenario import Scenario
from hlcmp_drake.config.shapes import misshapen_value
from hlcmp_drake.io.paths import DIAGRAMS_DIR


@dc.dataclass
class _Gains:
    q: list[float] = dc.field(default_factory=list)
    x: float = 0.0
    n: int = 1
    label: str | None = None


@pytest.mark.parametrize(
    "text, found",
    [
        ("q: [1, 2.5]\nx: 3\nn: 2\nlabel: a", None),
        ("x: 1e-3\nq: ['0.5', .inf]\nlabel: null", None),  # numbers as Drake reads them
        ("n: 10.0", None),  # a whole float: Drake's loader takes it for an integer
        ("n: .inf", (1, "n", "must be an integer, got .inf")),
        ("q: '300'", (1, "q", "must be a list, got '300'")),
        ("x: 1\nq: [1, [2]]", (2, "q.1", "must be a number, got a list")),
        ("n: 2.5", (1, "n", "must be an integer, got 2.5")),
        ("x: {a: 1}", (1, "x", "must be a number, got a map")),
        ("label: [a]", (1, "label", "must be text, got a list")),
        ("n: 1e3", (1, "n", "must be an integer in digits, got '1e3'")),  # Drake: int('1e3')
        ("label: 3", (1, "label", "must be text, got 3")),  # Drake reads no number as text
        ("q:", (1, "q", "must be a list, got nothing")),
        ("q: [1, 2", None),  # no YAML: the loader's own message says where
    ],
)
def test_a_misshapen_value_is_found_at_its_line(text, found):
    assert misshapen_value(text, _Gains) == found


def test_drake_reads_text_for_a_list_of_numbers_one_character_a_number():
    """Why the shapes are checked before Drake's loader, not only after it refuses."""
    assert yaml_load_typed(schema=_Gains, data="q: '300'").q == [3.0, 0.0, 0.0]


@pytest.mark.parametrize("path", sorted(DIAGRAMS_DIR.glob("*.yaml")), ids=lambda p: p.stem)
def test_every_bundled_scenario_fits_its_types(path):
    assert misshapen_value(path.read_text(), Scenario) is None
    load_scenario(path)


@pytest.mark.parametrize("path", sorted((DIAGRAMS_DIR / "variants").glob("*.yaml")), ids=str)
def test_every_bundled_variant_fits_its_types(path):
    assert misshapen_value(path.read_text(), Scenario) is None


@dc.dataclass
class _Soft:
    k: float = 1.0


@dc.dataclass
class _Stiff:
    k: float = 2.0


@dc.dataclass
class _Controllers:
    controllers: dict[str, _Soft | _Stiff] = dc.field(default_factory=dict)


@pytest.mark.parametrize(
    "text, found",
    [
        ("controllers:\n  a: !_Stiff {k: 3}\n  b: !_Soft {}", None),
        (
            "controllers:\n  a: !_Stiff {k: [3]}",
            (2, "controllers.a.k", "must be a number, got a list"),
        ),
        (
            "controllers:\n  a: !_Stif {}",
            (2, "controllers.a", "!_Stif is none of !_Soft, !_Stiff (did you mean !_Stiff?)"),
        ),
        ("controllers:\n  a: !Pid {}", (2, "controllers.a", "!Pid is none of !_Soft, !_Stiff")),
        ("controllers:\n  a: 5", (2, "controllers.a", "must be a map of fields, got 5")),
    ],
)
def test_a_tagged_value_is_checked_as_its_tag_says(text, found):
    assert misshapen_value(text, _Controllers) == found


def test_an_alias_within_itself_or_aliases_of_aliases_end_quickly():
    """Each node is walked once: an alias in itself would loop, ten aliases of ten aliases
    eight deep would be 10^8 walks."""
    assert misshapen_value("q: &r [1, *r]", _Gains) is None  # left to the loader's message
    levels = ["a0: &a0 [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]"]
    levels += [f"a{k}: &a{k} [" + ", ".join([f"*a{k - 1}"] * 10) + "]" for k in range(1, 9)]
    check_unique_keys("f.yaml", "\n".join(levels) + "\nb: &b {c: *b}\n")


@pytest.mark.parametrize(
    "text, found",
    [
        ("plant_config:\n  time_step: 0.002\n  contact_model: point", None),
        (
            "plant_config:\n  time_step: fast",
            (2, "plant_config.time_step", "must be a number, got 'fast'"),
        ),
        (
            "plant_config:\n  contact_model:",
            (2, "plant_config.contact_model", "must be text, got nothing"),
        ),
        (
            "simulator_config: {publish_every_time_step: maybe}",
            (1, "simulator_config.publish_every_time_step", "must be true or false, got 'maybe'"),
        ),
        (
            "plant_config:\n  timestep: 0.001",
            (
                2,
                "plant_config.timestep",
                "no such field in MultibodyPlantConfig (did you mean 'time_step'?)",
            ),
        ),
        (
            "directives:\n- add_model: {file: 3, name: a}",
            (2, "directives.0.add_model.file", "must be text, got 3"),
        ),
    ],
)
def test_drakes_own_schema_classes_are_checked_by_their_fields(text, found):
    """MultibodyPlantConfig, SimulatorConfig and the model directives name their fields in
    `__fields__`, which pydrake's loader reads: checked as a dataclass's are, so that their
    mistakes read as the scenario's own (Drake's loader says "Expected a <class 'float'>
    value for 'time_step' but instead got yaml data of type <class 'NoneType'>")."""
    assert misshapen_value(text, Scenario) == found


_FRAME = "directives:\n- add_frame:\n    name: f\n    X_PF:\n      base_frame: world\n"


@pytest.mark.parametrize(
    "value",
    [
        "translation: !DeterministicVector {value: [0.1, 0.2, 0.3]}",
        "translation: !GaussianVector {mean: [0, 0, 0], stddev: [0.1, 0.1, 0.1]}",
        "translation: !UniformVector {min: [0, 0, 0], max: [0.1, 0.1, 0.1]}",
        "rotation: !Rpy {deg: !DeterministicVector {value: [0, 0, 90]}}",
    ],
)
def test_a_drake_template_class_is_tagged_as_drakes_loader_names_it(value):
    """Drake's loader matches a tag against a template class's name without its
    arguments (DeterministicVector, not the class's own __name__,
    'DeterministicVector𝓣3𝓤'): a tag Drake takes is no misshapen value."""
    text = _FRAME + f"      {value}\n"
    yaml_load_typed(schema=Scenario, data=text)  # Drake's loader takes it
    assert misshapen_value(text, Scenario) is None


def test_a_misspelled_drake_template_tag_is_named_as_drake_spells_the_tag():
    text = _FRAME + "      translation: !DeterministicVectr {value: [0, 0, 0]}\n"
    line, key, problem = misshapen_value(text, Scenario)
    assert (line, key) == (6, "directives.0.add_frame.X_PF.translation")
    assert problem.endswith("(did you mean !DeterministicVector?)")
    assert "𝓣" not in problem


@pytest.mark.parametrize(
    "text",
    [
        # a model's free-body poses (a map of Drake's Transform), some merged from an anchor
        "directives:\n- add_model:\n    name: m\n    file: package://x/m.sdf\n"
        "    default_free_body_pose:\n"
        "      <<: {base: {base_frame: world, translation: [1, 0, 0]}}\n"
        "      top: {translation: [0, 0, 1]}\n",
        # controllers (a map of tagged configs) merged from an anchor
        "_c: &c {soft: !ConstantImpedanceConfig {}}\ncontrollers:\n  <<: *c\n",
    ],
)
def test_a_merge_key_in_a_map_is_no_entry_of_it(text):
    """`<<: *anchor` in a map field merges the anchor's entries into the map, as YAML reads
    it (and Drake's loader with it): the merged map is no entry of the field's type."""
    yaml_load_typed(schema=Scenario, data=text)  # Drake's loader takes it
    assert misshapen_value(text, Scenario, skip=("_c",)) is None


def test_a_documents_underscore_keys_hold_anchors_as_drakes_loader_reads_them(tmp_path):
    """Drake's loader ignores a document's top-level keys that start with `_` (where
    anchors are kept); below the top such a key is a field like any other."""
    anchored = "_step: &step {time_step: 0.002}\nplant_config:\n  <<: *step\n"
    assert misshapen_value(anchored, Scenario) is None
    assert misshapen_value("plant_config:\n  _step: 0.002", Scenario) == (
        2,
        "plant_config._step",
        "no such field in MultibodyPlantConfig (did you mean 'time_step'?)",
    )
    text = (DIAGRAMS_DIR / "one_dof.yaml").read_text()
    path = tmp_path / "anchored.yaml"
    path.write_text(
        text.replace(
            "plant_config:\n", "_kept: &kept {time_step: 1.0e-3}\nplant_config:\n  <<: *kept\n", 1
        ).replace("  time_step: 0.001", "", 1)
    )
    assert load_scenario(path)[0].plant_config.time_step == 0.001  # the anchor's
