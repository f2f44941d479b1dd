"""The few named exceptions of the planner.

``InputError`` is bad input from the user (a file, a key, a row, a command-line
value): the CLI prints its one-line message and exits with status 2.
``ModelError`` is a model asked to work outside its range; ``FitError`` a fit
that found no optimum.
"""


class PlannerError(Exception):
    """Base class of the planner's own errors."""


class InputError(PlannerError, ValueError):
    """Bad input: the message names the file, the key or row, and what was expected.

    Parameters
    ----------
    message : str
        One line, e.g. ``"aircraft/x.yaml: capacity_mah must be > 0, got -5"``.
    """

    def __init__(self, message: str):
        super().__init__(" ".join(str(message).split("\n")))


class WrongFileError(InputError):
    """A file of another kind than the one expected (a battery pack given as the aircraft):
    ``kind`` is what it is (``"battery pack"``, ``"aircraft"``, ``"pack catalog"``,
    ``"mission"``), for the command line to say where to give it."""

    def __init__(self, message: str, kind: str):
        super().__init__(message)
        self.kind = kind


class ModelError(PlannerError, ValueError):
    """A model evaluated outside its validity range (states the range)."""


class FitError(PlannerError, RuntimeError):
    """A fit that did not converge or is not identifiable from the data."""
