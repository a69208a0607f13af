"""Exceptions with messages that name the offending input and what is allowed."""

from __future__ import annotations


class ShellContactError(Exception):
    """Base class of every error this package raises on purpose."""


class InputError(ShellContactError, ValueError):
    """Invalid input: ``field`` names the key, the message says what is allowed."""

    def __init__(self, field: str, message: str) -> None:
        self.field = field
        self.message = message
        super().__init__(f"{field}: {message}")

    def __reduce__(self):  # a sweep worker's error reaches the parent whole
        return (type(self), (self.field, self.message))


class SolverError(ShellContactError, RuntimeError):
    """A solve did not reach its tolerance; ``residuals`` says how far it got."""

    def __init__(self, message: str, residuals: dict | None = None, iterations: int | None = None,
                 hint: str = ""):
        self.residuals = dict(residuals or {})
        self.iterations = iterations
        detail = ", ".join(f"{k}={v:.3e}" for k, v in self.residuals.items())
        text = message
        if iterations is not None:
            text += f" after {iterations} iterations"
        if detail:
            text += f" ({detail})"
        if hint:  # what to do about it
            text += f"; {hint}"
        super().__init__(text)
