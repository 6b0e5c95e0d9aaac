"""Tests of core.errors: message format, attributes, hierarchy and pickling."""

import pickle

import pytest

from plotgate.core import (
    CovarianceError,
    GeometryError,
    NonFiniteError,
    ParameterError,
    PlotgateError,
)


@pytest.mark.parametrize(
    "cls",
    [NonFiniteError, CovarianceError, ParameterError, GeometryError],
    ids=lambda c: c.__name__,
)
def test_every_error_is_a_plotgate_value_error(cls):
    err = cls("P2", "is not positive definite", 4)
    assert isinstance(err, PlotgateError) and isinstance(err, ValueError)
    assert (err.field, err.reason, err.index) == ("P2", "is not positive definite", 4)
    assert str(err) == "P2[4]: is not positive definite"
    copy = pickle.loads(pickle.dumps(err))
    assert type(copy) is cls and str(copy) == str(err) and copy.index == 4


def test_message_without_index():
    err = ParameterError("v_min", "v_min (600.0) exceeds v_max (500.0)")
    assert err.index is None
    assert str(err) == "v_min: v_min (600.0) exceeds v_max (500.0)"
