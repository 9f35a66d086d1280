"""Constant-velocity Kalman filter of one person on the floor plane (no ROS).

State ``[x, y, vx, vy]`` ([m], [m/s]) in the fixed frame; measurements are positions
``[x, y]`` [m] with a per-sensor standard deviation. The process noise is white
acceleration of spectral density ``q`` [m^2/s^3] (a walking person: q about 1).
"""

import numpy as np

H = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])


def measurement_covariance(noise):
    """2x2 covariance [m^2] of a position measurement: ``noise`` is a standard deviation [m] (the
    same in every direction) or already a 2x2 covariance."""
    if np.ndim(noise) == 0:
        return np.eye(2) * float(noise) ** 2
    return np.asarray(noise, dtype=float).reshape(2, 2)


def along_and_across(direction, std_along, std_across):
    """2x2 covariance [m^2] of a measurement with standard deviation ``std_along`` [m] along the unit
    vector ``direction`` (x, y) and ``std_across`` [m] across it (a range that is good and a bearing
    that is not)."""
    u = np.asarray(direction, dtype=float)
    u = u / max(float(np.hypot(*u)), 1e-9)
    n = np.array([-u[1], u[0]])
    return std_along**2 * np.outer(u, u) + std_across**2 * np.outer(n, n)


class ConstantVelocity:
    def __init__(self, x, y, t, pos_std=0.1, vel_std=1.0, q=1.0):
        self.x = np.array([x, y, 0.0, 0.0])
        self.P = np.diag([pos_std**2, pos_std**2, vel_std**2, vel_std**2])
        self.t = float(t)
        self.q = float(q)

    @staticmethod
    def transition(dt, q):
        """(F, Q) of a step of ``dt`` [s]."""
        F = np.eye(4)
        F[0, 2] = F[1, 3] = dt
        dt2, dt3 = dt * dt, dt * dt * dt
        Q = q * np.array([[dt3 / 3, 0, dt2 / 2, 0], [0, dt3 / 3, 0, dt2 / 2],
                          [dt2 / 2, 0, dt, 0], [0, dt2 / 2, 0, dt]])
        return F, Q

    def predicted(self, t):
        """(state, covariance) at time ``t`` without changing the filter (t before now: now)."""
        dt = max(0.0, float(t) - self.t)
        if dt == 0.0:
            return self.x.copy(), self.P.copy()
        F, Q = self.transition(dt, self.q)
        return F @ self.x, F @ self.P @ F.T + Q

    def predict(self, t):
        self.x, self.P = self.predicted(t)
        self.t = max(self.t, float(t))

    def stand(self, x, y, vel_std=1.0):
        """Put the state at (x, y) [m], standing still: the position's uncertainty is kept (its
        cross terms with the velocity dropped), the velocity's is ``vel_std`` [m/s] again, as at
        the start."""
        self.x = np.array([float(x), float(y), 0.0, 0.0])
        P = np.diag([vel_std**2] * 4)
        P[:2, :2] = self.P[:2, :2]
        self.P = P

    def innovation(self, z, noise, t=None):
        """(residual [2], covariance S [2x2]) of measurement ``z`` at ``t``; ``noise``: its standard
        deviation [m], the same in every direction, or its 2x2 covariance [m^2]."""
        x, P = self.predicted(self.t if t is None else t)
        S = P[:2, :2] + measurement_covariance(noise)
        return np.asarray(z, dtype=float) - x[:2], S

    def update(self, z, noise, velocity=True):
        """Fuse position ``z`` (x, y) [m] measured with ``noise`` (see :meth:`innovation`), after
        predict. ``velocity`` False: the position only (the velocity rows of the gain zeroed, the
        covariance by Joseph's form, which holds for any gain): a measurement whose error is
        biased and growing (a person more and more hidden) must not teach the filter a velocity."""
        y, S = self.innovation(z, noise)
        K = self.P @ H.T @ np.linalg.inv(S)
        if velocity:
            self.x = self.x + K @ y
            self.P = (np.eye(4) - K @ H) @ self.P
            return
        K[2:, :] = 0.0
        self.x = self.x + K @ y
        A = np.eye(4) - K @ H
        self.P = A @ self.P @ A.T + K @ measurement_covariance(noise) @ K.T

    @property
    def position(self):
        return float(self.x[0]), float(self.x[1])

    @property
    def velocity(self):
        return float(self.x[2]), float(self.x[3])

    @property
    def position_std(self):
        """Largest standard deviation [m] of the position estimate."""
        return float(np.sqrt(np.max(np.linalg.eigvalsh(self.P[:2, :2]))))
