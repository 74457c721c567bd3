"""forces.png (adapter/reports/render.py): the cycle means, the gliding drag and the headline
numbers drawn on it, and the Fx axis saying that negative Fx is net thrust. Synthetic loads
with hand-computed means; the figure's artists are read back, and the PNG is written."""

import numpy as np
import pytest

from adapter.reports.render import forces_figure, forces_headline, plot_forces

PERIOD = 2.0


def _loads():
    t = np.arange(1, 801) * 0.01                    # 8 s, four cycles of 2 s
    s = np.sin(2 * np.pi * t / PERIOD)
    return ({"Time": t, "total:Fx": -800.0 + 2000.0 * s, "total:Fz": 300.0 * s,
             "total:P": 4000.0 + 3000.0 * s},
            {"Time": t, "total:Fx": np.full_like(t, 660.0), "total:Fz": np.zeros_like(t)})


#: the swimming_cost figures of those loads: a sine's mean over whole cycles is its offset
FIGURES = {"gliding_drag_N": 660.0, "swimming_mean_fx_N": -800.0,
           "swimming_mean_power_W": 4000.0, "froude_efficiency": 0.47,
           "cycle_means": {"start_s": [2.0, 4.0, 6.0], "fx_N": [-790.0, -799.0, -800.0],
                           "power_W": [4010.0, 4001.0, 4000.0]}}


def test_the_headline_has_the_numbers_and_says_what_negative_fx_is():
    text = forces_headline(FIGURES)
    assert "gliding drag 660 N" in text
    assert "swimming mean Fx -800 N (net thrust)" in text
    assert "mean power 4,000 W" in text and "Froude efficiency 0.47" in text
    assert "(net drag)" in forces_headline({"swimming_mean_fx_N": 120.0})
    assert forces_headline({}) == ""


def test_forces_png_draws_the_cycle_means_and_the_gliding_drag(tmp_path):
    import matplotlib.pyplot as plt

    swim, glide = _loads()
    fig = forces_figure(swim, glide, PERIOD, 2.0, FIGURES)
    ax_fx, _, ax_p = fig.axes
    assert "negative: net thrust" in ax_fx.get_ylabel()
    assert forces_headline(FIGURES) in ax_fx.get_title()

    def segments(ax):
        """The horizontal segments one cycle long: (start, level)."""
        out = []
        for line in ax.get_lines():
            x, y = np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)
            if len(x) == 2 and x[1] - x[0] == pytest.approx(PERIOD) and y[0] == y[1]:
                out.append((float(x[0]), float(y[0])))
        return sorted(out)

    assert segments(ax_fx) == [(2.0, -790.0), (4.0, -799.0), (6.0, -800.0)]
    assert segments(ax_p) == [(2.0, 4010.0), (4.0, 4001.0), (6.0, 4000.0)]
    levels = [line.get_ydata()[0] for line in ax_fx.get_lines()
              if "gliding drag" in str(line.get_label())]
    assert levels == [660.0]
    texts = [t.get_text() for t in ax_fx.texts + ax_p.texts]
    assert "last cycle mean -800 N" in texts and "last cycle mean 4,000 W" in texts
    plt.close(fig)
    plot_forces(swim, glide, PERIOD, 2.0, tmp_path / "forces.png", figures=FIGURES)
    assert (tmp_path / "forces.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # without the figures (an older caller): the loads alone, no error
    plt.close(forces_figure(swim, glide, PERIOD, 2.0))
