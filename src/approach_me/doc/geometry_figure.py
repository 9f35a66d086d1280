#!/usr/bin/python3
"""Draw ApproachMe's goal geometry (the README's figure) with the product's own functions
(approach_me.geometry): the person P, the robot at goal time R0, the final position G at
desired_distance from P, turned by desired_p2r_orientation at P from the line P -> R0, the final
heading turned by desired_r2p_orientation from the line G -> P, and the spiral the robot drives.

    source devel/setup.bash && /usr/bin/python3 src/approach_me/doc/geometry_figure.py
"""

import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from approach_me import geometry

OUT = Path(__file__).with_name("approach_geometry.png")


def arc(ax, centre, radius, a0, a1, **kw):
    a = np.linspace(a0, a0 + math.atan2(math.sin(a1 - a0), math.cos(a1 - a0)), 40)
    ax.plot(centre[0] + radius * np.cos(a), centre[1] + radius * np.sin(a), **kw)
    return a[len(a) // 2]


def main(out=OUT):
    person, robot0 = (2.2, 1.3), (0.0, 0.6)
    d, p2r, r2p = 1.1, math.radians(80), math.radians(30)
    direction = geometry.approach_direction(person, robot0, p2r)
    goal = geometry.goal_position(person, direction, d)
    yaw = geometry.final_heading(goal, person, r2p)
    path = np.array([robot0, *geometry.approach_path(robot0, person, goal)])

    fig, ax = plt.subplots(figsize=(9.0, 5.2))
    ax.plot(path[:, 0], path[:, 1], color="0.6", lw=1.5, ls="--", label="the way: a spiral about P")
    ax.add_patch(plt.Circle(person, 0.25, color="tab:red", alpha=0.25))
    ax.plot(*person, "o", color="tab:red")
    ax.annotate("P: the person (the goal's x, y:\nin the robot frame at goal time)", person, (2.5, 1.6),
                color="tab:red")
    for xy, heading, label, colour in ((robot0, 0.25, "R0: the robot at goal time", "tab:blue"),
                                       (goal, yaw, "G: the final pose", "tab:green")):
        ax.add_patch(plt.Circle(xy, 0.18, fill=False, color=colour))
        ax.arrow(xy[0], xy[1], 0.3 * math.cos(heading), 0.3 * math.sin(heading), width=0.012, color=colour)
        ax.annotate(label, xy, (xy[0] - 0.5, xy[1] - 0.4), color=colour)
    # the line P -> R0 and P -> G, and p2r between them at P
    a_r0 = math.atan2(robot0[1] - person[1], robot0[0] - person[0])
    ax.plot([person[0], robot0[0]], [person[1], robot0[1]], color="tab:blue", lw=0.8)
    ax.plot([person[0], goal[0]], [person[1], goal[1]], color="tab:green", lw=0.8)
    mid = arc(ax, person, 0.35, a_r0, direction, color="k", lw=1)
    ax.annotate("desired_p2r_orientation:\nat P, from the line P -> R0\nto the line P -> G\n(counter-clockwise +)",
                (person[0] + 0.35 * math.cos(mid), person[1] + 0.35 * math.sin(mid)), (0.3, 1.5),
                arrowprops={"arrowstyle": "-", "lw": 0.5})
    ax.annotate(f"desired_distance d = |PG| = {d} m", ((person[0] + goal[0]) / 2, (person[1] + goal[1]) / 2),
                (2.8, 0.8), arrowprops={"arrowstyle": "-", "lw": 0.5})
    # r2p at G: from the line G -> P to the final heading
    a_gp = math.atan2(person[1] - goal[1], person[0] - goal[0])
    ax.plot([goal[0], goal[0] + 0.55 * math.cos(a_gp)], [goal[1], goal[1] + 0.55 * math.sin(a_gp)], color="k",
            lw=0.6, ls=":")
    mid = arc(ax, goal, 0.42, a_gp, yaw, color="k", lw=1)
    ax.annotate("desired_r2p_orientation: the final heading\nfrom the line G -> P (0 = facing the person)",
                (goal[0] + 0.42 * math.cos(mid), goal[1] + 0.42 * math.sin(mid)), (2.8, 0.15),
                arrowprops={"arrowstyle": "-", "lw": 0.5})
    ax.set_aspect("equal")
    ax.set_xlim(-0.6, 5.2)
    ax.set_ylim(-0.7, 2.3)
    ax.set_xlabel("x [m] (a fixed frame: odom)")
    ax.set_ylabel("y [m]")
    ax.set_title("ApproachMe: d = 1.1 m, p2r = +80 deg, r2p = +30 deg")
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else OUT)
