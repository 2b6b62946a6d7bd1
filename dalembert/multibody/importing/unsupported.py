"""What an imported model holds that dalembert leaves out, found in MuJoCo's compiled
model and listed in one :class:`~dalembert.UnsupportedModelFeatureWarning`."""

from __future__ import annotations

import warnings
from collections.abc import Collection, Iterable, Sequence
from typing import Any

import numpy as np

from ...errors import UnsupportedModelFeatureWarning, user_stacklevel


def _names(model: Any, kind: str, ids: Iterable[int]) -> str:
    """``'a', 'b', 'c'`` and how many more."""
    names = [repr(getattr(model, kind)(int(i)).name or f"{kind}{int(i)}") for i in ids]
    shown = ", ".join(names[:4])
    return shown + (f" and {len(names) - 4} more" if len(names) > 4 else "")


def _disabled(model: Any, flag: str) -> bool:
    import mujoco

    return bool(model.opt.disableflags & int(getattr(mujoco.mjtDisableBit, flag)))


def contact_possible(model: Any) -> bool:
    """Whether two geoms of the model may touch: on bodies that can move relative to
    each other (not parent and child, MuJoCo's default filter), with matching
    ``contype``/``conaffinity``, not excluded; or an explicit contact ``<pair>``."""
    if _disabled(model, "mjDSBL_CONTACT") or _disabled(model, "mjDSBL_CONSTRAINT"):
        return False
    if model.npair:
        return True
    weld = np.asarray(model.body_weldid)
    parent = weld[np.asarray(model.body_parentid)]
    excluded = {int(s) for s in np.asarray(model.exclude_signature).ravel()}
    filter_parent = not _disabled(model, "mjDSBL_FILTERPARENT")
    contype, affinity = np.asarray(model.geom_contype), np.asarray(model.geom_conaffinity)
    bodies = weld[np.asarray(model.geom_bodyid)]
    active = np.flatnonzero((contype != 0) | (affinity != 0))
    for n, g in enumerate(active):
        for h in active[n + 1:]:
            a, b = int(bodies[g]), int(bodies[h])
            if a == b or not (contype[g] & affinity[h] or contype[h] & affinity[g]):
                continue
            # MuJoCo filters parent and child, but never the world's geoms
            if filter_parent and a and b and (parent[a] == b or parent[b] == a):
                continue
            if (min(a, b) << 16) + max(a, b) in excluded:
                continue
            return True
    return False


def model_features(model: Any, limited: Collection[int] = ()) -> list[str]:
    """The features of the compiled model that dalembert does not model, one phrase each.

    Parameters
    ----------
    model
        MuJoCo's compiled ``MjModel``.
    limited
        The joints whose limits are imported (:mod:`.limits`): not listed.

    Examples
    --------
    >>> import mujoco
    >>> model = mujoco.MjModel.from_xml_string(
    ...     "<mujoco><worldbody><body><joint limited='true' range='-1 1'/>"
    ...     "<geom size='.1'/></body></worldbody></mujoco>")
    >>> model_features(model)
    ["joint limits (range) on 'joint0'"]
    """
    out = []
    if contact_possible(model):
        out.append("contact between geoms (no contact forces; disable it in the file, "
                   "<option><flag contact='disable'/>, to silence this)")
    if model.ntendon:
        out.append(f"tendons {_names(model, 'tendon', range(model.ntendon))}")
    checks = [
        ("jnt_limited", "joint limits (range)", "joint", "mjDSBL_LIMIT"),
        ("dof_armature", "armature (rotor inertia)", "dof", None),
        ("dof_frictionloss", "friction loss", "dof", "mjDSBL_FRICTIONLOSS"),
    ]
    for attribute, what, per, flag in checks:
        ids = np.flatnonzero(np.asarray(getattr(model, attribute)))
        if attribute == "jnt_limited":
            ids = np.array([j for j in ids if j not in limited], dtype=int)
        if flag is not None and _disabled(model, flag):
            continue
        if len(ids):
            joints = np.unique(model.dof_jntid[ids]) if per == "dof" else ids
            out.append(f"{what} on {_names(model, 'joint', joints)}")
    if np.any(getattr(model, "jnt_springyield", 0)):
        out.append("yielding joint springs (springyield)")
    if np.any(model.body_gravcomp):
        out.append("gravity compensation (gravcomp)")
    if model.opt.viscosity or model.opt.density or np.any(model.opt.wind):
        out.append("fluid forces (viscosity, density or wind)")
    if np.any(np.asarray(model.body_mocapid) >= 0):
        ids = np.flatnonzero(np.asarray(model.body_mocapid) >= 0)
        out.append(f"mocap bodies {_names(model, 'body', ids)} (held fixed)")
    if getattr(model, "nflex", 0):
        out.append("flexible bodies (flex)")
    return out


def warn_unsupported(label: str, features: Sequence[str]) -> None:
    """One :class:`~dalembert.UnsupportedModelFeatureWarning` listing ``features``.

    Parameters
    ----------
    label
        The source (a path, or "the MJCF string").
    features
        What the mechanism leaves out (nothing: no warning).

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     warn_unsupported("the MJCF string", ["tendons 't'"])
    >>> print(caught[0].message)
    the MJCF string: dalembert leaves out what it does not model: tendons 't'
    """
    if features:
        warnings.warn(f"{label}: dalembert leaves out what it does not model: "
                      + "; ".join(features), UnsupportedModelFeatureWarning,
                      stacklevel=user_stacklevel())
