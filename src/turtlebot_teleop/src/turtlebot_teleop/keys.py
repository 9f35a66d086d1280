"""Keyboard teleoperation of the TurtleBot, ROS-free: the key table, the speeds and the timing.

Keys (the TurtleBot's turtlebot_teleop_key layout)::

    u    i    o        forward-left   forward   forward-right
    j    k    l        turn left      stop      turn right
    m    ,    .        back-left      back      back-right     (backing to the left turns clockwise)

    k or space: stop (so does any other key)       Ctrl-C or Ctrl-D: quit
    q / z: both speeds +10 % / -10 %   w / x: forward speed only   e / c: turn rate only

Timing. A terminal sends no "key up": while a key is held it repeats the key (after a first delay
of 0.25-0.66 s, then 25-30 times a second). So a key counts as held while it keeps coming:

- a motion key is sent at once and then at ``rate`` while it is held;
- it is released when no key came for ``key_timeout`` once the key repeats, or for
  ``max(key_timeout, repeat_delay)`` after a single press (a held key does not stutter while the
  terminal waits to start repeating, and a tap nudges the robot);
- on release a zero command goes out at once and ``stop_messages - 1`` more follow at ``rate``;
  then nothing, so the velocity multiplexer lets a lower-priority input (move_base, follow_me)
  have the robot again. The multiplexer's input timeout and velocity_filter's command timeout stop
  the robot as well, should this program die: they are the last line, not the first.

Times are [s] of any monotonic clock (the node uses the wall clock: keys are typed in real time).
"""

import math
from dataclasses import dataclass

# key: (forward sign, turn sign); turn is counter-clockwise positive (REP 103)
MOVE_BINDINGS = {
    "u": (1, 1), "i": (1, 0), "o": (1, -1),
    "j": (0, 1), "k": (0, 0), "l": (0, -1),
    "m": (-1, -1), ",": (-1, 0), ".": (-1, 1),
}
STOP_KEYS = ("k", " ")
# key: (factor on the forward speed, factor on the turn rate)
SPEED_BINDINGS = {
    "q": (1.1, 1.1), "z": (0.9, 0.9),
    "w": (1.1, 1.0), "x": (0.9, 1.0),
    "e": (1.0, 1.1), "c": (1.0, 0.9),
}
QUIT_KEYS = ("\x03", "\x04")  # Ctrl-C, Ctrl-D (read as characters when the terminal does not signal)

MOVE, STOP, SPEED, QUIT = "move", "stop", "speed", "quit"

HELP = """Control the TurtleBot (turtlebot_teleop_key): hold a key to drive, release it to stop.
---------------------------
Moving around:
   u    i    o
   j    k    l
   m    ,    .

k or space (or any other key): stop
q/z : increase/decrease both speeds by 10%
w/x : increase/decrease only the forward speed by 10%
e/c : increase/decrease only the turn rate by 10%

Ctrl-C to quit"""


@dataclass(frozen=True)
class TeleopConfig:
    speed: float = 0.3  # [m/s] forward speed at start (the original's)
    turn: float = 1.0  # [rad/s] turn rate at start (the original's)
    speed_limit: float = 0.5  # [m/s] q and w stop here (the Create's top speed, velocity_filter's cap)
    turn_limit: float = 2.0  # [rad/s] (velocity_filter's cap)
    min_speed: float = 0.01  # [m/s] z and x stop here
    min_turn: float = 0.05  # [rad/s]
    rate: float = 10.0  # [Hz] commands while a key is held
    key_timeout: float = 0.3  # [s] no key for this long (the key repeating) = released
    repeat_delay: float = 0.7  # [s] after a single press: the terminal's delay before it repeats a held key
    stop_messages: int = 3  # zero commands sent on release

    def validate(self):
        for name in ("speed", "turn", "speed_limit", "turn_limit", "min_speed", "min_turn", "rate", "key_timeout"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        if not (math.isfinite(self.repeat_delay) and self.repeat_delay >= 0):
            raise ValueError(f"repeat_delay must be a finite number >= 0, got {self.repeat_delay!r}")
        if self.stop_messages < 1:
            raise ValueError(f"stop_messages must be at least 1, got {self.stop_messages}")
        if not (self.min_speed <= self.speed <= self.speed_limit):
            raise ValueError(f"speed {self.speed} must be within {self.min_speed}..{self.speed_limit} m/s")
        if not (self.min_turn <= self.turn <= self.turn_limit):
            raise ValueError(f"turn {self.turn} must be within {self.min_turn}..{self.turn_limit} rad/s")
        return self


class KeyboardTeleop:
    """The state of a keyboard teleoperation: call :meth:`press` with every key read, :meth:`poll`
    whenever :meth:`wake_time` comes (or sooner); poll returns the (linear [m/s], angular [rad/s])
    command to publish now, or None."""

    def __init__(self, config=None):
        self.cfg = (config or TeleopConfig()).validate()
        self.speed = self.cfg.speed  # [m/s]
        self.turn = self.cfg.turn  # [rad/s]
        self.motion = None  # (forward sign, turn sign) of the key held, None when none is
        self.last_key = None  # [s] when the held key last came
        self.repeats = 0  # how often the held key came again
        self.zeros_left = 0  # zero commands still to send after a release
        self.next_send = None  # [s] when the next command is due; None: nothing to send

    # --- keys -----------------------------------------------------------------------------------
    def press(self, key, now):
        """Take one key read at ``now``; returns MOVE, STOP, SPEED or QUIT."""
        if key in QUIT_KEYS:
            return QUIT
        if key in SPEED_BINDINGS:
            fs, ft = SPEED_BINDINGS[key]
            cfg = self.cfg
            self.speed = min(cfg.speed_limit, max(cfg.min_speed, self.speed * fs))
            self.turn = min(cfg.turn_limit, max(cfg.min_turn, self.turn * ft))
            if self.motion is not None:
                self.next_send = now  # the held motion at the new speed, at once
            return SPEED
        motion = MOVE_BINDINGS.get(key, (0, 0))  # any other key stops, as in the original
        if motion == self.motion and not self.released(now):
            self.repeats += 1  # the key repeating: it stays held, the rate stays steady
        else:
            self.motion, self.repeats = motion, 0
            self.zeros_left = 0
            self.next_send = now  # a new key is sent at once
        self.last_key = now
        return STOP if motion == (0, 0) else MOVE

    def release_time(self):
        """When the held key counts as released unless it comes again (None: no key held)."""
        if self.motion is None:
            return None
        cfg = self.cfg
        return self.last_key + (cfg.key_timeout if self.repeats else max(cfg.key_timeout, cfg.repeat_delay))

    def released(self, now):
        release = self.release_time()
        return release is None or now >= release

    # --- commands -----------------------------------------------------------------------------------
    def wake_time(self):
        """When :meth:`poll` has something to do next (None: nothing until a key comes)."""
        times = [t for t in (self.next_send, self.release_time()) if t is not None]
        return min(times) if times else None

    def poll(self, now):
        """The command to publish at ``now`` (linear [m/s], angular [rad/s]), or None."""
        if self.motion is not None and self.released(now):
            self.motion = None
            self.zeros_left = self.cfg.stop_messages
            self.next_send = now
        if self.next_send is None or now < self.next_send:
            return None
        period = 1.0 / self.cfg.rate
        if self.motion is not None:
            self.next_send = max(self.next_send + period, now)  # steady rate, no burst after a stall
            forward, turn = self.motion
            return forward * self.speed, turn * self.turn
        if self.zeros_left > 0:
            self.zeros_left -= 1
            self.next_send = now + period if self.zeros_left else None
            return 0.0, 0.0
        self.next_send = None
        return None

    def stop(self):
        """Forget the held key (on quit): the caller sends one zero command itself."""
        self.motion, self.zeros_left, self.next_send = None, 0, None

    def status(self):
        """The speeds line shown on screen (the original's wording, with units)."""
        return f"currently:\tspeed {self.speed:.2f} m/s\tturn {self.turn:.2f} rad/s"
