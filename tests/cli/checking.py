"""What the check_*.py scripts share: a count of the failed checks, each check printed with what
it got and what it expected, and the exit status (1 if any failed)."""
import sys


class Checks:
    def __init__(self):
        self.bad = 0

    def close(self, name, got, want, tol=1e-12):
        """|got - want| within tol x max(1, |want|)."""
        self.true(abs(got - want) <= tol * max(1.0, abs(want)), f"{name}: {got!r} (expected {want!r})")

    def equal(self, name, got, want):
        self.true(got == want, f"{name}: {got!r} (expected {want!r})")

    def true(self, ok, what):
        self.bad += not ok
        print(f"{what}: {'ok' if ok else 'WRONG'}")

    def fail(self, what):
        self.bad += 1
        print(what)

    def exit(self):
        sys.exit(1 if self.bad else 0)
