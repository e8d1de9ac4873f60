"""Where a 1 ms step of an arm world alone goes, by phase (the breakdown behind
docs/performance.md, "The arm worlds' own cost").

    python scripts/world_cost.py [--world insertion|cutting] [--rounds 3]

The world is driven along the Hl-CMP run's own joint motion by Drake's C++
InverseDynamicsController (as `hlcmp bench`'s world-alone runs). Each variant removes one
piece; the variants run alternately, round after round, and each is timed in 10 ms
windows of AdvanceTo, classified as free motion or in contact by whether the tool touched
the object in the whole world's run (same joint motion, so the same windows). Printed:
µs of this process's CPU time per plant step (less moved by a shared machine's load than
the wall clock), median over the rounds, per phase. Then, at one state of each phase, the
plant's step split into the contact geometry query and the rest (SAP and dynamics).
"""

import argparse
import dataclasses as dc
import statistics
import time

import numpy as np
from pydrake.geometry import (
    CollisionFilterDeclaration,
    GeometrySet,
    HydroelasticContactRepresentation,
)

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.run.benchmark import joint_space_replay
from hlcmp_drake.run.simulate import prepared_simulator, simulate
from hlcmp_drake.worlds import arm
from hlcmp_drake.worlds.models import scoped_frame

WINDOW_S = 0.01


def _variants(scenario, setup, run, has_puncture):
    """name -> a function building that variant's BuiltDiagram, and whether its contact
    with the object is filtered from the start."""
    out = {
        "whole world, harnessed (monitor, sensor, loggers)": (
            lambda: joint_space_replay(scenario, setup, run, harness=True),
            False,
        ),
        "bare (no harness)": (
            lambda: joint_space_replay(scenario, setup, run, harness=False),
            False,
        ),
    }
    if has_puncture:
        without, _ = load_scenario(scenario.name, ["task.puncture.object_frame=''"])
        out["bare, no tear hook (Simulator monitor)"] = (
            lambda: dc.replace(
                joint_space_replay(scenario, setup, run, harness=False), after_step=None
            ),
            False,
        )
        out["bare, no foam system (neither Python call)"] = (
            lambda: joint_space_replay(without, setup, run, harness=False),
            False,
        )
    out["bare, tool-object contact filtered"] = (
        lambda: joint_space_replay(scenario, setup, run, harness=False),
        True,
    )
    return out


def _tool_and_rest(built, task):
    plant = built.plant
    inspector = _scene_graph(built).model_inspector()
    tool = plant.GetCollisionGeometriesForBody(scoped_frame(plant, task.tool_frame).body())
    rest = [g for g in inspector.GetAllGeometryIds() if g not in tool]
    return tool, rest


def _scene_graph(built):
    return next(s for s in built.diagram.GetSystems() if s.get_name() == "scene_graph")


def _timed_windows(built, scenario, filtered, contact_log=None):
    simulator = prepared_simulator(built, scenario)
    context = simulator.get_mutable_context()
    if filtered:
        scene_graph = _scene_graph(built)
        tool, rest = _tool_and_rest(built, scenario.task)
        scene_graph.collision_filter_manager(
            scene_graph.GetMyMutableContextFromRoot(context)
        ).Apply(CollisionFilterDeclaration().ExcludeBetween(GeometrySet(tool), GeometrySet(rest)))
    simulator.Initialize()
    plant_context = built.plant.GetMyContextFromRoot(context)
    walls = []
    for k in range(1, round(scenario.duration_s / WINDOW_S) + 1):
        start = time.process_time()
        simulator.AdvanceTo(k * WINDOW_S)
        walls.append(time.process_time() - start)
        if contact_log is not None:
            results = built.plant.get_contact_results_output_port().Eval(plant_context)
            contact_log.append(
                results.num_hydroelastic_contacts() + results.num_point_pair_contacts() > 0
            )
    return np.array(walls)


def _step_split(built, scenario, times):
    """At each time: µs of the contact geometry query and of the plant's whole discrete
    update (geometry, SAP, dynamics), each recomputed 300 times at that state."""
    simulator = prepared_simulator(built, scenario)
    context = simulator.get_mutable_context()
    plant = built.plant
    plant_context = plant.GetMyMutableContextFromRoot(context)
    scene_graph = _scene_graph(built)
    scene_graph_context = scene_graph.GetMyContextFromRoot(context)
    out = {}
    for t in times:
        simulator.AdvanceTo(t)
        q = plant.GetPositions(plant_context).copy()

        def geometry(q=q):
            plant.SetPositions(plant_context, q)  # invalidates the poses and what follows
            scene_graph.get_query_output_port().Eval(scene_graph_context).ComputeContactSurfaces(
                HydroelasticContactRepresentation.kPolygon
            )

        def step(q=q):
            plant.SetPositions(plant_context, q)
            plant.EvalUniquePeriodicDiscreteUpdate(plant_context)

        out[t] = {name: _per_call_us(f) for name, f in (("geometry", geometry), ("step", step))}
    return out


def _per_call_us(function, calls=300):
    function()
    start = time.process_time()
    for _ in range(calls):
        function()
    return 1e6 * (time.process_time() - start) / calls


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--world", choices=("insertion", "cutting"), default="insertion")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    scenario, _ = load_scenario(args.world, ["task.control_path=fast"])
    setup = arm.prepare(scenario)
    run = simulate(arm.build(scenario, "hlcmp", setup), scenario, "hlcmp")
    variants = _variants(scenario, setup, run, bool(scenario.task.puncture.object_frame))
    contact: list[bool] = []
    walls = {name: [] for name in variants}
    for round_ in range(args.rounds):
        for name, (make, filtered) in variants.items():
            log = contact if round_ == 0 and not walls[name] and not contact else None
            walls[name].append(_timed_windows(make(), scenario, filtered, log))
    in_contact = np.array(contact)
    step_us = 1e6 * scenario.plant_config.time_step / WINDOW_S
    print(
        f"{args.world}, world alone, {args.rounds} rounds: {in_contact.sum() * WINDOW_S:.2f} s "
        f"in contact, {(~in_contact).sum() * WINDOW_S:.2f} s free"
    )
    print("µs per 1 ms step (median over rounds): free | in contact | whole run")
    for name, rounds in walls.items():
        free = statistics.median(w[~in_contact].mean() for w in rounds) * step_us
        touching = statistics.median(w[in_contact].mean() for w in rounds) * step_us
        whole = statistics.median(w.mean() for w in rounds) * step_us
        print(f"  {name}: {free:.0f} | {touching:.0f} | {whole:.0f}")
    windows = np.flatnonzero(in_contact)
    free_t = WINDOW_S * (np.flatnonzero(~in_contact)[len(np.flatnonzero(~in_contact)) // 4] + 1)
    contact_t = WINDOW_S * (windows[len(windows) // 2] + 1)
    make, _ = variants["bare (no harness)"]
    for t, split in _step_split(make(), scenario, [free_t, contact_t]).items():
        phase = "in contact" if t == contact_t else "free"
        print(
            f"  plant step at t = {t:.2f} s ({phase}): {split['step']:.0f} µs, of which the "
            f"contact geometry query {split['geometry']:.0f} µs"
        )


if __name__ == "__main__":
    main()
