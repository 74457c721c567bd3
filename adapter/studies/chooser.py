"""No more model than the scene needs: the coarsest whale, the cheapest stable method and step.

Given a tolerance on the surface (m) -- for a coupled run a fraction of the flow mesh's cell
size at the whale, for a dry-run a stated tolerance -- and the largest step the consumer
allows (the flow time step, or the output frame interval), :func:`choose` keeps the surface
error under ``fraction`` x tolerance, half of it for the resolution and half for the time
step:

1. resolution: going up the candidate node counts, the error of a whale is estimated by its
   largest key-point difference (8 samples over one half-stroke) from every finer candidate
   (the procedural meshes do not converge monotonically: on the smoke whale 600 nodes differ
   from 1200 by 0.097 m but from 2400 by 0.129 m); the first whose estimate is under half
   the budget is taken;
2. method and step: per method, the time error at that resolution is estimated from two runs
   (dt and dt/2, Richardson with the method's order); the step is the largest that meets the
   budget, at most ``safety`` x the predicted stable step and at most the consumer's step, and
   a whole fraction of the quarter stroke; the method with the fewest force evaluations over
   the run wins.

Every choice can be fixed by the user (``nodes=``, ``method=``, ``dt=``); the report says
what was chosen and why.
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from adapter.errors import UsageError
from adapter.jsonfiles import dumps
from adapter.motion.animator import Animator
from adapter.motion.dryrun import KEYPOINTS, keypoint_nodes
from adapter.motion.integrators import METHODS
from adapter.motion.stability import stable_dt
from adapter.options import in_file, in_folder, number, positive

CANDIDATE_NODES = (600, 1200, 2400, 5000, 11272)
#: relative cost of one step, in force evaluations (the methods' own ``step_cost``; backward
#: Euler: a sparse LU, ~10)
STEP_COST = {name: cls.step_cost for name, cls in METHODS.items()}


def keypoint_trace(scene, nodes, method=None, dt=None):
    """Key-point displacements (8 samples over one half-stroke, (8, 4, 3)) of a whale."""
    a = Animator.with_integrator(scene, method or "forward_euler", dt, nodes=nodes)
    kp = keypoint_nodes(a.surface.landmarks)
    n = 2 * a.steps_per_quarter
    out = []
    for k in range(1, 9):
        a.advance_to(k * n // 8)
        d = a.X - a.rest
        out.append([d[kp[p]].mean(axis=0) for p in KEYPOINTS])
    return np.array(out), a


def _split_steps(scene, dt: float, duration: float) -> int:
    """Extra steps the animator takes over ``duration`` at step ``dt``: the smooth stroke's
    ramp end, when it falls inside a step, splits that step in two (Animator.advance_to)."""
    if scene.stroke.reversal != "smooth":
        return 0
    ramp = scene.stroke.ramp_cycles * scene.period_s
    k = ramp / dt
    return int(0 < ramp < duration and abs(k - round(k)) > 1e-9)


def trace_distance(a, b) -> float:
    """The largest distance (m) between two :func:`keypoint_trace` traces."""
    return float(np.linalg.norm(a - b, axis=2).max())


def choose(scene, tolerance_m: float, max_dt: float | None = None, fraction: float = 0.5,
           candidates=CANDIDATE_NODES, methods=None, nodes: int | None = None,
           method: str | None = None, dt: float | None = None, log=None) -> dict:
    """The coarsest resolution and cheapest stable method and step for ``tolerance_m``.

    Returns a report: nodes, method, dt, the estimated errors and the reasons.
    """
    log = log or (lambda *a: None)
    budget = fraction * tolerance_m
    why = []
    quarter = scene.period_s / 4
    # 1. resolution
    if nodes is None:
        cands = sorted(candidates)
        traces = {n: keypoint_trace(scene, n)[0] for n in cands}
        chosen, est = cands[-1], float("nan")
        for k, n in enumerate(cands[:-1]):
            # the error of a whale: its largest key-point difference from every finer one
            e = max(trace_distance(traces[n], traces[m]) for m in cands[k + 1:])
            log(f"  {n} nodes: key-point error ~ {e:.3g} m (against {cands[k + 1:]})")
            if e <= budget / 2:
                chosen, est = n, e
                break
        nodes = chosen
        why.append(f"{nodes} nodes: resolution error ~ {est:.3g} m <= half the budget "
                   f"{budget / 2:.3g} m" if np.isfinite(est) else
                   f"{nodes} nodes: the finest candidate (no coarser one met the budget)")
    else:
        why.append(f"{nodes} nodes: set by the user")
    # 2. method and step
    options = []
    a = Animator.with_integrator(scene, nodes=nodes)
    for m in ([method] if method else (methods or list(METHODS))):
        limit = stable_dt(a.network, a.rest, m, free=a.dynamic)
        cap = min(scene.integrator.safety * limit, max_dt or np.inf, quarter)
        if dt is not None:
            step = dt
        else:
            t1, _ = keypoint_trace(scene, nodes, m, cap)
            t2, _ = keypoint_trace(scene, nodes, m, cap / 2)
            p = METHODS[m].order
            e_cap = trace_distance(t1, t2) * 2**p / (2**p - 1)
            step = cap if e_cap <= budget / 2 else cap * (budget / 2 / e_cap) ** (1 / p)
        n_q = max(1, math.ceil(quarter / step - 1e-9))
        step = quarter / n_q
        cost = STEP_COST[m] * (2 * n_q + _split_steps(scene, step, 2 * quarter))
        options.append({"method": m, "dt": step, "stable_dt": limit, "cost": cost})
        log(f"  {m}: dt {step:.3g} s (stable {limit:.3g} s), cost {cost} per half-stroke")
    best = min(options, key=lambda o: o["cost"])
    why.append(f"{best['method']} at dt = {best['dt']:.3g} s: the fewest force evaluations "
               f"among {', '.join(o['method'] for o in options)} that meet the time budget "
               f"{budget / 2:.3g} m and stay under the stable step")
    return {"nodes": nodes, "method": best["method"], "dt": best["dt"],
            "tolerance_m": tolerance_m, "budget_m": budget, "options": options, "why": why}


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "choose", help="coarsest whale and cheapest method for a tolerance",
        description="Pick the coarsest whale, the integrator and the step that keep the "
        "surface error under a tolerance (for a coupled run a fraction of the flow cell size "
        "at the whale, for a dry-run a stated tolerance), within the stable step and the "
        "consumer's step; prints the choice and why (docs/numerics.md).")
    p.add_argument("--scene", type=in_file, help="scene TOML file (default: built-in default)")
    p.add_argument("--preset", help="built-in preset")
    p.add_argument("--cell-size", type=positive, help="flow cell size at the whale (m): the "
                   "tolerance is 0.1 of it")
    p.add_argument("--flow-dt", type=positive, help="flow time step (s): the largest step")
    p.add_argument("--tolerance", type=positive, help="surface tolerance (m), for a dry-run; with "
                   "--flow-study: the figures' tolerance, a fraction (0.05 = 5 %%)")
    p.add_argument("--flow-study", metavar="DIR", type=in_folder,
                   help="a finished `whale-adapter study` folder: offer the coarsest flow mesh "
                   "whose figures lie within --tolerance of the extrapolated values "
                   "(docs/case.md, 'The flow study')")
    p.add_argument("--fps", type=positive, help="dry-run output frames per second")
    p.add_argument("--nodes", type=number(int, 400, 2_000_000),
                   help="the whale's node count (default: the coarsest that meets the tolerance)")
    p.add_argument("--method", choices=sorted(METHODS), help="the integrator (default: the "
                   "cheapest that meets the tolerance)")
    p.add_argument("--dt", type=positive, help="the integrator's step (s) (default: the largest "
                   "that meets the tolerance)")
    p.set_defaults(func=_cmd_choose)


def _cmd_choose(args: argparse.Namespace) -> int:
    from adapter.scene import load_scene

    if args.flow_study:
        return _choose_flow_mesh(args)
    scene = load_scene(args.scene, preset=args.preset)
    if args.cell_size:
        tol, max_dt = 0.1 * args.cell_size, args.flow_dt
    elif args.tolerance:
        tol, max_dt = args.tolerance, (1 / args.fps if args.fps else None)
    else:
        raise UsageError("give --cell-size (coupled) or --tolerance")
    report = choose(scene, tol, max_dt, nodes=args.nodes, method=args.method, dt=args.dt,
                    log=print)
    print(dumps(report))
    return 0


def _choose_flow_mesh(args: argparse.Namespace) -> int:
    """``choose --flow-study DIR --tolerance F``: the flow mesh for a tolerance."""
    from pathlib import Path

    from adapter.errors import AdapterError
    from adapter.studies.study import RESULT
    from adapter.studies.study_analysis import SLOWEST_ORDER, choose_flow_mesh

    if not args.tolerance or args.tolerance <= 0:
        raise UsageError("choose --flow-study: give --tolerance, a fraction (0.05 = 5 %)")
    path = Path(args.flow_study) / RESULT
    if not path.is_file():
        raise AdapterError(f"{path} is missing: run `whale-adapter study --out "
                           f"{args.flow_study}` first")
    report = choose_flow_mesh(json.loads(path.read_text()), args.tolerance)
    if report.get("divergent"):
        print(f"no mesh of the study can be vouched for within {args.tolerance:.1%}: "
              f"{', '.join(report['divergent'])} diverge or converge too slowly (observed "
              f"order under {SLOWEST_ORDER}) over the three meshes (their spread, "
              f"up to {report['worst_difference']:.1%}, is only a lower bound of the error); "
              "a study on finer meshes is needed (docs/case.md, \"The flow study\")")
    elif report["mesh"] is None:
        need = report.get("background_cell_m_needed")
        print(f"no mesh of the study is within {args.tolerance:.1%}: the finest differs by "
              f"{report['worst_difference']:.1%} from the extrapolated values"
              + (f"; a background cell of about {need:.3g} m would reach it (from the observed"
                 " order)" if need else "")
              + ("; that is far beyond the meshes the study ran, where the observed order was "
                 "not measured: run a study on finer meshes to know" if report.get("beyond_study")
                 else ""))
    else:
        print(f"mesh-{report['mesh']} (background cell {report['background_cell_m']:.4g} m, "
              f"{report['cells']:,} cells, {report['wall_s_per_cycle']:.0f} s per stroke "
              f"cycle): every figure within {report['worst_difference']:.2%} of its "
              f"extrapolated value or band (tolerance {args.tolerance:.1%})")
    print(dumps(report))
    return 0
