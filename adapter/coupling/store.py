"""The step-server's restart state: ``<case>/adapter/state_<t>.npz`` and ``frame_<t>.json``,
one each per written time.

A state file holds the animator's checkpoint right after computing the motion at ``t``, with the
fingerprint of the scene, surface and internal step it belongs to: a restarted server resumes
from the newest state that can reach the time OpenFOAM asks for, and passes over a file that is
cut short, empty or another scene's.

A frame file holds the whale's frame at ``t`` (:mod:`.frame`: its velocity and acceleration,
and the frame's own state after answering ``t``) and, once the next REQUEST has come, that
request's loads (``next``: the forces and moments of the step ending at ``t``). A restarted
OpenFOAM's first REQUEST carries no loads (NaN); the frame is answered with ``next`` instead,
so that a restart from a written time repeats the frame of the run that did not stop.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import math
import os
import threading
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from adapter.jsonfiles import dumps

log = logging.getLogger(__name__)

#: the layout of a state file; a file of another format is passed over
STATE_FORMAT = 1
#: the layout of a frame file
FRAME_FORMAT = 1
#: what reading a cut-short, empty or foreign state file raises
UNREADABLE = (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile)


def time_name(t: float) -> str:
    """The name of a time in file names: ``0.0125``, ``1e-05``."""
    return format(t, ".12g")


def atomic_write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file and a rename."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


@dataclasses.dataclass(frozen=True)
class FrameRecord:
    """A frame file: the frame at ``time`` (``velocity``, ``acceleration``), the frame's own
    ``state`` after answering it, and ``next``, the (12,) loads of the REQUEST that followed
    (None until it came, or when they were not known)."""

    time: float
    velocity: np.ndarray
    acceleration: np.ndarray
    state: dict
    next: np.ndarray | None


def copy_state(ckpt: dict) -> dict:
    """A deep copy of an animator checkpoint (its arrays copied)."""
    return {k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in ckpt.items()}


def fingerprint(scene, surface, dt: float) -> str:
    """What a state file must match to be restored: the scene (but its name and folder), the
    surface's points and triangles and the animator's internal step (s)."""
    fields = dataclasses.asdict(scene)
    fields.pop("base_dir", None)
    fields.pop("name", None)
    h = hashlib.sha256(json.dumps(fields, sort_keys=True, default=str, allow_nan=False).encode())
    h.update(np.ascontiguousarray(surface.points, dtype=np.float64).tobytes())
    h.update(np.ascontiguousarray(surface.triangles, dtype=np.int64).tobytes())
    h.update(repr(float(dt)).encode())
    return h.hexdigest()


class StateStore:
    """The state files of one case's ``adapter/`` folder.

    Parameters
    ----------
    folder : where ``state_<t>.npz`` live.
    fingerprint : :func:`fingerprint` of the scene served; other files are passed over.
    dt : the animator's internal step (s).
    """

    def __init__(self, folder, fingerprint: str, dt: float):
        self.folder = Path(folder)
        self.fingerprint = fingerprint
        self.dt = float(dt)
        self._frame_lock = threading.Lock()
        #: the frame file last saved by this server, until the next REQUEST's loads are in it
        self._frame_waiting: dict | None = None

    def path(self, t: float) -> Path:
        return self.folder / f"state_{time_name(t)}.npz"

    def save(self, served) -> None:
        """Save the checkpoint of a served time (``t``, ``ckpt``, ``animator_time``)."""
        arrays: dict[str, Any] = {f"ckpt:{k}": np.asarray(v) for k, v in served.ckpt.items()}
        arrays.update(format=np.array(STATE_FORMAT), time=np.array(served.t),
                      animator_time=np.array(served.animator_time),
                      dt=np.array(self.dt), fingerprint=np.array(self.fingerprint))
        path = self.path(served.t)
        tmp = path.with_name(path.name + ".tmp")
        with open(tmp, "wb") as f:
            np.savez(f, **arrays)
        os.replace(tmp, path)
        if getattr(served, "frame_state", None) is not None:
            self._save_frame(served)

    # --- the frame files ------------------------------------------------------------------------

    def frame_path(self, t: float) -> Path:
        return self.folder / f"frame_{time_name(t)}.json"

    def _save_frame(self, served) -> None:
        record = {"format": FRAME_FORMAT, "fingerprint": self.fingerprint, "time": served.t,
                  "velocity": served.frame.velocity.tolist(),
                  "acceleration": served.frame.acceleration.tolist(),
                  "state": served.frame_state, "next": None}
        with self._frame_lock:
            atomic_write_text(self.frame_path(served.t), dumps(record) + "\n")
            self._frame_waiting = record

    def add_frame_next(self, t: float, loads: np.ndarray) -> None:
        """The loads of the REQUEST after ``t``: into ``t``'s frame file, if this server saved
        it and they are not in it yet (finite loads only)."""
        with self._frame_lock:
            record, self._frame_waiting = self._frame_waiting, None
            if record is None or record["time"] != t or not np.isfinite(loads).all():
                return
            record["next"] = [float(v) for v in loads]
            atomic_write_text(self.frame_path(t), dumps(record) + "\n")

    def frame_record(self, t: float) -> FrameRecord | None:
        """The newest readable frame file of this scene at or before ``t``; None if none."""
        candidates = []
        for path in self.folder.glob("frame_*.json"):
            try:
                candidates.append((float(path.stem[len("frame_"):]), path))
            except ValueError:      # not a time: someone else's file
                continue
        for at, path in sorted(candidates, reverse=True):
            if at > t:
                continue
            try:
                d = json.loads(path.read_text())
                if d["format"] != FRAME_FORMAT or d["fingerprint"] != self.fingerprint:
                    continue
                nxt = None if d["next"] is None else np.array(d["next"], dtype=np.float64)
                return FrameRecord(float(d["time"]), np.array(d["velocity"], dtype=np.float64),
                                   np.array(d["acceleration"], dtype=np.float64),
                                   dict(d["state"]), nxt)
            except (*UNREADABLE, TypeError) as exc:
                log.warning("ignoring unreadable frame file %s: %s", path, exc)
        return None

    def newest_time(self) -> float:
        """The latest time with a saved state file (a restart may start there); 0 if none."""
        times = []
        for path in self.folder.glob("state_*.npz"):
            try:
                times.append(float(path.stem[len("state_"):]))
            except ValueError:      # not a time: someone else's file
                continue
        return max(times, default=0.0)

    def restore(self, animator, t: float, newer_than: float = -math.inf) -> bool:
        """Restore into ``animator`` the newest usable state at or before ``t`` (and after
        ``newer_than``, its time); False if there is none.

        A state file that cannot be read (cut short, empty, another scene's) is passed over
        with a warning: the caller then falls back on the next one, or on replay from t = 0.
        """
        candidates = []
        for path in self.folder.glob("state_*.npz"):
            try:
                with np.load(path, allow_pickle=False) as z:
                    if (int(z["format"]) != STATE_FORMAT
                            or str(z["fingerprint"]) != self.fingerprint):
                        continue
                    at, dt = float(z["animator_time"]), float(z["dt"])
            except UNREADABLE as exc:
                log.warning("ignoring unreadable state file %s: %s", path, exc)
                continue
            if at - dt <= t and at > newer_than:
                candidates.append((at, path))
        for at, path in sorted(candidates, reverse=True):
            try:
                with np.load(path, allow_pickle=False) as z:
                    ckpt = {k[5:]: (z[k].item() if z[k].ndim == 0 else np.array(z[k]))
                            for k in z.files if k.startswith("ckpt:")}
                animator.restore(ckpt)
            except UNREADABLE as exc:
                log.warning("ignoring unreadable state file %s: %s", path, exc)
                continue
            log.info("restored the animator from %s (t = %s s) to reach t = %s s", path.name,
                     time_name(at), time_name(t))
            return True
        return False
