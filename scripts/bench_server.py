#!/usr/bin/env python
"""Measure the step-server: compute per request and transfer per request on a UNIX socket.

Starts a real StepServer (in a process of its own, as ``run-case`` does: a client thread in the
server's process would share its GIL with the work-ahead) on a scene preset in a temporary case
folder, connects one client (one rank) with P patch points sampled near the whale, and sends
REQUESTs at a fixed flow step, sleeping ``--solve`` seconds between them as OpenFOAM would while
it solves the flow.

    .venv/bin/python scripts/bench_server.py --preset default --points 2500 15000

Prints one line per point count: server compute per request (what OpenFOAM waits for, with
work-ahead), animator cost per flow step (hidden by the work-ahead when it hits), server-side
transfer per request, client round trip, and work-ahead hits.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import socket
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from adapter.coupling import protocol as wire  # noqa: E402
from adapter.coupling.protocol import SOCKET_NAME, MessageType  # noqa: E402
from adapter.coupling.server import OUTPUT_DIR, StepServer  # noqa: E402
from adapter.motion.animator import Animator  # noqa: E402
from adapter.scene import load_scene  # noqa: E402


def sample_points(surface, n, seed=0):
    rng = np.random.default_rng(seed)
    tri = rng.integers(0, len(surface.triangles), n)
    w = rng.dirichlet([1.0, 1.0, 1.0], n)
    pts = np.einsum("pk,pkd->pd", w, surface.points[surface.triangles[tri]])
    return pts + 1e-3 * rng.normal(size=pts.shape)


def call(sock, seq, msg_type, payload=b""):
    wire.send_frame(sock, msg_type, payload, seq)
    frame = wire.read_frame(sock, 60)
    if frame.type == MessageType.ERROR:
        raise SystemExit(f"server error: {wire.unpack_error(frame.payload)}")
    return frame


def _serve(tmp, scene, animator, started):
    srv = StepServer(tmp, scene, animator=animator, first_client_timeout=60)
    srv.start()
    started.set()
    srv.run()


def bench(animator, scene, n_points, steps, flow_dt, solve_s):
    with tempfile.TemporaryDirectory() as tmp:
        # forked: the child has the animator already built
        ctx = multiprocessing.get_context("fork")
        started = ctx.Event()
        server = ctx.Process(target=_serve, args=(tmp, scene, animator, started), daemon=True)
        server.start()
        if not started.wait(60):
            raise SystemExit("the step-server did not start within 60 s")
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        sock.connect(str(Path(tmp) / SOCKET_NAME))
        t0 = time.perf_counter()
        call(sock, 1, MessageType.HELLO, wire.pack_hello(1, sample_points(animator.surface,
                                                                             n_points)))
        hello_s = time.perf_counter() - t0
        rtt = []
        for k in range(1, steps + 1):
            t0 = time.perf_counter()
            call(sock, k + 1, MessageType.REQUEST, wire.pack_request(k * flow_dt))
            rtt.append(time.perf_counter() - t0)
            time.sleep(solve_s)
        wire.send_frame(sock, MessageType.BYE, b"", steps + 2)
        sock.close()
        server.join(60)
        s = json.loads((Path(tmp) / OUTPUT_DIR / "server-stats.json").read_text())
    # the first two requests have no work-ahead yet; report the steady state too
    print(f"P={n_points:6d} ({12 + 24 * n_points} B/reply): HELLO+mapping "
          f"{1e3 * hello_s:.0f} ms | server compute/request median "
          f"{1e3 * s['median_compute_s']:.2f} ms, mean {1e3 * s['mean_compute_s']:.2f} ms | "
          f"animator/flow step {1e3 * s['mean_step_advance_s']:.1f} ms | server transfer/request "
          f"median {1e3 * s['median_transfer_s']:.2f} ms | client round trip median "
          f"{1e3 * np.median(rtt):.2f} ms | work-ahead hits "
          f"{s['work_ahead_hits']}/{s['work_ahead_tries']}", flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="default")
    ap.add_argument("--points", type=int, nargs="+", default=[2500, 15000])
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--flow-dt", type=float, default=0.01, help="flow time step (s)")
    ap.add_argument("--solve", type=float, default=0.1,
                    help="seconds the 'flow solve' takes between requests")
    args = ap.parse_args(argv)
    scene = load_scene(preset=args.preset)
    t0 = time.perf_counter()
    animator = Animator(scene)
    print(f"preset {args.preset}: {len(animator.surface.points)} nodes, internal step "
          f"{animator.dt:.4g} s ({args.flow_dt / animator.dt:.1f} internal steps per flow step "
          f"of {args.flow_dt:g} s), animator built in {time.perf_counter() - t0:.2f} s")
    for n in args.points:
        bench(animator, scene, n, args.steps, args.flow_dt, args.solve)


if __name__ == "__main__":
    main()
