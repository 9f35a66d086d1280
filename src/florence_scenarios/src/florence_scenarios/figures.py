"""The demo report's pictures (PNG, matplotlib without a display). ROS-free.

- :func:`paths_over_map`: the map with the robot's true and estimated paths, the people's paths and
  labelled marks (where each service call ended);
- :func:`timeline`: values over simulated time (the distance to the user while following) with
  reference lines (the desired distance, the edge of personal space);
- :func:`bars`: one value per name (CPU per node).
Units: metres, seconds.
"""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np


def _xy(points):
    return np.asarray(points, float).reshape(-1, 2) if len(points) else np.zeros((0, 2))


def paths_over_map(png, grid, robot_truth, robot_estimate=(), people=None, marks=(), title=""):
    """``grid``: a map_server GridMap; paths are sequences of (x, y) [m] in the map frame; ``people``
    maps an id to its path; ``marks`` are (x, y, label)."""
    left, right, bottom, top = grid.extent
    aspect = (top - bottom) / max(right - left, 1e-9)
    fig, ax = plt.subplots(figsize=(7.0, min(7.0 * aspect, 11.0) + 0.6))
    ax.imshow(grid.shades(), cmap="gray", origin="lower", extent=grid.extent, vmin=0, vmax=1)
    for pid, path in sorted((people or {}).items()):
        p = _xy(path)
        if len(p):
            ax.plot(p[:, 0], p[:, 1], "-", lw=3, alpha=0.35, label=f"{pid} (truth)")
    est = _xy(robot_estimate)
    if len(est):
        ax.plot(est[:, 0], est[:, 1], "--", lw=1.0, color="tab:orange", label="robot (amcl)")
    truth = _xy(robot_truth)
    if len(truth):
        ax.plot(truth[:, 0], truth[:, 1], "-", lw=1.3, color="tab:blue", label="robot (truth)")
        ax.plot(*truth[0], "o", color="tab:blue", ms=5)
    for x, y, label in marks:
        ax.plot(x, y, "x", color="black", ms=6)
        ax.annotate(str(label), (x, y), textcoords="offset points", xytext=(4, 4), fontsize=7)
    ax.set_xlim(left, right)
    ax.set_ylim(bottom, top)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(png, dpi=100)
    plt.close(fig)


def timeline(png, series, ylabel, hlines=(), title=""):
    """``series``: {label: (times [s], values)}; ``hlines``: (value, label) reference lines."""
    fig, ax = plt.subplots(figsize=(7.0, 3.0))
    for label, (t, v) in series.items():
        if len(t):
            ax.plot(t, v, "-", lw=1.2, label=label)
    for value, label in hlines:
        ax.axhline(value, ls=":", color="gray")
        ax.annotate(label, (0.0, value), xycoords=("axes fraction", "data"), textcoords="offset points",
                    xytext=(3, 2), fontsize=7, color="gray")
    ax.set_xlabel("simulated time [s]")
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3)
    if series:
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png, dpi=100)
    plt.close(fig)


def bars(png, values, xlabel, title="", limit=None):
    """Horizontal bars of ``values`` ({name: number}), largest on top; ``limit`` a reference line."""
    names = sorted(values, key=values.get)
    fig, ax = plt.subplots(figsize=(7.0, 0.6 + 0.25 * max(len(names), 1)))
    ax.barh(names, [values[n] for n in names], color="tab:blue")
    if limit is not None:
        ax.axvline(limit, ls=":", color="tab:red")
    ax.set_xlabel(xlabel)
    ax.set_title(title, fontsize=9)
    ax.tick_params(labelsize=7)
    fig.tight_layout()
    fig.savefig(png, dpi=100)
    plt.close(fig)
