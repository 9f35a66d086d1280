"""Where the person stands, for the approach's goal (ROS-free).

The sightings of a standing person are good from afar and worse close up: nearer than about 1 m the
Kinect's view cuts the torso at the image's edge (its centre slides toward the image's middle) and,
from the person's side, one leg hides the other from the laser (the centre of the one leg seen is
0.1 m off the person's). Both errors moved the final pose 0.08-0.13 m and 0.1-0.15 rad in the
simulator, more than the goal's tolerances. So the place of a person who stands still is the mean of
the sightings taken from at least ``far_range`` away; nearer sightings within ``still_radius`` of it
only say that they are still there. A person seen farther than ``still_radius`` from that place for
``move_time`` has moved: the place starts over from the latest sighting.
"""

import math


class StandingPlace:
    def __init__(self, far_range=1.0, still_radius=0.15, move_time=0.5, window=20):
        self.far_range, self.still_radius, self.move_time, self.window = far_range, still_radius, move_time, window
        self.xy = None  # (x, y) [m] the estimate
        self.far = 0  # far sightings in the mean (at most window)
        self.near = 0  # sightings in the mean while none was far
        self.moved_since = None  # [s] since when the sightings are off the place

    def update(self, xy, robot_xy, t):
        """A sighting ``xy`` at ``t`` [s] with the robot at ``robot_xy`` (one fixed frame). Returns the place."""
        xy = (float(xy[0]), float(xy[1]))
        if self.xy is None:
            return self._restart(xy, robot_xy)
        if math.dist(xy, self.xy) > self.still_radius:
            if self.moved_since is None:
                self.moved_since = t
            if t - self.moved_since >= self.move_time:
                return self._restart(xy, robot_xy)
            return self.xy
        self.moved_since = None
        if math.dist(robot_xy, xy) >= self.far_range:
            if self.far == 0:  # the first far sighting replaces the near ones
                self.xy, self.near = xy, 0
            self.far = self._add(xy, self.far)
        elif self.far == 0:
            self.near = self._add(xy, self.near)
        return self.xy

    def _add(self, xy, n):
        """Fold ``xy`` into the mean of ``n`` sightings (a running mean over at most window); the new count."""
        n = min(n, self.window - 1)
        self.xy = ((self.xy[0] * n + xy[0]) / (n + 1), (self.xy[1] * n + xy[1]) / (n + 1))
        return n + 1

    def _restart(self, xy, robot_xy):
        self.xy, self.moved_since = xy, None
        far = math.dist(robot_xy, xy) >= self.far_range
        self.far, self.near = (1, 0) if far else (0, 1)
        return self.xy
