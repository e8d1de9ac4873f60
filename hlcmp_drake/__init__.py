"""hlcmp-drake: human-like compliant movement primitives (Hl-CMPs, Zeng et al., IEEE TII
2022) on Drake.

What a script needs, from one place::

    from hlcmp_drake import load_scenario, diagram_factory, simulate

    scenario, _ = load_scenario("insertion", ["duration_s=4"])
    build = diagram_factory(scenario)            # fits the DMP, solves the start posture
    run = simulate(build("hlcmp"), scenario, "hlcmp")
    print(run.series["Ks"][-1])                   # learned stiffness at the end [N/m]

Names are imported on first use, so `import hlcmp_drake.core.dmp` (pure numpy) does not
pull in Drake. The package's layers, each importing only from those before it:
core -> io -> config -> systems -> worlds -> experiments -> present -> run -> cli.
"""

import importlib

# The one place the version is written: pyproject.toml reads it from here
# ([tool.setuptools.dynamic]), and `hlcmp --version` prints it.
__version__ = "0.1.0"

# public name -> the module that defines it
_EXPORTS = {
    # the numpy core
    "Dmp": "hlcmp_drake.core.dmp",
    "DmpSettings": "hlcmp_drake.core.dmp",
    "OrientationDmp": "hlcmp_drake.core.orientation_dmp",
    "HlcmpLaw": "hlcmp_drake.core.laws",
    "HlcmpForgettingLaw": "hlcmp_drake.core.laws",
    "ConstantImpedanceLaw": "hlcmp_drake.core.laws",
    # files
    "InputError": "hlcmp_drake.io.errors",
    "read_demonstration": "hlcmp_drake.io.demos",
    "Skill": "hlcmp_drake.io.skill",
    "load_skill": "hlcmp_drake.io.skill",
    "save_skill": "hlcmp_drake.io.skill",
    "RunResult": "hlcmp_drake.io.runs",
    # configuration
    "Scenario": "hlcmp_drake.config.scenario",
    "HlcmpConfig": "hlcmp_drake.config.scenario",
    "HlcmpForgettingConfig": "hlcmp_drake.config.scenario",
    "ConstantImpedanceConfig": "hlcmp_drake.config.scenario",
    "VariableImpedanceConfig": "hlcmp_drake.config.scenario",
    "PoseHlcmpConfig": "hlcmp_drake.config.scenario",
    "ConstantPoseImpedanceConfig": "hlcmp_drake.config.scenario",
    "load_scenario": "hlcmp_drake.config.loading",
    # Drake systems
    "DmpSource": "hlcmp_drake.systems.references",
    "linear_dmp_source": "hlcmp_drake.systems.references",
    "StepReference": "hlcmp_drake.systems.references",
    "LawController": "hlcmp_drake.systems.law_controller",
    "HlcmpGains": "hlcmp_drake.core.laws",
    "VariableImpedanceController": "hlcmp_drake.systems.baselines",
    "TaskSpaceDynamics": "hlcmp_drake.systems.task_space",
    "TaskForceToJointTorque": "hlcmp_drake.systems.task_space",
    "NullSpaceImpedance": "hlcmp_drake.systems.arm",
    "ToolContactForce": "hlcmp_drake.systems.arm",
    "ControlLoop": "hlcmp_drake.systems.control_loop",
    "ControlTick": "hlcmp_drake.systems.control_loop",
    "SafetyMonitor": "hlcmp_drake.systems.monitor",
    # building and running diagrams
    "diagram_factory": "hlcmp_drake.worlds.build",
    "BuiltDiagram": "hlcmp_drake.worlds.common",
    "add_controller": "hlcmp_drake.worlds.controllers",
    "CONTROLLER_KINDS": "hlcmp_drake.worlds.controllers",
    "simulate": "hlcmp_drake.run.simulate",
    "run_scenario": "hlcmp_drake.run.runner",
    "learn": "hlcmp_drake.run.learning",
    "reproduce": "hlcmp_drake.run.learning",
    # skill libraries: a skill per task parameter, regressed to new ones
    "build_library": "hlcmp_drake.run.library",
    "SkillLibrary": "hlcmp_drake.run.skill_library",
    # a real (or simulated) iiwa over LCM
    "TorqueClient": "hlcmp_drake.run.serve",
    "serve_scenario": "hlcmp_drake.run.serve",
    "SimulatedIiwaDriver": "hlcmp_drake.run.sim_driver",
    "EXPERIMENTS": "hlcmp_drake.experiments",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(_EXPORTS[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'hlcmp_drake' has no attribute '{name}'")


def __dir__():
    return sorted(set(globals()) | set(__all__))
