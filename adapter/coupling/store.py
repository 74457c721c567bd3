"""The step-server's restart state: ``<case>/adapter/state_<t>.npz``, one per written time.

A state file holds the animator's checkpoint right after computing the motion at ``t``, with the
fingerprint of the scene, surface and internal step it belongs to: a restarted server resumes
from the newest state that can reach the time OpenFOAM asks for, and passes over a file that is
cut short, empty or another scene's.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import math
import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

log = logging.getLogger(__name__)

#: the layout of a state file; a file of another format is passed over
STATE_FORMAT = 1
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
