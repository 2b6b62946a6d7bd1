"""A Multibody given what is not a list of bodies or joints, an initial state that is
not a dict by body, parameter values for a mechanism without parameters: each named
(they gave Python's own TypeError or AttributeError from inside the builder, or, for
the parameters, nothing at all)."""

from __future__ import annotations

import pytest

from dalembert import InitialConditionError, ModelError, ParameterError
from dalembert.multibody import Multibody
from dalembert.multibody.bodies import Ground, Particle
from dalembert.multibody.joints import Distance


@pytest.mark.parametrize(("bodies", "got"), [(None, "None"), ("bob", "'bob'"), (3, "3")])
def test_bodies_that_are_not_a_sequence_are_named(bodies, got):
    with pytest.raises(ModelError, match=r"^bodies must be a sequence of Particle, RigidBody "
                                         rf"or PlanarBody objects, got {got}$"):
        Multibody(bodies)


def test_a_joint_that_is_not_a_joint_is_named():
    with pytest.raises(ModelError, match=r"^joints must be Joint objects, got 5$"):
        Multibody([Particle("bob", 1.0)], joints=[5])


def test_an_initial_state_argument_that_is_not_a_dict_is_named():
    bob = Particle("bob", 1.0)
    mb = Multibody([bob], joints=[Distance("rod", Ground(), bob, 1.0)])
    with pytest.raises(InitialConditionError, match=r"^velocities must be a dict \{body or "
                                                    r"body name: value\}, got \[1, 0, 0\]$"):
        mb.initial_state(positions={"bob": (1.0, 0.0, 0.0)}, velocities=[1, 0, 0])


def test_a_parameter_a_mechanism_without_parameters_lacks_is_named():
    mb = Multibody([Particle("bob", 1.0)])
    with pytest.raises(ParameterError, match=r"^'m' is not a parameter of this model"):
        mb.bound({"m": 2.0})
    assert mb.bound() is mb and mb.bound(None) is mb
