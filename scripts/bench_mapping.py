"""Time mapping synthetic patch points onto the default whale (PatchMap), as HELLO does.

    PYTHONPATH=. .venv/bin/python scripts/bench_mapping.py --points 1000000

Prints the wall time (it includes loading the compiled search kernel, about 0.5 s, as the
first HELLO does), the CPU time of the process over the mapping (all threads: on a busy
machine the wall time grows, the CPU time much less), and the process's peak memory. With
``--cache FILE`` it maps twice through that cache file: computed and saved, then loaded.
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from adapter.body.geometry import build_surface  # noqa: E402
from adapter.coupling.mapping import PatchMap  # noqa: E402
from adapter.scene import load_scene  # noqa: E402
from tests.wire_client import points_near  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=1_000_000)
    ap.add_argument("--preset", default="default")
    ap.add_argument("--cache", type=Path, help="map through this cache file, twice")
    args = ap.parse_args()
    surface = build_surface(load_scene(preset=args.preset))
    pts = points_near(surface, args.points, seed=0)
    if args.cache is not None:
        args.cache.unlink(missing_ok=True)
    for _ in range(1 if args.cache is None else 2):
        t0, c0 = time.perf_counter(), time.process_time()
        patch = PatchMap.from_surface(pts, surface, cache=args.cache)
        elapsed, cpu = time.perf_counter() - t0, time.process_time() - c0
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        how = f" (map {patch.cache_status})" if patch.cache_status else ""
        print(f"mapped {args.points} points onto the {args.preset} whale ({len(surface.points)} "
              f"nodes, {len(surface.triangles)} triangles) in {elapsed:.2f} s{how}; CPU "
              f"{cpu:.2f} s; peak memory {peak:.0f} MB; max distance "
              f"{patch.max_distance:.3g} m")


if __name__ == "__main__":
    main()
