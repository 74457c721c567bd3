"""Time mapping synthetic patch points onto the default whale (PatchMap), as HELLO does.

    PYTHONPATH=. .venv/bin/python scripts/bench_mapping.py --points 1000000
"""

from __future__ import annotations

import argparse
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
    args = ap.parse_args()
    surface = build_surface(load_scene(preset=args.preset))
    pts = points_near(surface, args.points, seed=0)
    t0 = time.perf_counter()
    patch = PatchMap.from_surface(pts, surface)
    elapsed = time.perf_counter() - t0
    print(f"mapped {args.points} points onto the {args.preset} whale ({len(surface.points)} "
          f"nodes, {len(surface.triangles)} triangles) in {elapsed:.2f} s; max distance "
          f"{patch.max_distance:.3g} m")


if __name__ == "__main__":
    main()
