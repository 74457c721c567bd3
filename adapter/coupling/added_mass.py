"""The free whale's mass and added masses: Lamb's coefficients of a prolate spheroid
(Hydrodynamics, section 373) and the whale's :class:`Inertia` (adapter/coupling/surge.py moves
the frame with it)."""

from __future__ import annotations

import math
from dataclasses import dataclass

#: the axes a free whale may move along: surge (x) always, heave (z) when asked
SURGE, HEAVE = 0, 2


def spheroid_added_mass(length: float, diameter: float) -> tuple[float, float]:
    """Added-mass coefficients (k1 along the axis, k2 across it) of a prolate spheroid of this
    length and largest diameter, as fractions of its displaced mass (Lamb, Hydrodynamics,
    section 373: k1 = a0 / (2 - a0), k2 = b0 / (2 - b0))."""
    if not (length > diameter > 0):
        raise ValueError(f"a prolate spheroid needs length > diameter > 0, got {length!r}, "
                         f"{diameter!r}")
    e = math.sqrt(1.0 - (diameter / length) ** 2)
    log_term = math.log((1.0 + e) / (1.0 - e))
    a0 = 2.0 * (1.0 - e * e) / e ** 3 * (0.5 * log_term - e)
    b0 = 1.0 / (e * e) - (1.0 - e * e) / (2.0 * e ** 3) * log_term
    return a0 / (2.0 - a0), b0 / (2.0 - b0)


def spheroid_added_inertia(length: float, diameter: float) -> float:
    """Added moment of inertia of a prolate spheroid turning about a diameter, as a fraction of
    the moment of inertia of its displaced fluid (Lamb, section 373: k' = e^4 (b0 - a0) /
    ((2 - e^2) (2 e^2 - (2 - e^2) (b0 - a0))))."""
    if not (length > diameter > 0):
        raise ValueError(f"a prolate spheroid needs length > diameter > 0, got {length!r}, "
                         f"{diameter!r}")
    e2 = 1.0 - (diameter / length) ** 2
    e = math.sqrt(e2)
    log_term = math.log((1.0 + e) / (1.0 - e))
    a0 = 2.0 * (1.0 - e2) / e ** 3 * (0.5 * log_term - e)
    b0 = 1.0 / e2 - (1.0 - e2) / (2.0 * e ** 3) * log_term
    d = b0 - a0
    return e2 * e2 * d / ((2.0 - e2) * (2.0 * e2 - (2.0 - e2) * d))


@dataclass(frozen=True)
class Inertia:
    """The whale's mass and its added masses along x (surge) and z (heave), kg."""

    mass_kg: float
    added_surge_kg: float
    added_heave_kg: float

    @classmethod
    def of_body(cls, volume_m3: float, length_m: float, diameter_m: float,
                density: float) -> Inertia:
        """A neutrally buoyant whale of this enclosed volume; added masses from the prolate
        spheroid of its length and largest diameter, on its own volume."""
        k1, k2 = spheroid_added_mass(length_m, diameter_m)
        mass = density * volume_m3
        return cls(mass, k1 * mass, k2 * mass)

    def added(self, axis: int) -> float:
        return self.added_surge_kg if axis == SURGE else self.added_heave_kg
