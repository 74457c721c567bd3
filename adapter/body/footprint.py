"""A fin's root as the footprint of its root section on the body (:func:`foil_root`): the
root loop of the fin's patch moved on the body's smooth surface into the outline of the
symmetric NACA four-digit foil of the fin's root thickness ratio
(:mod:`adapter.body.procedural` grows the flippers and the flukes from such loops;
docs/geometry.md, "The flippers' root" and "The flukes' root").

``surface(s, phi, length) -> (y, z)``, each (len(s), len(phi)): the body's smooth surface
the rings sample, at stations ``s`` (fractions of L) and angles ``phi`` (0 dorsal, pi/2 the
left side).
"""

from __future__ import annotations

import numpy as np

from adapter.body.fins import ROOT_LEAD, ROOT_TRAIL, Fin, foil_half_thickness
from adapter.errors import GeometryError


def foil_root(s: np.ndarray, n_phi: int, fin: Fin, surface, length: float,
              lead: float = ROOT_LEAD, trail: float = ROOT_TRAIL, cut: bool = False) -> dict:
    """A fin's root loop moved on the body's surface into the footprint of a foil: the
    symmetric NACA section of the fin's root thickness ratio, its chord along the patch's
    middle line (the phi of the short sides' middle nodes). The nose (the leading side's middle
    node) moves forward by ``lead`` of the ring spacing ahead of the patch, the trailing point
    back by ``trail`` of the one behind; every other loop node keeps its ring and moves around
    it to the foil's half-thickness at its ring's chord fraction, measured as arc length along
    the ring. Where the foil is wider than the patch the rows beside its long sides make room,
    each farther row by less, so that no quad there narrows below 0.6 of its width. Returns
    ``{(ring, phi index): position}`` of every node that moves (the left side). A patch two
    quads across (``fin.b``, even), whose short sides' middle nodes make the nose and the tail;
    a short side more than two quads across puts its other nodes on the outline between its
    corners' ring and its point (:func:`_short_sides`). With ``cut`` the trailing side
    stays on the patch's last ring, the foil cut off there: its nodes spread evenly across the
    foil's thickness at that ring (the chord still ends ``trail`` of a spacing behind it, so
    the cut edge is thin, not a point), for a patch whose last ring is followed by quads too
    slender to take a node moved along the body (the flukes'). The ring behind the patch must
    exist (the flukes' patch ends one ring before the tail's last)."""
    i0, i1, j0, j1 = fin.ring0, fin.ring0 + fin.a, fin.phi0, fin.phi0 + fin.b
    jc = fin.phi0 + fin.b // 2
    s_nose = s[i0] - lead * (s[i0] - s[i0 - 1])
    s_tail = s[i1] + trail * (s[i1 + 1] - s[i1])
    chord, dphi = (s_tail - s_nose) * length, 2 * np.pi / n_phi
    tc = fin.thickness_ratio(0.0)

    def half(st):
        """The foil's half-thickness (m) at station ``st``."""
        return float(foil_half_thickness(np.array((st - s_nose) / (s_tail - s_nose)), tc)) * chord

    moved = {(i0, jc): _at(surface, s_nose, jc * dphi, length)}
    if not cut:
        moved[(i1, jc)] = _at(surface, s_tail, jc * dphi, length)
    moved.update(_short_sides(s, fin, n_phi, (s_nose, s[i1] if cut else s_tail), half,
                              surface, length))
    shift = {}   # (ring, phi index) of a long side's node -> its turn about the body (rad)
    for i in range(i0, i1 + 1):
        for j in (j0, j1):
            shift[(i, j)] = _phi_at_arc(surface, s[i], jc * dphi,
                                        np.sign(j - jc) * half(s[i]), length) - j * dphi
    widest = max(max(-d if j == j0 else d for (_, j), d in shift.items()), 0.0)
    rows = max(int(np.ceil(widest / (0.4 * dphi))) - 1, 0)  # rows beside a side that make room
    if j0 - rows <= 0 or j1 + rows >= n_phi // 2:
        raise GeometryError(f"the {fin.a} x {fin.b} patch's foil root needs {rows} rows beside "
                            "it, past the body's midline; use the rectangular root")
    for (i, j), d in shift.items():
        out = 1 if j == j1 else -1
        for k in range(rows + 1):
            phi = (j + out * k) * dphi + d * (1 - k / (rows + 1))
            moved[(i, j + out * k)] = _at(surface, s[i], phi, length)
    return moved


def _at(surface, st: float, phi: float, length: float) -> np.ndarray:
    """The point (m) of the body's smooth ``surface`` at station ``st`` and angle ``phi``."""
    y, z = surface(np.array([st]), np.array([phi]), length)
    return np.array([st * length, y[0, 0], z[0, 0]])


def _short_sides(s: np.ndarray, fin: Fin, n_phi: int, ends, half, surface,
                 length: float) -> dict:
    """The nodes of a foil root's short sides between a corner and the side's middle (none
    on a side two quads across): each onto the foil's outline (``half``: its half-thickness
    (m) at a station) at a station between the corners' ring and the side's point (``ends``:
    the nose's and the trailing point's stations), the share of the way from the point
    1 - cos(pi u / 2) at the nose (the nodes closer together at the round leading edge, as
    the sections' are) and u at the trailing point, u the node's share of the way from the
    middle to the corner in phi index. A trailing point on the corners' ring (a cut foil,
    :func:`foil_root`) leaves its side there, the nodes at u of the half-thickness. Returns
    ``{(ring, phi index): position}``."""
    j0, jc, dphi = fin.phi0, fin.phi0 + fin.b // 2, 2 * np.pi / n_phi
    moved = {}
    for ring, s_end, nose in ((fin.ring0, ends[0], True), (fin.ring0 + fin.a, ends[1], False)):
        cut = s_end == s[ring]   # the side stays on its ring, straight across the foil
        for j in range(j0 + 1, j0 + fin.b):
            if j == jc:
                continue
            u = abs(j - jc) / (jc - j0)
            st = s_end + ((1 - np.cos(0.5 * np.pi * u)) if nose else u) * (s[ring] - s_end)
            arc = u * half(st) if cut else half(st)
            phi = _phi_at_arc(surface, st, jc * dphi, np.sign(j - jc) * arc, length)
            moved[(ring, j)] = _at(surface, st, phi, length)
    return moved


def _phi_at_arc(surface, st: float, phi_c: float, arc: float, length: float) -> float:
    """The angle phi on the ring at station ``st`` that lies ``arc`` (m, signed: toward larger
    phi when positive) along the ring from ``phi_c``: sampled every 0.001 rad within 0.6 rad
    of it, or within 1.2 rad when the arc reaches farther."""
    for reach in (0.6, 1.2):
        phi = phi_c + np.linspace(-reach, reach, int(round(2000 * reach)) + 1)
        y, z = surface(np.array([st]), phi, length)
        seg = np.hypot(np.diff(y[0]), np.diff(z[0]))
        along = np.concatenate([[0.0], np.cumsum(seg)])
        along -= np.interp(phi_c, phi, along)
        if along[0] <= arc <= along[-1]:
            return float(np.interp(arc, along, phi))
    raise GeometryError(f"a foil root {abs(arc):.3f} m across half its thickness does not fit "
                        f"on the body's ring at {st:.3f} L; use the rectangular root")
