"""Coordinates and constraints grouped by the body or joint they belong to, for plots
of many curves drawn as small multiples (one panel per group).

A system built by :class:`dalembert.multibody.Multibody` says which body owns each
coordinate and which joint each constraint row (the bodies' unit-quaternion rows form
one group of their own). For any other system, or a trajectory without its system,
the names say it: ``<prefix>_<rest>`` names sharing a prefix form the group
``<prefix>`` (the longest prefix shared by another name: ``arm_upper_x`` and
``arm_upper_y`` go to ``arm_upper``), the coordinates of a point ``x<s>, y<s>[, z<s>]``
the group ``point <s>``, and the other names one group of their own.
"""

from __future__ import annotations

from collections.abc import Sequence

from .drawers import multibody_or_none, particle_points

#: ``{title: [(column, label), ...]}``: each group's columns, in order, and their
#: labels within the group.
Groups = dict[str, list[tuple[int, str]]]
#: The title of the group of names that belong to no other.
OTHER = "other"
#: The title of the group of the bodies' unit-quaternion rows of a multibody system.
UNIT_QUATERNIONS = "unit quaternions"


def coordinate_groups(names: Sequence[str], system: object = None) -> Groups:
    """The coordinates ``names`` grouped by body (a multibody ``system``) or by name.

    Parameters
    ----------
    names
        Coordinate names, in column order.
    system
        The :class:`~dalembert.System` they come from, if known.

    Examples
    --------
    >>> coordinate_groups(["cart_x", "cart_y", "pole_x", "pole_y", "phi"])
    {'cart': [(0, 'x'), (1, 'y')], 'pole': [(2, 'x'), (3, 'y')], 'other': [(4, 'phi')]}
    >>> coordinate_groups(["x1", "y1", "x2", "y2"])
    {'point 1': [(0, 'x1'), (1, 'y1')], 'point 2': [(2, 'x2'), (3, 'y2')]}
    """
    mb = multibody_or_none(system)
    if mb is None:
        return name_groups(names)
    owners = {c.name: body.name for body in mb.bodies for c in body.coordinates}
    return _by_owner(names, owners)


def constraint_groups(names: Sequence[str], system: object = None) -> Groups:
    """The constraints ``names`` grouped by joint (a multibody ``system``) or by name.

    Parameters
    ----------
    names
        Constraint names, in column order.
    system
        The :class:`~dalembert.System` they come from, if known.

    Examples
    --------
    >>> constraint_groups(["hinge_1", "hinge_2", "rod"])
    {'hinge': [(0, '1'), (1, '2')], 'other': [(2, 'rod')]}
    """
    mb = multibody_or_none(system)
    if mb is None:
        return name_groups(names)
    owners = {row: joint.name for joint in mb.joints for row in joint.constraint_names}
    owners |= {row: UNIT_QUATERNIONS for body in mb.bodies for row in body.constraint_names}
    groups = _by_owner(names, owners)
    # a body's row is labelled by its body, not by what is left of its name
    body_of = {row: body.name for body in mb.bodies for row in body.constraint_names}
    if UNIT_QUATERNIONS in groups:
        groups[UNIT_QUATERNIONS] = [(i, body_of[names[i]]) for i, _ in groups[UNIT_QUATERNIONS]]
    return groups


def name_groups(names: Sequence[str]) -> Groups:
    """Group ``names`` by what they say: a shared ``<prefix>_``, a point's suffix, or none.

    Parameters
    ----------
    names
        Coordinate or constraint names, in column order.

    Examples
    --------
    >>> name_groups(["arm_upper_x", "arm_upper_y", "arm_lower_x", "arm_lower_y"])
    {'arm_upper': [(0, 'x'), (1, 'y')], 'arm_lower': [(2, 'x'), (3, 'y')]}
    """
    owner: dict[str, tuple[str, str]] = {}
    for point in particle_points(names):
        suffix = names[point[0]][1:]
        for i in point:
            owner[names[i]] = (f"point {suffix}" if suffix else "point", names[i])
    prefixes: dict[str, int] = {}
    for name in names:
        parts = name.split("_")
        for k in range(1, len(parts)):
            key = "_".join(parts[:k])
            prefixes[key] = prefixes.get(key, 0) + 1
    for name in names:
        if name in owner:
            continue
        parts = name.split("_")
        for k in range(len(parts) - 1, 0, -1):   # the longest prefix another name shares
            key = "_".join(parts[:k])
            if prefixes[key] > 1:
                owner[name] = (key, "_".join(parts[k:]))
                break
        else:
            owner[name] = (OTHER, name)
    groups: Groups = {}
    for i, name in enumerate(names):
        title, label = owner[name]
        groups.setdefault(title, []).append((i, label))
    if OTHER in groups:   # last, whatever the order of the names
        groups[OTHER] = groups.pop(OTHER)
    return groups


def _by_owner(names: Sequence[str], owners: dict[str, str]) -> Groups:
    groups: Groups = {}
    for i, name in enumerate(names):
        title = owners.get(name, OTHER)
        prefix = f"{title}_"
        label = name[len(prefix):] if name.startswith(prefix) else name
        groups.setdefault(title, []).append((i, label))
    return groups

