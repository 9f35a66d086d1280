"""Named pass/fail checks of the demo, addressed by name (never by position).

    checks = Checks()
    checks.add("robot drove into the corridor", 5.55 < y < 6.75, f"truth y {y:.2f} m")
    checks["robot drove into the corridor"].passed
    checks.passed            # every check passed
    checks.failed()          # the names of the failed ones

ROS-free.
"""

from dataclasses import asdict, dataclass


@dataclass(frozen=True)
class Check:
    name: str
    passed: bool
    detail: str = ""

    def line(self):
        """Markdown task-list line of the report."""
        return f"- [{'x' if self.passed else ' '}] {self.name}: {self.detail}"


class Checks:
    """An ordered set of checks with unique names."""

    def __init__(self, checks=()):
        self._checks = {}
        for check in checks:
            self._put(check)

    def _put(self, check):
        if check.name in self._checks:
            raise ValueError(f"check {check.name!r} added twice")
        self._checks[check.name] = check
        return check

    def add(self, name, passed, detail=""):
        return self._put(Check(name, bool(passed), str(detail)))

    def extend(self, other):
        for check in other:
            self._put(check)
        return self

    def __getitem__(self, name):
        return self._checks[name]

    def __contains__(self, name):
        return name in self._checks

    def __iter__(self):
        return iter(self._checks.values())

    def __len__(self):
        return len(self._checks)

    @property
    def passed(self):
        return all(c.passed for c in self)

    def failed(self):
        return [c.name for c in self if not c.passed]

    def as_json(self):
        """``{name: {"passed": bool, "detail": str}}`` in order."""
        return {c.name: {k: v for k, v in asdict(c).items() if k != "name"} for c in self}

    def markdown(self):
        return "\n".join(c.line() for c in self)
