"""Control in joint space: the actuated joints' torques for a motion, and a
linearization in joint coordinates with the model's inputs.

Inverse dynamics. A motion ``(q, qd, qdd)`` that the constraints allow needs the
generalized force ``r = M qdd - f`` (:meth:`dalembert.System.inverse_dynamics`; ``f``
the model's own forces, its inputs at zero). The actuated joints supply ``B tau``, with
``B = J^T`` the map of their torques and forces to generalized forces (virtual work, see
:mod:`~dalembert.multibody.joint_space`), and the constraints ``A^T lambda``:

    M qdd - f = B tau + A^T lambda,

solved for ``(tau, lambda)``. With ``Z`` an orthonormal basis of ``null(A)``,
``Z^T A^T = 0`` removes the multipliers: ``Z^T B tau = Z^T r`` in least squares (``tau``
unique when ``Z^T B`` has full column rank), then ``lambda`` the minimum-norm solution of
``A^T lambda = r - B tau``. What neither supplies, ``Z Z^T (r - B tau)``, is the
residual: zero when the actuators can produce the motion.

Linearization. :func:`dalembert.statics.linearize` gives ``x' = A_ss x + B_inputs du`` on
the constraints' tangent space; :meth:`~dalembert.statics.Linearization.in_coordinates`
changes to coordinates ``y`` with ``dy = J dq``, here the chosen joints' rows of
:func:`~dalembert.multibody.joint_space.joint_jacobian` (a hinge's angle, a slide's
travel: their velocities are their rates).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from ..errors import ModelError
from ..model.values import CoordinateValues, coordinate_values
from ..numerics.rank import RANK_RTOL, min_norm_multipliers
from ..rules import NONE, FiniteNumber, PositiveNumber, Table, check_parameters
from .builder import Multibody
from .joint_space import JointValues, joint_jacobian, selected_joints
from .joints import Joint, Prismatic, Revolute
from .types import FloatArray

if TYPE_CHECKING:  # statics (scipy.optimize) is imported when a linearization is made
    from ..statics import Equilibrium, StateSpace

@dataclass(frozen=True)
class JointEfforts:
    """The actuated joints' torques and forces for a motion (see
    :mod:`~dalembert.multibody.joint_control`).

    Attributes
    ----------
    torques : JointValues
        By joint velocity name: a hinge's torque about its axis and a slide's force
        along it (on body ``b``; the opposite on ``a``), a ball joint's three torques
        in ``a``'s joint frame.
    multipliers : numpy.ndarray
        ``lambda``, in constraint order (minimum norm).
    residual : numpy.ndarray
        The generalized force neither the actuators nor the constraints supply
        (coordinate order): zero for a motion the actuators can produce.
    """

    torques: JointValues
    multipliers: FloatArray
    residual: FloatArray


#: inverse_dynamics's time and tolerance (a NaN tolerance would let any residual pass).
_CHECKED: Table = {"t": [FiniteNumber()], "tol": [PositiveNumber(), NONE]}


def _actuated(mb: Multibody, actuated: Sequence[Joint | str] | None) -> list[Joint]:
    if actuated is not None:
        chosen = selected_joints(mb, actuated)
        if not chosen:
            raise ModelError("actuated=[] names no joint: name the joints whose torques you "
                             "want (the joints with coordinates are "
                             f"{', '.join(j.name for j in selected_joints(mb, None))}), or "
                             "leave it out for those carrying an Actuator")
        return chosen
    joints: list[Joint] = []
    for actuator in mb.actuators:
        if not any(actuator.joint is j for j in joints):
            joints.append(actuator.joint)
    if not joints:
        raise ModelError(
            f"no joint of {mb.name!r} is actuated: add an Actuator, or name the joints "
            f"whose torques you want with actuated=[...] (the joints with coordinates are "
            f"{', '.join(j.name for j in selected_joints(mb, None)) or 'none'})")
    return joints


def inverse_dynamics(
    mb: Multibody,
    t: float,
    q: CoordinateValues,
    qd: CoordinateValues | None,
    qdd: CoordinateValues,
    *,
    actuated: Sequence[Joint | str] | None = None,
    parameters: Mapping[Any, object] | None = None,
    tol: float | None = 1e-8,
) -> JointEfforts:
    """The torques and forces the actuated joints must apply for a motion.

    Parameters
    ----------
    mb
        The mechanism.
    t
        The time.
    q, qd, qdd
        The motion at one instant (dict by coordinate or sequence; ``qd`` ``None``: at
        rest); ``qdd`` must satisfy the constraints differentiated twice.
    actuated
        The joints (or names) that act; default those carrying an
        :class:`~dalembert.multibody.Actuator`, in the order of the actuators.
    parameters
        Parameter values overriding the mechanism's.
    tol
        The residual (see :class:`JointEfforts`) allowed, relative to ``|M qdd - f|``;
        more raises. ``None``: return the least-squares torques whatever the residual.

    Returns
    -------
    JointEfforts
        ``torques`` by name, ``multipliers`` and ``residual``.

    Raises
    ------
    ValueError
        ``qdd`` violates a constraint; or the actuators cannot produce the motion (the
        message names the coordinate where most force is missing).
    ModelError
        No joint is actuated, or the actuated joints' torques are not determined (the
        constraints carry one of them: the message names the joints).

    Examples
    --------
    A planar link hung from a motor, held still at 90 degrees: the motor carries the
    weight's moment ``m g l / 2``:

    >>> from dalembert.multibody import chain
    >>> mb = chain(1, 1.0, 2.0, 0.05, joint="revolute", planar=True)
    >>> q = {"link1_x": 0.5, "link1_y": 0.0, "link1_theta": np.pi / 2}
    >>> need = inverse_dynamics(mb, 0.0, q, None, {}, actuated=["joint1"])
    >>> round(need.torques["joint1"], 12)
    9.81
    """
    import scipy.linalg

    check_parameters({"t": t, "tol": tol}, _CHECKED, "inverse_dynamics")
    system = mb.system
    names = system.coordinate_names
    joints = _actuated(mb, actuated)
    q_ = coordinate_values(q, names, "q")
    need = system.inverse_dynamics(t, q_, qd, qdd, parameters=parameters)
    r = need.required
    labels, J = joint_jacobian(mb, q_, joints=joints, parameters=parameters)
    A = system.numeric(parameters).velocity_constraint(float(t), q_)[0]
    Z = scipy.linalg.null_space(A) if A.size else np.eye(len(names))
    ZB = Z.T @ J.T
    singular = np.linalg.svd(ZB, compute_uv=False)
    if len(singular) < len(labels) or singular[-1] <= RANK_RTOL * max(singular[0], 1e-300):
        raise ModelError(
            f"the torques of the actuated joints {', '.join(j.name for j in joints)} are "
            "not determined by the motion: the constraints carry some combination of them "
            "(a joint locked by the others, or a loop it cannot move); actuate fewer joints")
    tau = np.linalg.lstsq(ZB, Z.T @ r, rcond=None)[0]
    left = r - J.T @ tau
    residual = Z @ (Z.T @ left)
    scale = max(float(np.abs(r).max(initial=0.0)), 1e-300)
    worst = int(np.argmax(np.abs(residual))) if residual.size else 0
    if tol is not None and residual.size and abs(residual[worst]) > tol * scale:
        raise ValueError(
            f"the actuated joints {', '.join(j.name for j in joints)} cannot produce this "
            f"motion: a generalized force of {residual[worst]:.3g} on {names[worst]} is "
            "left that neither they nor the constraints supply; actuate more joints, give "
            "a motion they can produce, or pass tol=None for the least-squares torques")
    lam = min_norm_multipliers(A, left) if A.size else np.zeros(0)
    return JointEfforts(JointValues(labels, tau), lam, residual)


def linearize_joints(
    mb: Multibody,
    q_eq: Equilibrium | CoordinateValues,
    coordinates: Sequence[Joint | str],
    **options: Any,
) -> StateSpace:
    """``x' = A x + B u`` about an equilibrium in joint coordinates, with the model's
    inputs: ready for :mod:`scipy.signal` or an LQR design.

    Parameters
    ----------
    mb
        The mechanism.
    q_eq
        The equilibrium: an :class:`~dalembert.statics.Equilibrium` or a configuration.
    coordinates
        Hinge and slide joints (or names), as many as the degrees of freedom there: the
        state is their changes from the equilibrium, then their rates
        (``<joint>_dot``).
    options
        :func:`dalembert.statics.linearize`'s keywords: ``inputs`` (their values at
        the equilibrium, by name), ``parameters``, ``t``, ``fixed``, ``tol``...

    Returns
    -------
    StateSpace
        ``A``, ``B`` (``B`` per unit of each of the model's inputs), ``state_names``,
        ``input_names``.

    Raises
    ------
    ModelError
        A coordinate is not a hinge or a slide (named).
    ValueError
        Not as many coordinates as degrees of freedom, or they do not fix the motion.

    Examples
    --------
    A planar link hanging from a motor ``u``: ``I theta'' = -m g l/2 theta + u`` with
    ``I = m l^2 / 3`` about the pin:

    >>> import sympy as sp
    >>> from dalembert.multibody import Actuator, Ground, Multibody, PlanarBody, Revolute
    >>> u = sp.Symbol("u")
    >>> link = PlanarBody("link", 3.0, 3.0 / 12)
    >>> pin = Revolute("pin", Ground(), link, (0, 0, 0), (-0.5, 0, 0))
    >>> mb = Multibody([link], [pin], gravity=(0, -9.81, 0),
    ...                actuators=[Actuator("motor", pin, u)], inputs=[u])
    >>> down = {"link_x": 0.0, "link_y": -0.5, "link_theta": -np.pi / 2}
    >>> ss = linearize_joints(mb, down, ["pin"])
    >>> ss.state_names, ss.A.round(9).tolist(), ss.B.round(9).tolist()
    (('pin', 'pin_dot'), [[0.0, 1.0], [-14.715, 0.0]], [[0.0], [1.0]])
    """
    from ..statics import linearize

    chosen = selected_joints(mb, coordinates)
    for joint in chosen:
        if not isinstance(joint, Revolute | Prismatic):
            raise ModelError(
                f"joint {joint.name!r} ({type(joint).__name__}) is not a hinge or a slide: "
                "linearize in joint coordinates takes Revolute and Prismatic joints")
    lin = linearize(mb.system, cast(Any, q_eq), **options)
    parameters = {**_equilibrium_parameters(q_eq), **(options.get("parameters") or {})}
    names, J = joint_jacobian(mb, lin.q, joints=chosen, parameters=parameters or None)
    return lin.in_coordinates(J, names)


def _equilibrium_parameters(q_eq: object) -> dict[str, float]:
    """The parameter values an Equilibrium was found with (none for a configuration)."""
    return dict(getattr(q_eq, "parameter_values", None) or {})
