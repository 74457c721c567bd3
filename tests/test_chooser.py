"""The chooser's actual choice against a brute-force enumeration of its candidates: each
(method, step) run here over the half-stroke the chooser judges, its force evaluations counted
and its key-point error measured against a converged run (RK4 at a tiny step)."""

import numpy as np
import pytest

from adapter.motion.animator import Animator
from adapter.motion.dryrun import KEYPOINTS, keypoint_nodes
from adapter.motion.integrators import make_integrator
from adapter.studies import chooser

NODES = 600
METHODS = ("forward_euler", "symplectic_euler", "verlet", "rk4")


def _half_stroke(scene, method, dt, count=False):
    """Key-point displacements at 8 instants over the first half-stroke, and the number of
    force evaluations the run took (counted by wrapping the force, when ``count``)."""
    a = Animator.with_integrator(scene, method, dt, nodes=NODES)
    calls = [0]
    if count:
        def force(X, V):
            calls[0] += 1
            return a.network.forces(X, V)

        # the generic (uncompiled) step, which calls the force as the method's table says
        a.integrator = make_integrator(method, force, a.dt, runaway=2.0 * a.surface.length,
                                       reference=a.rest)
    kp = keypoint_nodes(a.surface.landmarks)
    n = 2 * a.steps_per_quarter
    out = []
    for k in range(1, 9):
        a.advance_to(k * n // 8)
        d = a.X - a.rest
        out.append([d[kp[p]].mean(axis=0) for p in KEYPOINTS])
    return np.array(out), calls[0]


@pytest.mark.slow
@pytest.mark.parametrize("tolerance", [
    0.2,
    # strict xfail until the smooth stroke's push and the fluke gate were applied once per
    # internal step (operator splitting): every method was then first order (RK4 on the smoke
    # whale: errors 3.1 mm and 1.5 mm at 260 and 520 steps per quarter) while the chooser
    # extrapolates with the method's own order; both are now in the right-hand side, at every
    # stage time (tests/test_orders.py)
    0.02,
])
def test_the_choice_is_the_cheapest_candidate_that_meets_the_budget(smoke_scene, tolerance):
    report = chooser.choose(smoke_scene, tolerance, max_dt=0.05, nodes=NODES, methods=METHODS)
    budget = report["budget_m"] / 2  # the time step's half of the budget
    truth, _ = _half_stroke(smoke_scene, "rk4", smoke_scene.period_s / 4 / 2000)
    runs = {}
    for o in report["options"]:
        trace, evals = _half_stroke(smoke_scene, o["method"], o["dt"], count=True)
        err = float(np.linalg.norm(trace - truth, axis=2).max())
        runs[o["method"]] = (evals, err)
    feasible = {m: ev for m, (ev, err) in runs.items() if err <= budget}
    # the candidates differ in cost, and more than one meets the budget: a real choice
    assert len(feasible) >= 2 and len(set(feasible.values())) >= 2, runs
    assert report["method"] in feasible, (report["method"], runs)
    assert feasible[report["method"]] == min(feasible.values()), (report["method"], runs)
    # and the report's costs are the evaluations counted
    for o in report["options"]:
        assert o["cost"] == runs[o["method"]][0]
