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
