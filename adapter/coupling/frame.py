"""PLACEHOLDER until the frame branch lands."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FrameState:
    velocity: np.ndarray
    acceleration: np.ndarray
