"""How good a map built by SLAM is, against the world's ground truth (no ROS).

- Trajectory: the absolute trajectory error (ATE, Sturm et al. 2012): the estimated positions are
  aligned to the true ones by the rigid motion (rotation + translation, no scale) that fits them
  best in least squares (Umeyama 1991), then the RMS of the remaining position errors. Also given
  anchored at the start (the map frame starts where the robot started, as slam_gmapping's does).
- Map: the built map is carried into the true map's grid through the same alignment, cell centre by
  cell centre (nearest cell). Then, with the true map of the world at the laser's height
  (florence_sim's generated map):

  * occupied-cell precision: the built map's occupied cells that lie within one cell (the 8
    neighbours) of a truly occupied cell;
  * occupied-cell recall: of the truly occupied cells the laser saw on the tour, those within one
    cell of an occupied cell of the built map. "Saw" is judged by the same scans ray-traced from the
    true poses (a perfect-pose map): a truly occupied cell within one cell of one of its hits. (The
    inside of walls and the back of furniture against a wall are no one's to see.)
  * F1 of the two;
  * free-space agreement: of the cells the built map calls free, the fraction free in the world
    (strict, cell by cell: a free cell in a wall or outside the apartment disagrees);
  * free-space coverage: of the truly free cells the tour's beams crossed (the perfect-pose map's
    free cells), the fraction the built map calls free.
"""

import math

import numpy as np
from scipy import ndimage

from florence_common import angles

FREE, UNKNOWN, OCCUPIED = 0, -1, 100


def align_se2(est_xy, true_xy):
    """(rotation angle [rad], translation (2,) [m]) of the rigid motion that carries ``est_xy`` [N, 2] onto
    ``true_xy`` [N, 2] best in least squares (Umeyama, without scale)."""
    est, true = np.asarray(est_xy, float).reshape(-1, 2), np.asarray(true_xy, float).reshape(-1, 2)
    mu_e, mu_t = est.mean(axis=0), true.mean(axis=0)
    cov = (true - mu_t).T @ (est - mu_e) / len(est)
    u, _, vt = np.linalg.svd(cov)
    d = np.diag([1.0, np.sign(np.linalg.det(u @ vt))])
    r = u @ d @ vt
    theta = math.atan2(r[1, 0], r[0, 0])
    return theta, mu_t - r @ mu_e


def apply_se2(theta, t, xy):
    c, s = math.cos(theta), math.sin(theta)
    xy = np.asarray(xy, float).reshape(-1, 2)
    return np.column_stack([c * xy[:, 0] - s * xy[:, 1] + t[0], s * xy[:, 0] + c * xy[:, 1] + t[1]])


def trajectory_errors(est, truth, anchor=None):
    """Per-pose position error [m] and |yaw error| [rad] of ``est`` [N, 3] against ``truth`` [N, 3], and the
    alignment used (theta, t): the best rigid fit, or with ``anchor`` (x, y, yaw) the given pose of the
    estimate's frame in the world."""
    est, truth = np.asarray(est, float).reshape(-1, 3), np.asarray(truth, float).reshape(-1, 3)
    if anchor is None:
        theta, t = align_se2(est[:, :2], truth[:, :2])
    else:
        theta, t = float(anchor[2]), np.asarray(anchor[:2], float)
    xy = apply_se2(theta, t, est[:, :2])
    pos = np.hypot(xy[:, 0] - truth[:, 0], xy[:, 1] - truth[:, 1])
    yaw = np.abs(angles.diff(est[:, 2] + theta, truth[:, 2]))
    return pos, yaw, (theta, t)


def rms(v):
    v = np.asarray(v, float)
    return float(np.sqrt(np.mean(v * v))) if v.size else math.nan


def resample_into(data, origin, resolution, theta, t, target_shape, target_origin, target_resolution):
    """The grid ``data`` [H, W] (origin (x, y) of cell (0, 0), its frame placed in the world by (theta, t))
    sampled at the centres of a target grid's cells (nearest cell; UNKNOWN off the grid)."""
    h, w = target_shape
    cx = target_origin[0] + (np.arange(w) + 0.5) * target_resolution
    cy = target_origin[1] + (np.arange(h) + 0.5) * target_resolution
    gx, gy = np.meshgrid(cx, cy)
    c, s = math.cos(theta), math.sin(theta)
    # world -> the built map's frame: R^T (p - t)
    lx = c * (gx - t[0]) + s * (gy - t[1])
    ly = -s * (gx - t[0]) + c * (gy - t[1])
    col = np.floor((lx - origin[0]) / resolution).astype(np.int64)
    row = np.floor((ly - origin[1]) / resolution).astype(np.int64)
    inside = (col >= 0) & (row >= 0) & (col < data.shape[1]) & (row < data.shape[0])
    out = np.full(target_shape, UNKNOWN, np.int8)
    out[inside] = data[row[inside], col[inside]]
    return out


def map_scores(built, truth, seen):
    """Scores of ``built`` against ``truth`` (int8 grids of one shape: -1, 0, 100) with ``seen`` the
    perfect-pose map on the same grid (what the tour's beams showed). See the module's docstring."""
    built_occ, built_free = built == OCCUPIED, built == FREE
    true_occ, true_free = truth == OCCUPIED, truth == FREE
    ring = np.ones((3, 3), bool)
    near_true = ndimage.binary_dilation(true_occ, ring)
    near_built = ndimage.binary_dilation(built_occ, ring)
    visible = true_occ & ndimage.binary_dilation(seen == OCCUPIED, ring)
    n_built, n_visible = int(built_occ.sum()), int(visible.sum())
    precision = float((built_occ & near_true).sum() / n_built) if n_built else math.nan
    recall = float((visible & near_built).sum() / n_visible) if n_visible else math.nan
    f1 = 2 * precision * recall / (precision + recall) if precision + recall > 0 else math.nan
    n_free = int(built_free.sum())
    crossed = (seen == FREE) & true_free
    return {
        "occupied_precision": precision, "occupied_recall": recall, "occupied_f1": f1,
        "built_occupied_cells": n_built, "visible_occupied_cells": n_visible,
        "free_agreement": float((built_free & true_free).sum() / n_free) if n_free else math.nan,
        "free_coverage": float((built_free & crossed).sum() / crossed.sum()) if crossed.any() else math.nan,
        "built_free_cells": n_free, "free_in_walls": int((built_free & true_occ).sum()),
        "free_outside": int((built_free & (truth == UNKNOWN)).sum()),
    }


def false_cells(built, truth):
    """(occupied cells of ``built`` farther than one cell from any truly occupied cell, free cells of
    ``built`` that are not free in ``truth``): boolean grids for the pictures."""
    near_true = ndimage.binary_dilation(truth == OCCUPIED, np.ones((3, 3), bool))
    return (built == OCCUPIED) & ~near_true, (built == FREE) & (truth != FREE)


def seen_map(poses, scans, resolution, occ_thresh, truth):
    """The perfect-pose map on ``truth``'s grid (a map_server GridMap): every scan of ``scans``
    [(laser geometry, ranges, usable [m], max_range [m])] ray-traced as slam_gmapping does from the true base
    pose of the same index in ``poses`` [N, 3]."""
    from gmapping.occupancy import OccupancyCounts

    counts = OccupancyCounts(resolution)
    for pose, (laser, ranges, usable, max_range) in zip(poses, scans, strict=True):
        counts.add_scan(pose, laser, ranges, usable, max_range)
    data, origin = counts.grid(occ_thresh)
    return resample_into(data, origin, resolution, 0.0, (0.0, 0.0), truth.data.shape, truth.origin[:2],
                         truth.resolution)


def judge_map(data, origin, resolution, alignment, truth, seen):
    """(scores (map_scores), the built map on the truth's grid) of a built map ``data`` (int8 [H, W], origin
    (x, y) of its cell (0, 0), its frame placed in the world by ``alignment`` (theta, t))."""
    theta, t = alignment
    built = resample_into(np.asarray(data), origin, resolution, theta, t, truth.data.shape, truth.origin[:2],
                          truth.resolution)
    return map_scores(built, truth.data, seen), built


def plot_map(path, built, truth, seen, origin, resolution, title, tracks=()):
    """The built map over the true one, written to ``path`` (PNG). Grids on one grid (int8 -1/0/100); colours:
    black, occupied in both (within one cell); red, occupied only in the built map; orange, truly occupied and
    seen by the tour's beams but missing from the built map; light grey, truly occupied and never seen; white,
    free in the built map and in the world; magenta, free in the built map, not in the world; dark grey,
    unknown. ``tracks``: [(xy [N, 2] in the world, colour, label)]."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ring = np.ones((3, 3), bool)
    true_occ, built_occ = truth == OCCUPIED, built == OCCUPIED
    near_true, near_built = ndimage.binary_dilation(true_occ, ring), ndimage.binary_dilation(built_occ, ring)
    visible = true_occ & ndimage.binary_dilation(seen == OCCUPIED, ring)
    img = np.full((*built.shape, 3), 0.35)
    img[built == FREE] = (1.0, 1.0, 1.0)
    img[(built == FREE) & (truth != FREE)] = (0.9, 0.2, 0.9)
    img[true_occ & ~visible] = (0.8, 0.8, 0.8)
    img[visible & ~near_built] = (1.0, 0.6, 0.0)
    img[built_occ & near_true] = (0.0, 0.0, 0.0)
    img[built_occ & ~near_true] = (0.9, 0.0, 0.0)
    h, w = built.shape
    extent = [origin[0], origin[0] + w * resolution, origin[1], origin[1] + h * resolution]
    fig, ax = plt.subplots(figsize=(7, 8.5))
    ax.imshow(img, origin="lower", extent=extent, interpolation="nearest")
    for track, colour, label in tracks:
        xy = np.asarray(track).reshape(-1, 2)
        ax.plot(xy[:, 0], xy[:, 1], "-", color=colour, lw=0.8, label=label)
    if tracks:
        ax.legend(loc="upper right", fontsize=7)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title, fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
