"""`make bench`: steps per second of one spring-mass step on the paper-scale whale.

Three implementations of the same forward-Euler step on the same network, measured in the
same run: the project's (adapter.motion.integrators, a numba kernel fused with the update and the
check), a naive numpy baseline (SpringNetwork.forces_numpy, sparse products), and an
independent compiled kernel: the same equations in C, compiled here with gcc -O3 and called
through ctypes. Also the project's whole animator step (integrator + fluke gate), and the
resident memory before and after 100,000 steps. Prints figures, writes out/bench.json.
"""

from __future__ import annotations

import ctypes
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import psutil

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from adapter.jsonfiles import finite  # noqa: E402
from adapter.motion.animator import Animator  # noqa: E402
from adapter.motion.integrators import make_integrator  # noqa: E402
from adapter.scene import load_scene  # noqa: E402

C_SOURCE = r"""
#include <math.h>
#include <stdint.h>
void fe_step(int64_t n, int64_t ne, const double *X, const double *V, const int64_t *ei,
             const int64_t *ej, const double *rest, const double *ki, const double *kj,
             double mu, double nu, double dt, double *X1, double *V1) {
    for (int64_t a = 0; a < 3 * n; ++a) V1[a] = -nu * V[a];
    for (int64_t e = 0; e < ne; ++e) {
        int64_t a = 3 * ei[e], b = 3 * ej[e];
        double dx = X[b] - X[a], dy = X[b + 1] - X[a + 1], dz = X[b + 2] - X[a + 2];
        double f = 1.0 - rest[e] / sqrt(dx * dx + dy * dy + dz * dz);
        double vx = mu * (V[b] - V[a]), vy = mu * (V[b + 1] - V[a + 1]),
               vz = mu * (V[b + 2] - V[a + 2]);
        double fa = ki[e] * f, fb = kj[e] * f;
        V1[a] += fa * dx + vx; V1[a + 1] += fa * dy + vy; V1[a + 2] += fa * dz + vz;
        V1[b] -= fb * dx + vx; V1[b + 1] -= fb * dy + vy; V1[b + 2] -= fb * dz + vz;
    }
    for (int64_t a = 0; a < 3 * n; ++a) { X1[a] = X[a] + dt * V[a]; V1[a] = V[a] + dt * V1[a]; }
}
"""


def _c_kernel():
    d = Path(tempfile.mkdtemp(prefix="whale-bench-"))
    (d / "k.c").write_text(C_SOURCE)
    subprocess.run(["gcc", "-O3", "-march=native", "-shared", "-fPIC", "-o", str(d / "k.so"),
                    str(d / "k.c"), "-lm"], check=True)
    lib = ctypes.CDLL(str(d / "k.so"))
    p = ctypes.c_void_p
    lib.fe_step.argtypes = [ctypes.c_int64, ctypes.c_int64] + [p] * 7 + [ctypes.c_double] * 3 \
        + [p, p]
    return lib


def _rate(fn, seconds=3.0) -> float:
    fn()
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        fn()
        n += 1
    return n / (time.perf_counter() - t0)


def main() -> int:
    scene = load_scene()
    a = Animator(scene)
    net, dt = a.network, a.dt
    X = a.rest + 1e-3 * np.random.default_rng(0).standard_normal(a.rest.shape)
    V = 1e-3 * np.random.default_rng(1).standard_normal(a.rest.shape)
    print(f"whale: {net.n_nodes} nodes, {len(net.i)} edges, dt = {dt:.3g} s (forward Euler)")

    project = make_integrator(  # as the animator runs it: checked, into reused arrays
        "forward_euler", net.forces, dt, network=net, reference=a.rest,
        runaway=2.0 * a.surface.length, reuse_buffers=True)
    naive = make_integrator("forward_euler", net.forces_numpy, dt)
    lib = _c_kernel()
    X1, V1 = np.empty_like(X), np.empty_like(V)
    args = (net.i, net.j, net.rest, net.k_on_i, net.k_on_j)

    def c_step():
        lib.fe_step(net.n_nodes, len(net.i), X.ctypes.data, V.ctypes.data,
                    *[x.ctypes.data for x in args], net.mu, net.nu, dt, X1.ctypes.data,
                    V1.ctypes.data)

    r_project = _rate(lambda: project.step(X, V))
    r_naive = _rate(lambda: naive.step(X, V))
    r_c = _rate(c_step)
    a.reset()
    r_anim = _rate(lambda: a.advance_to(a.step_index + 1))
    ref_X, ref_V = project.step(X, V)
    c_step()
    agree = float(max(np.abs(X1 - ref_X).max(), np.abs(V1 - ref_V).max()))

    proc = psutil.Process()
    a.reset()
    rss0 = proc.memory_info().rss
    t0 = time.perf_counter()
    n_mem = 100_000
    a.advance_to(n_mem)
    wall = time.perf_counter() - t0
    rss1 = proc.memory_info().rss
    res = {
        "nodes": int(net.n_nodes), "edges": int(len(net.i)),
        "steps_per_s": {"project_integrator_step": r_project, "numpy_baseline": r_naive,
                        "c_kernel_gcc_O3": r_c, "project_animator_step": r_anim},
        "ratios": {"c_over_project": r_c / r_project, "project_over_numpy": r_project / r_naive,
                   "c_over_project_animator": r_c / r_anim},
        "c_vs_project_max_difference": agree,
        "rss_mb_before": rss0 / 2**20, "rss_mb_after_100k_steps": rss1 / 2**20,
        "steps_100k_wall_s": wall,
    }
    print(f"steps per second: project {r_project:.0f}, numpy {r_naive:.0f}, C {r_c:.0f}; "
          f"whole animator step (with the fluke gate) {r_anim:.0f}")
    print(f"ratios: C / project {r_c / r_project:.2f} (goal <= 1.2), project / numpy "
          f"{r_project / r_naive:.1f}, C / animator step {r_c / r_anim:.2f}")
    print(f"resident memory: {rss0 / 2**20:.1f} MB before, {rss1 / 2**20:.1f} MB after "
          f"{n_mem} animator steps ({wall:.0f} s)")
    out = ROOT / "out"
    out.mkdir(exist_ok=True)
    (out / "bench.json").write_text(json.dumps(finite(res), indent=2, allow_nan=False) + "\n")
    print("wrote out/bench.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
