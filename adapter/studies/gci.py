"""Richardson extrapolation and Roache's grid convergence index (GCI) for three meshes.

Pure functions, after the procedure of Celik et al. (2008), "Procedure for estimation and
reporting of uncertainty due to discretization in CFD applications", J. Fluids Eng. 130(7)
078001 (the ASME policy; Roache's GCI with safety factor 1.25 for three meshes):

- meshes 1 (finest), 2, 3 (coarsest) with representative cell sizes h1 < h2 < h3, refinement
  ratios r21 = h2 / h1 and r32 = h3 / h2 (at least 1.3), values f1, f2, f3;
- e21 = f2 - f1, e32 = f3 - f2; the convergence ratio R = e21 / e32: 0 < R < 1 monotone
  convergence, -1 < R < 0 oscillatory convergence, |R| >= 1 divergence;
- the observed order p = ln|e32 / e21| / ln r for one ratio r (= ln((f3 - f2)/(f2 - f1)) / ln r
  when monotone); for r21 != r32 Celik's fixed point
  p = |ln|e32 / e21| + q(p)| / ln r21, q(p) = ln((r21^p - s) / (r32^p - s)), s = sign(e32 / e21);
- the extrapolated value f_ext = (r21^p f1 - f2) / (r21^p - 1);
- the relative errors e_a = |(f1 - f2) / f1| and e_ext = |(f_ext - f1) / f_ext|;
- GCI_fine = 1.25 e_a / (r21^p - 1) (relative), 1.25 |e21| / (r21^p - 1) in the figure's unit.

With divergence there is no extrapolated value and no GCI (None); an oscillatory sequence gets
them from |R| (Celik's procedure), flagged by ``convergence``.
"""

from __future__ import annotations

import math
import typing

#: Roache's safety factor for three or more meshes
SAFETY = 1.25


def representative_h(cells: float, volume: float = 1.0, dim: int = 3) -> float:
    """Celik's representative cell size (volume / cells)^(1/dim)."""
    return (float(volume) / float(cells)) ** (1.0 / dim)


def convergence_type(f1: float, f2: float, f3: float) -> tuple[str, float]:
    """("monotone" | "oscillatory" | "divergent" | "converged", R = e21 / e32)."""
    e21, e32 = f2 - f1, f3 - f2
    if e32 == 0:
        return ("converged", 0.0) if e21 == 0 else ("divergent", math.inf)
    ratio = e21 / e32
    if abs(ratio) >= 1:
        return "divergent", ratio
    return ("monotone" if ratio > 0 else "oscillatory" if ratio < 0 else "converged"), ratio


def observed_order(f1: float, f2: float, f3: float, r21: float, r32: float | None = None,
                   tol: float = 1e-12, max_iter: int = 500) -> float:
    """The observed order p (Celik's fixed-point iteration when r21 != r32); nan when two of
    the values coincide."""
    r32 = r21 if r32 is None else r32
    e21, e32 = f2 - f1, f3 - f2
    if e21 == 0 or e32 == 0:
        return math.nan
    s = math.copysign(1.0, e32 / e21)
    base = math.log(abs(e32 / e21))
    if abs(r21 - r32) < 1e-14:
        return base / math.log(r21)
    p = abs(base) / math.log(r21)
    for _ in range(max_iter):
        try:
            q = math.log((r21**p - s) / (r32**p - s))
        except (ValueError, ZeroDivisionError, OverflowError):
            return math.nan
        new = abs(base + q) / math.log(r21)
        if abs(new - p) < tol:
            return new
        p = new
    return p


def gci(f1: float, f2: float, f3: float, r21: float, r32: float | None = None,
        safety: float = SAFETY) -> dict:
    """Everything of the three-mesh procedure for one figure (f1 on the finest mesh).

    Returns a dict: ``values`` [f1, f2, f3], ``r21``, ``r32``, ``e21``, ``e32``, ``ratio``
    (R = e21 / e32), ``convergence``, ``p``, ``extrapolated``, ``e_a``, ``e_ext``,
    ``gci_fine`` (relative), ``gci_fine_abs`` (in the figure's unit), ``gci_coarse``
    (Celik's GCI32 of mesh 2, relative to f2); None where undefined (divergence, a zero
    value)."""
    r32 = r21 if r32 is None else r32
    kind, ratio = convergence_type(f1, f2, f3)
    out: dict[str, typing.Any] = {
        "values": [f1, f2, f3], "r21": r21, "r32": r32, "e21": f2 - f1, "e32": f3 - f2,
        "ratio": None if not math.isfinite(ratio) else ratio, "convergence": kind,
        "p": None, "extrapolated": None, "e_a": None, "e_ext": None, "gci_fine": None,
        "gci_fine_abs": None, "gci_coarse": None, "safety": safety}
    if kind == "converged":
        out.update(extrapolated=f1, gci_fine=0.0, gci_fine_abs=0.0, e_a=0.0, e_ext=0.0)
        return out
    if kind == "divergent":
        return out
    p = observed_order(f1, f2, f3, r21, r32)
    if not math.isfinite(p) or p <= 0:
        return out
    out.update(with_order(f1, f2, f3, r21, r32, p, safety))
    return out


def with_order(f1: float, f2: float, f3: float, r21: float, r32: float, p: float,
               safety: float = SAFETY) -> dict:
    """The extrapolated value and the GCIs of three values for a given order ``p`` (the
    observed one, or the formal one in its place): ``p``, ``extrapolated``, ``gci_fine_abs``,
    ``e_a``, ``gci_fine``, ``e_ext``, ``gci_coarse`` (None where a value is zero)."""
    a21, a32 = r21**p, r32**p
    ext = (a21 * f1 - f2) / (a21 - 1)
    e_a = abs((f1 - f2) / f1) if f1 != 0 else None
    return {"p": p, "extrapolated": ext, "gci_fine_abs": safety * abs(f2 - f1) / (a21 - 1),
            "e_a": e_a, "gci_fine": None if e_a is None else safety * e_a / (a21 - 1),
            "e_ext": abs((ext - f1) / ext) if ext != 0 else None,
            "gci_coarse": safety * abs((f2 - f3) / f2) / (a32 - 1) if f2 != 0 else None}
