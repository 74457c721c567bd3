"""What the step-server writes under ``<case>/adapter/`` besides its state files: the whale at
every written time (``whale_<t>.vtp`` and the collection ``whale.pvd``), a row of
``keypoints.csv`` per served time (the landmarks' positions and the patch's forces), and its
statistics (``server-stats.json``, and the summary line it prints at the end).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import threading
from collections.abc import Callable
from pathlib import Path

import numpy as np

from adapter import vtkfiles
from adapter.body.landmarks import LANDMARKS
from adapter.coupling.store import atomic_write_text, time_name
from adapter.errors import VTKFileError
from adapter.jsonfiles import write_json

log = logging.getLogger(__name__)

FORCE_COLUMNS = ("fx_p", "fy_p", "fz_p", "fx_v", "fy_v", "fz_v")


@dataclasses.dataclass
class Row:
    """One row of keypoints.csv, before it is written."""

    landmarks: np.ndarray            # (3 * n_landmarks,)
    forces: np.ndarray | None        # (6,) the whole patch's, as the link reported them


class Recorder:
    """The outputs of one case's step-server, in ``folder`` (``<case>/adapter``).

    Parameters
    ----------
    folder : the output folder (it exists).
    surface : the whale's :class:`~adapter.body.surface.WhaleSurface` at rest.
    """

    def __init__(self, folder, surface):
        self.folder = Path(folder)
        self.surface = surface
        self.landmarks = [n for n in LANDMARKS if n in surface.landmarks]
        self._landmark_nodes = np.array([surface.landmarks[n] for n in self.landmarks],
                                        dtype=np.int64)
        self._rows_lock = threading.Lock()      # rows and keypoints.csv
        self._write_lock = threading.Lock()     # the written times, the surfaces, whale.pvd
        self._rows: dict[float, Row] = {}
        self._keypoints_file = None
        self._pvd: dict[float, str] = {}
        self._written: set[float] = set()
        self._load_pvd()

    # --- keypoints.csv ----------------------------------------------------------------------

    def served(self, served, restart: bool) -> None:
        """A newly served time: after a (re)start drop the rows from it on, write the rows
        before it, and keep its row until its forces come (:meth:`add_forces`)."""
        t, disp = served.t, served.disp
        if restart:
            self.restart(t)
        self.flush_rows(t)
        nodes = self._landmark_nodes
        self._rows[t] = Row((self.surface.points[nodes] + disp[nodes]).ravel(), None)

    def add_forces(self, t: float, forces: np.ndarray) -> None:
        """The patch's (6,) forces the link reported with its REQUEST at t."""
        with self._rows_lock:
            row = self._rows.get(t)
            if row is None:
                return
            row.forces = forces
        self.flush_rows(t, inclusive=True)

    def flush_rows(self, t: float = math.inf, inclusive: bool = False) -> None:
        """Write the keypoint rows of times before t (or up to t), in time order."""
        with self._rows_lock:
            times = sorted(k for k in self._rows if k < t or (inclusive and k == t))
            rows = [(k, self._rows.pop(k)) for k in times]
            if not rows:
                return
            f = self._keypoints()
            for k, row in rows:
                fields = [repr(float(v)) for v in (k, *row.landmarks)]
                forces = row.forces
                if forces is not None and np.all(np.isfinite(forces)):
                    fields += [repr(float(v)) for v in forces]
                else:
                    # unknown (the first REQUEST after a restart carries no forces yet, or a
                    # link did not report): empty fields, never NaN
                    fields += [""] * len(FORCE_COLUMNS)
                f.write(",".join(fields) + "\n")
            f.flush()

    def _keypoints_header(self) -> str:
        cols = ["t"] + [f"{n}_{x}" for n in self.landmarks for x in "xyz"] + list(FORCE_COLUMNS)
        return ",".join(cols) + "\n"

    def _keypoints(self):
        if self._keypoints_file is None:
            self._keypoints_file = open(self.folder / "keypoints.csv", "a")  # noqa: SIM115
        return self._keypoints_file

    def restart(self, t: float) -> None:
        """A (re)start at t: drop keypoint rows and ParaView entries from t on."""
        with self._rows_lock:
            for k in [k for k in self._rows if k >= t]:
                del self._rows[k]
            if self._keypoints_file is not None:
                self._keypoints_file.close()
                self._keypoints_file = None
            path = self.folder / "keypoints.csv"
            header = self._keypoints_header()
            keep = [header]
            if path.exists():
                lines = path.read_text().splitlines(keepends=True)
                if lines and lines[0] == header:
                    keep += [line for line in lines[1:]
                             if line.endswith("\n") and _row_time(line) < t]
            atomic_write_text(path, "".join(keep))
        with self._write_lock:
            self._pvd = {k: v for k, v in self._pvd.items() if k < t}
            self._written = {k for k in self._written if k < t}
            vtkfiles.write_pvd(self.folder / "whale.pvd", self._pvd)

    # --- the surface at written times -------------------------------------------------------

    def written(self, t: float) -> bool:
        with self._write_lock:
            return t in self._written

    def write(self, served, also: Callable | None = None) -> bool:
        """The surface at a written time and its entry in whale.pvd, once per time;
        ``also(served)`` (the state file) is written with it. False if t was written."""
        with self._write_lock:
            if served.t in self._written:
                return False
            self._write_surface(served)
            if also is not None:
                also(served)
            self._pvd[served.t] = f"whale_{time_name(served.t)}.vtp"
            vtkfiles.write_pvd(self.folder / "whale.pvd", self._pvd)
            self._written.add(served.t)
        return True

    def _write_surface(self, served) -> None:
        vtkfiles.write_vtp(self.folder / f"whale_{time_name(served.t)}.vtp",
                           np.asarray(self.surface.points) + served.disp,
                           np.asarray(self.surface.triangles, dtype=np.int64),
                           point_data={"displacement": served.disp, "velocity": served.vel},
                           field_data={"time": np.array([served.t])})

    def _load_pvd(self) -> None:
        path = self.folder / "whale.pvd"
        if not path.exists():
            return
        try:
            self._pvd.update(vtkfiles.read_pvd(path))
        except VTKFileError as exc:
            log.warning("ignoring unreadable %s: %s", path, exc)

    def close(self) -> None:
        with self._rows_lock:
            if self._keypoints_file is not None:
                self._keypoints_file.close()
                self._keypoints_file = None


def _row_time(line: str) -> float:
    """The time of a keypoints.csv row; infinite (never kept) when it has none."""
    head = line.split(",", 1)[0]
    try:
        return float(head)
    except ValueError:
        return math.inf


# --- statistics -------------------------------------------------------------------------------


class ServerStats:
    """The step-server's statistics: per request, per link; written as server-stats.json."""

    def __init__(self):
        self._lock = threading.Lock()
        self.req_compute: list[float] = []
        self.req_transfer: list[float] = []
        self.links = 0
        self.ranks: int | None = None
        self.patch_points = 0
        self.max_distance = 0.0

    def add_request(self, compute_s: float, transfer_s: float) -> None:
        with self._lock:
            self.req_compute.append(compute_s)
            self.req_transfer.append(transfer_s)

    def add_link(self, n_ranks: int, n_points: int, max_distance: float) -> None:
        with self._lock:
            self.ranks = n_ranks
            self.links += 1
            self.patch_points = n_points
            self.max_distance = max(self.max_distance, max_distance)

    def report(self, timeline_stats, failure: str | None) -> tuple[dict, str]:
        """(the statistics, the summary line) with the timeline's ``steps``, ``ahead_hits``,
        ``ahead_tries`` and ``advance_s``."""
        ts = timeline_stats
        n = len(self.req_compute)
        mean_c = float(np.mean(self.req_compute)) if n else 0.0
        mean_t = float(np.mean(self.req_transfer)) if n else 0.0
        stats = {
            "requests": n,
            "steps": ts.steps,
            "ranks": self.ranks or 0,
            "links": self.links,
            "mean_compute_s": mean_c,
            "mean_transfer_s": mean_t,
            "median_compute_s": float(np.median(self.req_compute)) if n else 0.0,
            "median_transfer_s": float(np.median(self.req_transfer)) if n else 0.0,
            "mean_step_advance_s": float(np.mean(ts.advance_s)) if ts.advance_s else 0.0,
            "work_ahead_hits": ts.ahead_hits,
            "work_ahead_tries": ts.ahead_tries,
            "patch_points": int(self.patch_points),
            "max_mapping_distance_m": self.max_distance,
            "model_failure": failure,
        }
        summary = (
            f"{n} requests served ({ts.steps} steps, {stats['ranks']} ranks, "
            f"{self.links} link{'s' if self.links != 1 else ''}), mean compute "
            f"{1e3 * mean_c:.3g} ms per request, transfer {1e3 * mean_t:.3g} ms, work-ahead hits "
            f"{ts.ahead_hits}/{ts.ahead_tries}")
        return stats, summary

    def write(self, folder: Path, stats: dict) -> None:
        if folder.is_dir():
            write_json(folder / "server-stats.json", stats)
