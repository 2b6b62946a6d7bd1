"""Input functions that return nothing: the message says they returned None."""

from __future__ import annotations

import warnings

import pytest
import sympy as sp

from dalembert import InputError, System, coordinates

(theta,) = coordinates("theta")
u, v = sp.symbols("u v")


def pushed(*inputs: sp.Symbol) -> System:
    return System([theta], kinetic=theta.diff() ** 2 / 2, potential=-9.81 * sp.cos(theta),
                  generalized_forces={theta: sum(inputs)}, inputs=list(inputs))


def forgot_to_return(t):
    0.5 * t  # the return statement a user forgot


@pytest.mark.parametrize("backend", ["c", "python"])
@pytest.mark.parametrize(("model", "inputs", "what"), [
    ((u,), forgot_to_return, "the input 'u'"),
    ((u, v), {"u": forgot_to_return, "v": 1.0}, "the input 'u'"),
    ((u, v), forgot_to_return, "inputs= (all of u, v)"),
])
def test_an_input_function_returning_none_is_said_to(model, inputs, what, backend):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            traj = pushed(*model).simulate((0, 1), {theta: 1.0}, inputs=inputs,
                                           backend=backend)
        except InputError as exc:
            message = str(exc)
        else:
            message = traj.message
    assert "returned None" in message and "[nan]" not in message, message
    assert what in message, message
