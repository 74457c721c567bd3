"""The numerics study: stable steps, convergence orders, work-precision, error vs resolution.

``whale-adapter numerics --out DIR [--quick]`` (``make chart``) writes into DIR:

- ``stability.csv`` / ``stability.png``: the largest stable step against the damping mu, per
  method, predicted (:mod:`adapter.motion.stability`) and measured on the whale by bisection, with
  the paper's criterion dt |F_i| <= 1;
- ``work_precision.csv`` / ``work_precision.png``: surface error against wall time over one
  half-stroke of the whole whale (the smooth stroke's force and the fluke gate imposed at every
  stage of every method), per method and step, against a converged RK4 reference; the legend
  gives each method's observed order (``whale_order_with_gate`` in the summary);
- ``convergence.csv``: error against step on the spring network alone (no gate), the
  observed orders;
- ``resolution.csv`` / ``resolution.png``: error against node count at fixed method;
- ``summary.json``: per method predicted_dt, measured_dt, paper_criterion_dt,
  observed_order (and the figures above in short).

The measurements are here; the CSV files and the charts are written by
:mod:`adapter.studies.numerics_report`.

Measuring a stable step: a tiny random perturbation (1e-7 L) is added to the free nodes at
t = 0 and the whale is run twice, with and without it, for up to two quarter strokes; the run
is unstable if the difference grows between the middle and the end of the run (the
perturbation holds every mode, so a growing mode takes over), or if it blows up. Bisection in
dt then brackets the threshold to about 1 %.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from adapter.body.springs import stiffness_matrix
from adapter.errors import UnstableError
from adapter.jsonfiles import write_json
from adapter.motion.animator import Animator
from adapter.motion.integrators import METHODS, make_integrator
from adapter.motion.stability import EXPLICIT, paper_criterion_dt, predict
from adapter.options import in_file, out_folder
from adapter.studies.numerics_report import plot_stability, plot_xy, write_csv

#: theory's order per method (the methods' own ``order``)
THEORY_ORDER = {name: cls.order for name, cls in METHODS.items()}
#: the small whale of the stability and order studies (nodes)
SMALL_NODES = 500


def perturbation_growth(a, method: str, dt: float, n_steps: int | None = None,
                        seed: int = 0, every: int = 2) -> float:
    """How much a tiny perturbation of the whale grows (> 1: the step is unstable; inf: the
    run blew up).

    The whale's spring network is run from rest with the upward stroke velocity, the fluke
    nodes held (as in the prediction: free nodes only), twice in lockstep: as is, and with a
    perturbation of 1e-7 L. The perturbation is random noise filtered by K^3 (K the stiffness
    on the free nodes); the difference of the two runs is measured every ``every`` steps by
    dx = |K dX| and dv = |K dV|, which weigh the stiff modes that go unstable first and leave
    out the neutral ones (a node's drift normal to the surface, which a truss surface does
    not resist). The step is unstable if

    - dx or dv ever exceeds 1000 times its first value: a fast-growing mode. Such a mode does
      not always blow up: on the whale it grows to a few centimetres within tens of steps,
      the stretched springs then stop it, and the whale settles, crumpled, into a new
      equilibrium (so comparing only the middle and the end of the run misses it); or
    - dx or dv at the end exceeds its largest value over the first half of the run: slow
      growth (a decaying oscillation never exceeds its earlier peaks).

    The value returned is the largest of those ratios (the first divided by 1000). Forward
    Euler goes unstable slowly (the growth per step is about c dt (dt / dt_max - 1) / 2),
    hence its long runs.
    """
    if n_steps is None:
        n_steps = (fe_steps(a, dt) if method == "forward_euler" else
                   int(np.clip(8.0 / dt, 60, 400)) if method == "backward_euler" else 4000)
    dyn = a.dynamic
    held = np.flatnonzero(~dyn)
    rest_held = a.rest[held]
    dofs = (3 * np.flatnonzero(dyn)[:, None] + np.arange(3)).ravel()
    K = stiffness_matrix(a.network, a.rest, symmetric=False)[dofs][:, dofs]
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(len(dofs))
    for _ in range(3):
        u = K @ u
        u /= np.abs(u).max()

    def integ():
        return make_integrator(method, a.network.forces, dt, runaway=2.0 * a.surface.length,
                               reference=a.rest, network=a.network)

    runs = []
    for pert in (False, True):
        X = a.rest.copy()
        if pert:
            X[dyn] += 1e-7 * a.surface.length * u.reshape(-1, 3)
        V = np.zeros_like(X)
        V[dyn, 2] = a.profile[dyn]
        runs.append([integ(), X, V])
    d = []
    try:
        for k in range(1, n_steps + 1):
            for r in runs:
                X, V = r[0].step(r[1], r[2])
                X[held] = rest_held
                V[held] = 0.0
                r[1], r[2] = X, V
            if k == 1 or k % every == 0 or k == n_steps:
                dX = (runs[1][1] - runs[0][1])[dyn].ravel()
                dV = (runs[1][2] - runs[0][2])[dyn].ravel()
                d.append((np.linalg.norm(K @ dX), np.linalg.norm(K @ dV)))
    except UnstableError:
        return np.inf
    errs = np.array(d)
    if not np.isfinite(errs).all():
        return np.inf
    half = max(2, len(errs) // 2)
    fast = (errs.max(axis=0) / (1e3 * np.maximum(errs[0], 1e-300))).max()
    slow = (errs[-1] / np.maximum(errs[1:half].max(axis=0), 1e-300)).max()
    return float(max(fast, slow))


def fe_steps(a, dt: float) -> int:
    """Steps forward Euler needs to show its slow growth near the bound: about 100 / (c dt),
    with c ~ mu lambda_max(L) + nu the damping of the stiffest modes (the growth per step is
    about c dt (dt / dt_max - 1) / 2), between 20,000 and 150,000."""
    net = a.network
    c = net.mu * 2.0 * net.laplacian.diagonal().max() / 2.0 + net.nu
    return int(np.clip(100.0 / (c * dt), 20000, 150000))


def measure_stable_dt(a, method: str, guess: float, iterations: int = 4,
                      n_steps: int | None = None) -> float:
    """The largest step (s) at which the whale stays stable, by bisection (in log dt) from
    the bracket ``guess`` / 1.15 .. ``guess`` x 1.15 (widened until it brackets): with the
    default 4 bisections the answer is within 1 % of the threshold."""
    def stable(dt):
        return perturbation_growth(a, method, dt, n_steps,
                                   every=20 if method == "forward_euler" else 2) <= 1.0

    lo, hi = guess / 1.15, guess * 1.15
    for _ in range(8):
        if stable(lo):
            break
        hi, lo = lo, lo / 1.3
    for _ in range(8):
        if not stable(hi):
            break
        lo, hi = hi, hi * 1.3
    for _ in range(iterations):
        mid = np.sqrt(lo * hi)
        if stable(mid):
            lo = mid
        else:
            hi = mid
    return float(np.sqrt(lo * hi))


def paper_criterion(a, dt: float, n_steps: int = 2000, every: int = 10) -> float:
    """The step the paper's criterion dt |F_i| <= 1 allows, with the largest force met over a
    run of ``n_steps`` forward-Euler steps at ``dt`` (a stable step)."""
    a.set_integrator("forward_euler", dt)
    peak = np.inf
    n = min(n_steps, 2 * a.steps_per_quarter - 1)
    for k in range(every, n + 1, every):
        a.advance_to(k)
        peak = min(peak, paper_criterion_dt(a.network.forces(a.X, a.V)))
    return float(peak)


def stability_study(scene, mus, nodes=SMALL_NODES, log=print) -> list[dict]:
    """Rows (mu, method, predicted_dt, measured_dt, paper_criterion_dt) on the small whale."""
    rows = []
    for mu in mus:
        a = Animator.with_integrator(scene, nodes=nodes, mu=float(mu))
        pred = predict(a.network, a.rest, a.dynamic, exact=True)
        paper = paper_criterion(a, 0.5 * pred["forward_euler"])
        for m in EXPLICIT:
            t0 = time.perf_counter()
            meas = measure_stable_dt(a, m, pred[m])
            rows.append({"mu": float(mu), "method": m, "predicted_dt": pred[m],
                         "measured_dt": meas, "paper_criterion_dt": paper,
                         "paper_criterion_dt_mm": paper / 1000.0,
                         "paper_criterion_safe": bool(paper <= meas)})
            log(f"  mu {mu:g} {m:17s} predicted {pred[m]:.4g} s, measured {meas:.4g} s "
                f"({meas / pred[m] - 1:+.1%}), paper {paper:.3g} s "
                f"[{time.perf_counter() - t0:.1f} s]")
        # backward Euler: A-stable for the linearised network (no bound predicted), but one
        # linearised (Newton) step per step does not hold the large stroke motion at any step
        t0 = time.perf_counter()
        meas = measure_stable_dt(a, "backward_euler", 0.2, iterations=2)
        rows.append({"mu": float(mu), "method": "backward_euler", "predicted_dt": np.inf,
                     "measured_dt": meas, "paper_criterion_dt": paper,
                     "paper_criterion_dt_mm": paper / 1000.0,
                     "paper_criterion_safe": bool(paper <= meas)})
        log(f"  mu {mu:g} backward_euler    predicted: any step (linear), measured {meas:.3g} "
            f"s with the stroke (one linearised step per step) "
            f"[{time.perf_counter() - t0:.1f} s]")
    return rows


# -- accuracy -------------------------------------------------------------------------------

def network_run(a, method: str, n_per_quarter: int) -> tuple[np.ndarray, float]:
    """The spring network alone (no fluke gate: a smooth problem) from the upward stroke
    velocity over one half-stroke, with the negation at its middle on a step boundary.
    Returns the final positions (N, 3) and the wall time (s)."""
    quarter = a.period / 4
    dt = quarter / n_per_quarter
    integ = make_integrator(method, a.network.forces, dt, runaway=2.0 * a.surface.length,
                            reference=a.rest, network=a.network)
    X = a.rest.copy()
    V = np.zeros_like(X)
    V[a.dynamic, 2] = a.profile[a.dynamic]
    t0 = time.perf_counter()
    for k in range(1, 2 * n_per_quarter + 1):
        X, V = integ.step(X, V)
        if k == n_per_quarter:
            V = -V
    return X, time.perf_counter() - t0


def whale_run(a, method: str, n_per_quarter: int) -> tuple[np.ndarray, float]:
    """The animator as it runs (the stroke's force and the fluke gate at every stage time,
    the paper's events if any) over one half-stroke: final positions and wall time."""
    a.set_integrator(method, a.period / 4 / n_per_quarter)
    t0 = time.perf_counter()
    a.advance_to(2 * n_per_quarter)
    return a.X.copy(), time.perf_counter() - t0


#: steps per quarter stroke tried per method (the accuracy studies)
#: (in the asymptotic range on the 500-node network: RK4 shows 3.74 between 64 and 128 steps
#: and 3.96 between 128 and 256; backward Euler 0.85 between 200 and 400, 0.91 between 400
#: and 800, its stiff, heavily damped modes leave the pre-asymptotic range late)
STEPS = {"forward_euler": (1600, 3200, 6400), "symplectic_euler": (1600, 3200, 6400),
         "verlet": (100, 200, 400, 800), "rk4": (128, 256, 512),
         "backward_euler": (400, 800, 1600)}
REFERENCE_STEPS = 4096  # RK4; against 8192 steps it differs by 2e-13 m: converged


def order_study(a, steps=STEPS, runner=network_run, log=print) -> tuple[list, dict]:
    """Error (max node distance at the end of a half-stroke, m) against step per method, and
    the observed order (least-squares slope of log error against log dt)."""
    ref, _ = runner(a, "rk4", REFERENCE_STEPS)
    quarter = a.period / 4
    rows, orders = [], {}
    for m, ns in steps.items():
        dts, errs = [], []
        for n in ns:
            X, wall = runner(a, m, n)
            err = float(np.linalg.norm(X - ref, axis=1).max())
            rows.append({"method": m, "steps_per_quarter": n, "dt": quarter / n,
                         "error_m": err, "wall_s": wall})
            dts.append(quarter / n)
            errs.append(err)
        orders[m] = float(np.polyfit(np.log(dts), np.log(errs), 1)[0])
        log(f"  {m:17s} errors {', '.join(f'{e:.2e}' for e in errs)} m: order "
            f"{orders[m]:.2f} (theory {THEORY_ORDER[m]})")
    return rows, orders


def resolution_study(scene, nodes_list, reference_nodes, method="forward_euler",
                     log=print) -> list[dict]:
    """Error of the key points over one half-stroke against node count (fixed method, the
    scene's step rule), measured against the ``reference_nodes`` whale."""
    from adapter.motion.dryrun import KEYPOINTS, keypoint_nodes

    def trace(nodes):
        a = Animator.with_integrator(scene, nodes=nodes)
        a.set_integrator(method, a.integrator.dt)
        kp = keypoint_nodes(a.surface.landmarks)
        n = 2 * a.steps_per_quarter
        out = []
        t0 = time.perf_counter()
        for k in range(1, 9):
            a.advance_to(k * n // 8)
            d = a.X - a.rest
            out.append([d[kp[p]].mean(axis=0) for p in KEYPOINTS])
        return np.array(out), time.perf_counter() - t0, a.surface.n_nodes

    ref, _, _ = trace(reference_nodes)
    rows = []
    for nodes in nodes_list:
        tr, wall, n_actual = trace(nodes)
        err = float(np.linalg.norm(tr - ref, axis=2).max())
        rows.append({"nodes": n_actual, "method": method, "error_m": err, "wall_s": wall})
        log(f"  {n_actual:6d} nodes: key-point error {err:.3g} m, {wall:.1f} s")
    return rows


def run(scene, out: Path, quick: bool = False, log=print) -> dict:
    """The whole study into ``out``; returns the summary."""
    from adapter.scene import load_scene

    out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    mus = (0.2, 0.5, 2.0) if quick else (0.1, 0.2, 0.5, 1.0, 2.0)
    log(f"stable step against mu on the {SMALL_NODES}-node whale")
    stab = stability_study(scene, mus, log=log)
    write_csv(out / "stability.csv", stab)
    plot_stability(stab, out / "stability.png")

    log(f"convergence orders on the {SMALL_NODES}-node spring network (no gate)")
    small = Animator.with_integrator(scene, nodes=SMALL_NODES)
    conv, orders = order_study(small, log=log)
    write_csv(out / "convergence.csv", conv)

    wp_scene = load_scene(preset="smoke") if quick else scene
    log(f"work-precision on the {wp_scene.name} whale (stroke and gate included)")
    big = Animator.with_integrator(wp_scene)
    wp_steps = {"forward_euler": (1500, 3000, 6000), "symplectic_euler": (1500, 3000, 6000),
                "verlet": (64, 128, 256, 512), "rk4": (48, 96, 192),
                "backward_euler": (8, 16, 32)}
    if quick:
        wp_steps = {m: s[:2] for m, s in wp_steps.items()}
    wp, wp_orders = order_study(big, steps=wp_steps, runner=whale_run, log=log)
    for r in wp:
        r["nodes"] = big.surface.n_nodes
    write_csv(out / "work_precision.csv", wp)
    plot_xy({f"{m}: order {wp_orders[m]:.2f} (theory {THEORY_ORDER[m]})":
              [r for r in wp if r["method"] == m] for m in METHODS}, "wall_s", "error_m",
             "wall time over one half-stroke (s)", "surface error (m)",
             f"Work-precision, {wp_scene.name} whale ({big.surface.n_nodes} nodes)",
             out / "work_precision.png")

    log("error against resolution (forward Euler, the scene's step)")
    nodes_list = (600, 1200, 2400) if quick else (600, 1200, 2400, 5000)
    res = resolution_study(scene, nodes_list, 4800 if quick else 11272, log=log)
    write_csv(out / "resolution.csv", res)
    plot_xy({"forward_euler": res}, "nodes", "error_m", "nodes", "key-point error (m)",
             "Error against resolution over one half-stroke", out / "resolution.png")

    mu0 = scene.springs.mu
    at_mu = [r for r in stab if abs(r["mu"] - mu0) < 1e-12] or stab
    methods = {}
    for m in METHODS:
        r = next(x for x in at_mu if x["method"] == m)
        methods[m] = {
            "predicted_dt": float(r["predicted_dt"]),
            "measured_dt": float(r["measured_dt"]),
            "paper_criterion_dt": float(r["paper_criterion_dt"]),
            "observed_order": orders[m],
            "theory_order": THEORY_ORDER[m],
            "whale_order_with_gate": wp_orders[m],
            "force_calls_per_step": METHODS[m].force_calls,
        }
    fe = [r for r in stab if r["method"] == "forward_euler"]
    paper = {
        "criterion": "dt |F_i| <= 1 for every node (F in m/s^2; the same whale in mm: "
                     "a 1000 times smaller step)",
        "per_mu": [{"mu": r["mu"], "paper_dt_m_units": r["paper_criterion_dt"],
                    "paper_dt_mm_units": r["paper_criterion_dt_mm"],
                    "measured_forward_euler_dt": r["measured_dt"],
                    "ratio_paper_over_measured": r["paper_criterion_dt"] / r["measured_dt"],
                    "safe_for_forward_euler": r["paper_criterion_safe"]} for r in fe],
    }
    summary = {"mu": mu0, "small_nodes": SMALL_NODES, "methods": methods,
               "paper_criterion": paper,
               "resolution": res, "quick": quick,
               "wall_s": time.perf_counter() - t_start}
    write_json(out / "summary.json", summary)
    return summary


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "numerics", help="stable steps, orders, work-precision, resolution: PNG, CSV, JSON",
        description="The numerics study: predicted against measured stable steps of each "
        "integrator, convergence orders, work against precision and error against "
        "resolution, as charts, CSV and JSON in --out (docs/numerics.md; about 8 minutes, "
        "--quick for a short version).")
    p.add_argument("--scene", type=in_file, help="scene TOML file (default: built-in default)")
    p.add_argument("--preset", help="built-in preset: default, smoke, fine")
    p.add_argument("--out", required=True, type=out_folder, help="output folder")
    p.add_argument("--quick", action="store_true", help="fewer points, the smoke whale")
    p.set_defaults(func=_cmd_numerics)


def _cmd_numerics(args: argparse.Namespace) -> int:
    from adapter.scene import load_scene

    scene = load_scene(args.scene, preset=args.preset)
    summary = run(scene, Path(args.out), quick=args.quick)
    for m, r in summary["methods"].items():
        print(f"{m:17s} predicted {r['predicted_dt']} s, measured {r['measured_dt']} s, "
              f"paper {r['paper_criterion_dt']:.3g} s, order {r['observed_order']:.2f}")
    print(f"wrote {args.out}/summary.json, stability, work_precision, convergence, resolution "
          f"(CSV, PNG) in {summary['wall_s']:.0f} s")
    return 0
