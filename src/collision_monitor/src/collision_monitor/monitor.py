"""The collision monitor's rule (ROS-free): how fast may the robot carry out a velocity command
among obstacle points?

Frames and units: the robot's base frame (REP 103: x forward, y left) [m]; a command is
(v [m/s], w [rad/s]) of a differential drive, held until the next one. The robot's footprint is a
polygon, or a circle of ``robot_radius`` when no polygon is given.

The rule (Nav2's collision_monitor is the anchor: a stop zone, a slow-down, an approach judged by
time to collision; here the zones are measured along the commanded motion itself):

1. The command's path is predicted: the arc (v, w) describes, over ``time_horizon`` s at the
   commanded speed (and never less than the distance the robot needs to stop, nor
   ``min_lookahead``), sampled every ``step`` m and ``turn_step`` rad.
2. An obstacle point's *clearance* is its signed distance to the footprint (negative inside). At
   every pose of the path the footprint's least clearance is taken; the motion is *threatened* at
   the first pose where that is below ``stop_distance`` *and* below the least clearance now. So a
   robot already inside the stop zone may move in any way that does not bring it nearer to
   anything than it is now: moving away from an obstacle is never blocked, nor sliding along it.
3. ``s_stop``, the path length travelled before the first threatened pose, sets the speed from
   which the robot can still stop short of it: ``v_max = a (-tau + sqrt(tau^2 + 2 s_stop / a))``
   with the braking ``deceleration`` a and the ``latency`` tau (the time a command stands before
   the next is judged). A command faster than that is scaled down as a whole, keeping its path
   (state SLOW); one whose allowed speed falls below ``min_speed`` loses its linear part (state
   STOP). A command with no threatened pose passes unchanged (state CLEAR).
4. Turning in place is never blocked: a command without linear speed passes as it is, and a
   stopped command keeps its angular speed (the robot may turn away from what stopped it).
"""

import math
from dataclasses import dataclass, field

import numpy as np

CLEAR, SLOW, STOP, TURN, BLIND = "clear", "slow", "stop", "turn", "blind"


@dataclass(frozen=True)
class MonitorConfig:
    """The rule's settings; units in brackets."""

    footprint: tuple = ()  # polygon [(x, y), ...] [m] in the base frame; () = circle of robot_radius
    robot_radius: float = 0.17  # [m] footprint circle (the Create's body, 0.1696 m)
    stop_distance: float = 0.06  # [m] least clearance a motion may bring the footprint to
    time_horizon: float = 1.5  # [s] how far ahead a command is followed, at its own speed
    min_lookahead: float = 0.15  # [m] path length checked however slow the command
    deceleration: float = 0.5  # [m/s^2] braking the speed limit counts on (the base brakes at 1.0)
    latency: float = 0.2  # [s] a command's effect lasts this long before the next one is judged
    min_speed: float = 0.02  # [m/s] an allowed speed below this stops the linear motion
    step: float = 0.02  # [m] path sampling
    turn_step: float = 0.05  # [rad] path sampling on tight arcs
    approach_margin: float = 1e-6  # [m] a drop of the least clearance smaller than this is rounding

    def __post_init__(self):
        for name in ("robot_radius", "stop_distance", "time_horizon", "deceleration", "step", "turn_step"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise ValueError(f"{name} must be finite and > 0, got {getattr(self, name)}")
        for name in ("min_lookahead", "latency", "min_speed", "approach_margin"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {getattr(self, name)}")
        if len(self.footprint):
            poly = np.asarray(self.footprint, dtype=float)
            if poly.ndim != 2 or poly.shape[1] != 2 or len(poly) < 3 or not np.all(np.isfinite(poly)):
                raise ValueError(f"footprint must be 3 or more finite [x, y] points, got {self.footprint!r}")
            if not _inside(np.zeros((1, 2)), poly)[0]:
                raise ValueError("footprint must contain the robot's origin (0, 0)")

    @property
    def reach(self):
        """Largest distance [m] of the footprint from the origin."""
        if len(self.footprint):
            return float(np.max(np.hypot(*np.asarray(self.footprint, dtype=float).T)))
        return self.robot_radius


@dataclass
class Decision:
    """What the monitor does with one command."""

    state: str  # CLEAR, SLOW, STOP, TURN (no linear part: passed), BLIND (no obstacle data: stopped)
    v: float  # [m/s] command out
    w: float  # [rad/s]
    scale: float = 1.0  # v out / v in (1 when passed)
    stop_path: float = math.inf  # [m] path length before the first threatened pose (inf: none ahead)
    clearance: float = math.inf  # [m] least clearance of the footprint now
    nearest: tuple = field(default=(math.nan, math.nan))  # (x, y) [m] of the point that threatens (or nearest)


def braking_speed(distance, deceleration, latency):
    """Largest speed [m/s] from which the robot, moving on for ``latency`` s and then braking at
    ``deceleration`` m/s^2, stops within ``distance`` m."""
    if distance <= 0.0:
        return 0.0
    a, tau = deceleration, latency
    return a * (-tau + math.sqrt(tau * tau + 2.0 * distance / a))


def stopping_distance(speed, deceleration, latency):
    """Path [m] the robot needs to stop from ``speed`` (the inverse of :func:`braking_speed`)."""
    v = abs(speed)
    return v * latency + v * v / (2.0 * deceleration)


def arc_poses(v, w, length, step, turn_step):
    """Poses [K, 3] (x, y, yaw) along the arc of command (v, w), from the origin over ``length`` m
    of path (backwards when v < 0), every ``step`` m and at most ``turn_step`` rad; pose 0 is now.
    Returns (poses, path lengths [K])."""
    kappa = w / v  # [1/m] curvature (v != 0)
    n = min(math.ceil(max(length / step, abs(kappa) * length / turn_step, 1.0)), 400)
    s = np.linspace(0.0, length, n + 1)
    sigma = math.copysign(1.0, v) * s  # signed path length
    theta = kappa * sigma
    if abs(kappa) < 1e-9:
        x, y = sigma, np.zeros_like(sigma)
    else:
        x, y = np.sin(theta) / kappa, (1.0 - np.cos(theta)) / kappa
    return np.column_stack([x, y, theta]), s


def _inside(points, poly):
    """Whether each of ``points`` [..., 2] lies inside polygon ``poly`` [E, 2] (crossing number)."""
    px, py = points[..., 0, None], points[..., 1, None]
    a, b = poly, np.roll(poly, -1, axis=0)
    ax, ay, bx, by = a[:, 0], a[:, 1], b[:, 0], b[:, 1]
    straddles = (ay > py) != (by > py)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_cross = ax + (py - ay) * (bx - ax) / (by - ay)
    return np.count_nonzero(straddles & (px < x_cross), axis=-1) % 2 == 1


def polygon_clearance(points, poly):
    """Signed distance [m] of ``points`` [..., 2] to polygon ``poly`` [E, 2]: positive outside,
    negative inside."""
    a, b = poly, np.roll(poly, -1, axis=0)
    ab = b - a
    ap = points[..., None, :] - a  # [..., E, 2]
    t = np.clip(np.sum(ap * ab, axis=-1) / np.sum(ab * ab, axis=-1), 0.0, 1.0)
    d = np.min(np.hypot(ap[..., 0] - t * ab[:, 0], ap[..., 1] - t * ab[:, 1]), axis=-1)
    return np.where(_inside(points, poly), -d, d)


def clearances(points, poses, config):
    """Clearance [K, N] of ``points`` [N, 2] (base frame) to the footprint at each of ``poses`` [K, 3]."""
    pts = np.asarray(points, dtype=float)
    if not len(config.footprint):
        d = np.hypot(pts[None, :, 0] - poses[:, None, 0], pts[None, :, 1] - poses[:, None, 1])
        return d - config.robot_radius
    c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
    dx, dy = pts[None, :, 0] - poses[:, None, 0], pts[None, :, 1] - poses[:, None, 1]
    local = np.stack([c * dx + s * dy, -s * dx + c * dy], axis=-1)  # points in each pose's frame
    return polygon_clearance(local, np.asarray(config.footprint, dtype=float))


def decide(points, v, w, config, padding=None):
    """The :class:`Decision` for command (v, w) among obstacle ``points`` [N, 2] in the base frame;
    ``padding`` [N] [m]: how much less each point's clearance counts (a sensor that may place an
    obstacle's edge that much beyond it), none by default."""
    cfg = config
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    pad = np.zeros(len(pts)) if padding is None else np.asarray(padding, dtype=float).reshape(-1)
    ok = np.all(np.isfinite(pts), axis=1)
    pts, pad = pts[ok], pad[ok]
    now = clearances(pts, np.zeros((1, 3)), cfg)[0] - pad if len(pts) else np.zeros(0)
    least = float(np.min(now)) if len(pts) else math.inf
    nearest_now = tuple(float(c) for c in pts[int(np.argmin(now))]) if len(pts) else (math.nan, math.nan)
    if v == 0.0:
        return Decision(TURN, 0.0, w, 1.0, math.inf, least, nearest_now)
    length = max(abs(v) * cfg.time_horizon, stopping_distance(v, cfg.deceleration, cfg.latency) + cfg.step,
                 cfg.min_lookahead)
    poses, s = arc_poses(v, w, length, cfg.step, cfg.turn_step)
    # only points the swept footprint can come near are judged in full: first those within the
    # path's reach of the robot, then those near one of its poses
    reach = cfg.reach + cfg.stop_distance + cfg.step + (float(np.max(pad)) if len(pad) else 0.0)
    keep = np.hypot(pts[:, 0], pts[:, 1]) <= length + reach if len(pts) else np.zeros(0, dtype=bool)
    near, pad = pts[keep], pad[keep]
    if len(near):
        gap = np.min((near[None, :, 0] - poses[:, None, 0]) ** 2 + (near[None, :, 1] - poses[:, None, 1]) ** 2, axis=0)
        keep = gap <= reach * reach
        near, pad = near[keep], pad[keep]
    if not len(near):
        return Decision(CLEAR, v, w, 1.0, math.inf, least, nearest_now)
    c = clearances(near, poses, cfg) - pad  # [K, M]
    least_ahead = np.min(c, axis=1)  # [K] the footprint's least clearance along the path
    limit = min(cfg.stop_distance, least_ahead[0] - cfg.approach_margin)  # inside the zone: no nearer than now
    hit = np.flatnonzero(least_ahead < limit)
    if not len(hit):
        return Decision(CLEAR, v, w, 1.0, math.inf, least, nearest_now)
    k = int(hit[0])  # >= 1: pose 0 never threatens
    before, after = least_ahead[k - 1], least_ahead[k]  # the last pose still allowed, and on to the limit
    stop_path = float(s[k - 1] + (s[k] - s[k - 1]) * (before - limit) / (before - after))
    culprit = tuple(float(x) for x in near[int(np.argmin(c[k]))])
    allowed = braking_speed(stop_path, cfg.deceleration, cfg.latency)
    if allowed < cfg.min_speed:
        return Decision(STOP, 0.0, w, 0.0, stop_path, least, culprit)
    if allowed >= abs(v):
        return Decision(CLEAR, v, w, 1.0, stop_path, least, culprit)
    scale = allowed / abs(v)
    return Decision(SLOW, v * scale, w * scale, scale, stop_path, least, culprit)


STEER_OFFSETS = (0.15, 0.3, 0.45, 0.6, 0.9, 1.2)  # [rad/s] turn-rate changes steer_clear tries, nearest first


def steer_clear(points, v, w, config, max_w, max_change=0.6, padding=None, min_gain=0.05):
    """For a commander that wants to go on rather than be stopped (follow_me): the command the
    rule passes nearest (v, w) with as much of the linear speed as it can get.

    (v, w) itself when the rule passes it whole, or when what slows it is ahead rather than beside
    the robot (beside: at least 30 deg off the heading, a door jamb; ahead: the person followed, a
    wall). Else the same forward speed with the turn rate changed by the smallest of
    :data:`STEER_OFFSETS` (up to ``max_change`` [rad/s], within +-``max_w``) that the rule passes
    whole, or failing that the one it lets go fastest when that is ``min_gain`` [m/s] faster than
    (v, w) itself; when even that is stopped, a turn on the spot away from what stops it (at
    ``max_change``), after which an arc passes. Returns the :class:`Decision` to send (its v, w).

    Each candidate is judged by :func:`decide`, so a steered command is as safe as any: it only
    finds the arc that leaves, say, a door jamb beside the robot instead of grazing it, where the
    straight command would be stopped and the commander's law would keep asking for it."""
    first = decide(points, v, w, config, padding)
    if first.state in (CLEAR, TURN) or not _beside(first.nearest):
        return first  # passed; or what slows it is ahead (a person followed, a wall): that is the commander's
    best, best_speed = first, abs(first.v)
    for change in (c for c in STEER_OFFSETS if c <= max_change + 1e-9):
        for sign in (1.0, -1.0):
            cw = w + sign * change
            if abs(cw) > max_w + 1e-9:
                continue
            d = decide(points, v, cw, config, padding)
            if d.state == CLEAR:
                return d
            if abs(d.v) > best_speed + min_gain:
                best, best_speed = d, abs(d.v)
    if best is first and first.state == STOP and v > 0:
        # every arc from this heading comes nearer to what is beside the robot: turn away from it on the spot
        # (never blocked), then an arc will pass
        away = -math.copysign(min(max_change, max_w), first.nearest[1])
        return Decision(TURN, 0.0, away, 0.0, first.stop_path, first.clearance, first.nearest)
    return best


BESIDE_BEARING = math.radians(30)  # [rad] a point at least this far off the heading is beside the robot, not ahead


def _beside(point):
    """A point in the front half, at least BESIDE_BEARING off the heading (not straight ahead)."""
    x, y = point
    return math.isfinite(x) and math.isfinite(y) and x > -0.05 and abs(math.atan2(y, x)) >= BESIDE_BEARING


def blind(v, w, least=math.inf):
    """No obstacle data to judge by: the linear part stops, turning in place passes."""
    return Decision(TURN if v == 0.0 else BLIND, 0.0, w, 0.0 if v else 1.0, 0.0, least)
