"""The numerics study's outputs: its CSV files and its charts (stability.png,
work_precision.png, resolution.png). They draw and write the rows the studies of
:mod:`adapter.studies.numerics` measured.
"""

from __future__ import annotations

import csv
from pathlib import Path

from adapter.motion.stability import EXPLICIT


def write_csv(path: Path, rows: list[dict]) -> None:
    """``rows`` (dicts with the same keys) as a CSV file with a header."""
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def plot_stability(rows, path) -> None:
    """The largest stable step against the damping mu per method, predicted and measured,
    with the paper's criterion (rows of :func:`~adapter.studies.numerics.stability_study`)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    colors = dict(zip(EXPLICIT, ("C0", "C1", "C2", "C3"), strict=True))
    for m in EXPLICIT:
        r = [x for x in rows if x["method"] == m]
        mu = [x["mu"] for x in r]
        ax.plot(mu, [x["predicted_dt"] for x in r], "-", color=colors[m], label=f"{m} predicted")
        ax.plot(mu, [x["measured_dt"] for x in r], "o", color=colors[m], label=f"{m} measured")
    r = [x for x in rows if x["method"] == "backward_euler"]
    ax.plot([x["mu"] for x in r], [x["measured_dt"] for x in r], "s", color="C4",
            label="backward_euler measured (predicted: any)")
    r = [x for x in rows if x["method"] == "forward_euler"]
    ax.plot([x["mu"] for x in r], [x["paper_criterion_dt"] for x in r], "k--",
            label="paper: dt |F| <= 1 (F in m/s^2)")
    ax.plot([x["mu"] for x in r], [x["paper_criterion_dt_mm"] for x in r], "k:",
            label="paper, the same whale in mm")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("damping mu (1/s)")
    ax.set_ylabel("largest stable step (s)")
    ax.set_title("Largest stable step against damping, 500-node whale")
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_xy(groups, xkey, ykey, xlabel, ylabel, title, path) -> None:
    """A log-log chart: per label of ``groups``, its rows' ``ykey`` against ``xkey``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for label, rows in groups.items():
        ax.loglog([r[xkey] for r in rows], [r[ykey] for r in rows], "o-", label=label)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
