"""The flow study (adapter/study.py, adapter/gci.py): the GCI arithmetic against the worked
example of Celik et al. (2008), the three meshes' cell sizes, the study's machinery with a
model runner (known convergence, known self-propelled speed, stop and resume, chart, chooser),
and the study on the smoke whale with the real pimpleFoam."""

import math

import pytest

from adapter import gci as G


def test_gci_reproduces_celik_2008_table_1():
    """Celik et al. (2008), J. Fluids Eng. 130(7) 078001, Table 1, first column (2D meshes of
    18,000, 8,000 and 4,500 cells on the same domain; the reattachment length 6.063, 5.972,
    5.863). Published: r21 = 1.5, r32 = 1.333, p = 1.53, phi_ext21 = 6.1685, e_a21 = 1.5 %,
    e_ext21 = 1.7 %, GCI_fine21 = 2.2 %."""
    h = [G.representative_h(n, 76.0, dim=2) for n in (18000, 8000, 4500)]
    r21, r32 = h[1] / h[0], h[2] / h[1]
    assert round(r21, 3) == 1.5 and round(r32, 3) == 1.333
    g = G.gci(6.063, 5.972, 5.863, r21, r32)
    assert g["convergence"] == "monotone"
    assert round(g["p"], 2) == 1.53
    assert round(g["extrapolated"], 4) == 6.1685
    assert round(100 * g["e_a"], 1) == 1.5
    assert round(100 * g["e_ext"], 1) == 1.7
    assert round(100 * g["gci_fine"], 1) == 2.2
    assert g["gci_fine_abs"] == pytest.approx(g["gci_fine"] * 6.063)


def test_gci_with_one_ratio_is_the_closed_form_and_classifies_convergence():
    r = 1.3
    f1, f2, f3 = 10.0, 10.5, 11.4  # monotone: R = 0.5 / 0.9
    g = G.gci(f1, f2, f3, r)
    p = math.log((f3 - f2) / (f2 - f1)) / math.log(r)
    assert g["p"] == pytest.approx(p, rel=1e-12)
    assert g["extrapolated"] == pytest.approx(f1 + (f1 - f2) / (r**p - 1))
    assert g["gci_fine_abs"] == pytest.approx(1.25 * 0.5 / (r**p - 1))
    # an exact power law: f = 3 + 2 h^2 on h = 1, 1.3, 1.69 gives p = 2 and f_ext = 3
    fs = [3 + 2 * hh**2 for hh in (1.0, 1.3, 1.69)]
    g2 = G.gci(*fs, 1.3)
    assert g2["p"] == pytest.approx(2.0, rel=1e-9)
    assert g2["extrapolated"] == pytest.approx(3.0, rel=1e-12)
    assert G.gci(10.0, 9.8, 10.3, r)["convergence"] == "oscillatory"
    div = G.gci(10.0, 11.0, 11.5, r)
    assert div["convergence"] == "divergent" and div["gci_fine"] is None
