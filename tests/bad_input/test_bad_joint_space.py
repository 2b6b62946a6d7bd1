"""Bad use of the joint-space helpers: each error names the joint, the input or the
coordinates at fault and says what to do (docs/errors.md, Multibody section)."""

from __future__ import annotations

import numpy as np
import pytest

from dalembert.errors import InputError, ModelError
from dalembert.examples import cart_pole, slider_crank
from dalembert.multibody import (
    Distance,
    Ground,
    Multibody,
    Particle,
    chain,
    inverse_dynamics,
    joint_positions,
    linearize_joints,
)


@pytest.fixture(scope="module")
def cart():
    return cart_pole.build_multibody()


def test_unknown_joint(cart):
    with pytest.raises(KeyError, match="no joint 'hnge'; the joints are rail, hinge"):
        joint_positions(cart, cart_pole.UPRIGHT, joints=["hnge"])
    with pytest.raises(KeyError, match="no joint coordinate 'hnge'; there are rail, hinge"):
        joint_positions(cart, cart_pole.UPRIGHT)["hnge"]


def test_joint_without_coordinates():
    bob = Particle("bob", 1.0)
    mb = Multibody([bob], [Distance("rod", Ground(), bob, 1.0)])
    with pytest.raises(ModelError, match="joint 'rod' \\(Distance\\) has no joint coordinates"):
        joint_positions(mb, {"bob_z": -1.0}, joints=["rod"])


def test_linearize_with_too_few_coordinates(cart):
    with pytest.raises(ValueError, match=r"2 degrees of freedom: give 2 coordinates .* got 1 "
                                         r"\(hinge\)"):
        linearize_joints(cart, cart_pole.UPRIGHT, ["hinge"])


def test_linearize_in_coordinates_that_do_not_fix_the_motion():
    mb = slider_crank.build_multibody()
    state = slider_crank.INITIAL["q0"]
    from dalembert.statics import linearize

    lin = linearize(mb.system, mb.system.equilibrium(state))
    with pytest.raises(ValueError, match="the coordinates piston_theta do not fix the motion"):
        lin.in_coordinates(["piston_theta"])


def test_linearize_in_a_ball_joint_is_refused():
    mb = chain(1, 1.0, 1.0, 0.05)
    with pytest.raises(ModelError, match="joint 'joint1' \\(Spherical\\) is not a hinge or a "
                                         "slide"):
        linearize_joints(mb, {"link1_z": -0.5, "link1_b0": 1.0}, ["joint1"])


def test_an_input_the_model_lacks(cart):
    with pytest.raises(InputError, match="'force' is not an input of the model; its inputs "
                                         "are u"):
        linearize_joints(cart, cart_pole.UPRIGHT, ["rail", "hinge"], inputs={"force": 1.0})
    with pytest.raises(InputError, match="the value of input 'u' at the equilibrium must be "
                                         "a number, got 'x'"):
        linearize_joints(cart, cart_pole.UPRIGHT, ["rail", "hinge"], inputs={"u": "x"})
    with pytest.raises(InputError, match="as a dict"):
        linearize_joints(cart, cart_pole.UPRIGHT, ["rail", "hinge"], inputs=2.0)


def test_a_motion_the_actuators_cannot_produce(cart):
    q = np.array([0.0, 0.0, 0.0, *cart_pole.tilted(0.3).values()])  # tilted, at rest
    with pytest.raises(ValueError, match=r"the actuated joints rail cannot produce this "
                                         r"motion: a generalized force of .* on pole_"):
        inverse_dynamics(cart, 0.0, q, None, np.zeros(6))
    # the least-squares torque on request, with what is left over
    need = inverse_dynamics(cart, 0.0, q, None, np.zeros(6), tol=None)
    assert np.abs(need.residual).max() > 0.1  # the weight's moment on the pole is unheld


def test_joints_of_the_wrong_kind_or_named_twice(cart):
    with pytest.raises(TypeError, match=r"joints must be joints or their names, got 3 \(int\); "
                                        r"the joints are rail, hinge"):
        joint_positions(cart, cart_pole.UPRIGHT, joints=3)
    with pytest.raises(ValueError, match="joint 'rail' is named twice; name each joint once"):
        inverse_dynamics(cart, 0.0, cart_pole.UPRIGHT, None, np.zeros(6),
                         actuated=["rail", "rail"])
    with pytest.raises(ValueError, match="joint 'hinge' is named twice"):
        linearize_joints(cart, cart_pole.UPRIGHT, ["hinge", "hinge"])


def test_no_joint_actuated(cart):
    with pytest.raises(ModelError, match=r"actuated=\[\] names no joint: name the joints "
                                         r"whose torques you want \(the joints with "
                                         r"coordinates are rail, hinge\)"):
        inverse_dynamics(cart, 0.0, cart_pole.UPRIGHT, None, np.zeros(6), actuated=[])


@pytest.mark.parametrize(("name", "value"), [
    ("t", float("nan")), ("t", "0"), ("tol", float("nan")), ("tol", -1.0), ("tol", "x")])
def test_a_time_or_tolerance_that_is_not_a_number(cart, name, value):
    """A NaN tolerance let any residual pass: torques for a motion the actuators cannot
    produce, silently."""
    q = np.array([0.0, 0.0, 0.0, *cart_pole.tilted(0.3).values()])  # tilted, at rest
    t, tol = (value, 1e-8) if name == "t" else (0.0, value)
    with pytest.raises(ValueError, match=f"The '{name}' parameter of inverse_dynamics must "
                                         "be a finite"):
        inverse_dynamics(cart, t, q, None, np.zeros(6), tol=tol)
    if name == "t":
        with pytest.raises(ValueError, match="The 't' parameter of inverse_dynamics must "
                                             "be a finite number"):
            cart.system.inverse_dynamics(t, q, None, np.zeros(6))


def test_parameters_a_mechanism_without_parameters_lacks(cart):
    """They were dropped without a word (the answer of the mechanism's own values)."""
    from dalembert.errors import ParameterError

    with pytest.raises(ParameterError, match=r"'zz' is not a parameter of this model \(its "
                                             r"parameters: none\)"):
        joint_positions(cart, cart_pole.UPRIGHT, parameters={"zz": 1.0})
