"""Variants of a loaded scenario that swap a model for another."""

import dataclasses as dc

import numpy as np
import yaml
from pydrake.common.schema import Transform
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import AddModel, AddWeld, ModelDirective

from hlcmp_drake.config.loading import dump_scenario
from hlcmp_drake.config.scenario import Scenario
from hlcmp_drake.io.errors import InputError

OWN_IIWA = "package://hlcmp_drake/models/iiwa14.sdf"
DRAKE_MODELS_IIWA = "package://drake_models/iiwa_description/sdf/iiwa14_no_collision.sdf"
FLANGE_OFFSET_M = 0.045  # our model's "flange" frame, along link 7's +z


def use_drake_models_iiwa(scenario: Scenario) -> Scenario:
    """The same scenario with Drake's official iiwa14 in place of ours.

    The official model comes from drake_models, which Drake downloads on first use (needs
    internet). Its links have the same names; it has no "flange" frame, so welds to
    iiwa::flange go to iiwa::iiwa_link_7 + 0.045 m (FLANGE_OFFSET_M) along its +z.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario; it is not modified.

    Returns
    -------
    Scenario
        A new Scenario with a new directives list; its other fields are shared with
        `scenario`, not copied.

    Raises
    ------
    InputError
        When the scenario has no iiwa of ours to swap (the 1-DOF slider): the option only
        applies to arm scenarios.
    """
    if not any(
        d.add_model is not None and d.add_model.file == OWN_IIWA for d in scenario.directives
    ):
        raise InputError(
            f"--iiwa drake_models: only applies to arm scenarios (with {OWN_IIWA}, e.g. "
            f"insertion, cutting); '{scenario.name}' has no iiwa"
        )
    directives = []
    for directive in scenario.directives:
        model, weld = directive.add_model, directive.add_weld
        if model is not None and model.file == OWN_IIWA:
            directive = ModelDirective(
                add_model=AddModel(
                    file=DRAKE_MODELS_IIWA,
                    name=model.name,
                    default_joint_positions=model.default_joint_positions,
                    default_free_body_pose=model.default_free_body_pose,
                )
            )
        elif weld is not None and weld.parent.endswith("::flange"):
            x_pc = weld.X_PC.GetDeterministicValue() if weld.X_PC is not None else RigidTransform()
            # pydrake's stubs spell a 3-vector as ndarray[float64]; numpy's arrays are generic.
            flange_offset = RigidTransform(p=np.array([0.0, 0.0, FLANGE_OFFSET_M]))  # type: ignore[arg-type]
            directive = ModelDirective(
                add_weld=AddWeld(
                    parent=weld.parent[: -len("flange")] + "iiwa_link_7",
                    child=weld.child,
                    X_PC=Transform(flange_offset @ x_pc),
                )
            )
        directives.append(directive)
    return dc.replace(scenario, directives=directives)


def _flat_values(node: yaml.Node, prefix: str, out: dict[str, object]) -> None:
    """`out[dotted key] = value` for every leaf of a composed YAML document; a tagged
    mapping (a task's or a controller's class) also records its tag at its own key, and a
    list of plain values is one value."""
    if isinstance(node, yaml.MappingNode):
        if node.tag.startswith("!"):
            out[prefix] = node.tag
        for key, value in node.value:
            _flat_values(value, f"{prefix}.{key.value}" if prefix else key.value, out)
    elif isinstance(node, yaml.SequenceNode):
        if all(isinstance(item, yaml.ScalarNode) for item in node.value):
            out[prefix] = tuple(item.value for item in node.value)
        else:
            for k, item in enumerate(node.value):
                _flat_values(item, f"{prefix}.{k}", out)
    else:
        out[prefix] = node.value


def changed_keys(scenario: Scenario, varied: Scenario) -> list[str]:
    """The dotted keys whose values differ between a scenario and the same scenario under
    a variant (its `name` aside, which a variant always changes), e.g.
    ["controllers.const_500.stiffness_N_per_m", "robot_imperfection.seed"].

    Parameters
    ----------
    scenario : Scenario
        As loaded without the variant.
    varied : Scenario
        As loaded with it.

    Returns
    -------
    list of str
        Sorted; a key only one of them has (a controller the variant adds) is among them.
    """
    # Compared as written out, so that any two values a run could tell apart differ here.
    flat: list[dict[str, object]] = [{}, {}]
    for values, loaded in zip(flat, (scenario, varied)):
        _flat_values(yaml.compose(dump_scenario(loaded)), "", values)
        values.pop("name", None)
    before, after = flat
    return sorted(key for key in before.keys() | after.keys() if before.get(key) != after.get(key))
