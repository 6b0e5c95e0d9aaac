"""Exceptions raised by core for bad input.

Every error names the offending argument (``field``, the core argument name such as
``"P2"`` or ``"v_min"``), says why it was refused (``reason``), and, for batched
arrays, gives the batch index of the first offending row (``index``). The service
maps each class to a problem type; callers that do not care catch the base class.

Hierarchy::

    ValueError
     └── PlotgateError          any bad input refused by core
          ├── NonFiniteError    NaN or infinity in an input
          ├── CovarianceError   a covariance that is not symmetric positive definite
          ├── ParameterError    a parameter out of its domain, or a wrong shape
          └── GeometryError     a geometry with no solution
"""

from __future__ import annotations

__all__ = [
    "CovarianceError",
    "GeometryError",
    "NonFiniteError",
    "ParameterError",
    "PlotgateError",
]


class PlotgateError(ValueError):
    """Base of every bad-input error raised by core.

    Parameters
    ----------
    field : str
        Name of the core argument that was refused, e.g. ``"P2"``.
    reason : str
        A sentence saying what is wrong, with the offending values.
    index : int or None, optional
        Batch index (flat, C order) of the first offending row, or None when the
        argument is not batched.

    Examples
    --------
    >>> err = PlotgateError("P2", "is not positive definite", index=3)
    >>> str(err)
    'P2[3]: is not positive definite'
    >>> str(PlotgateError("v_min", "must be non-negative, got -1.0"))
    'v_min: must be non-negative, got -1.0'
    """

    def __init__(self, field: str, reason: str, index: int | None = None) -> None:
        super().__init__(field, reason, index)
        self.field = field
        self.reason = reason
        self.index = index

    def __str__(self) -> str:
        if self.index is None:
            return f"{self.field}: {self.reason}"
        return f"{self.field}[{self.index}]: {self.reason}"


class NonFiniteError(PlotgateError):
    """An input contains NaN or infinity."""


class CovarianceError(PlotgateError):
    """A covariance matrix is not symmetric positive definite."""


class ParameterError(PlotgateError):
    """A parameter is outside its domain, or an array has the wrong shape.

    Examples: ``v_min > v_max``, a probability outside (0, 1), a non-positive
    sigma, tau or gate coefficient, or batch lengths that do not match.
    """


class GeometryError(PlotgateError):
    """The geometry of the input has no solution (e.g. a mark at the sensor)."""
