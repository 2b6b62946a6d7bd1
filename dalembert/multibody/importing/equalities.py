"""MJCF equalities -> exact closed loops.

MuJoCo holds an equality softly (a stiff spring-damper through its solver's
``solref``/``solimp``), so its loops drift; dalembert makes each one a joint, held to
rounding: a ``connect`` a :class:`~dalembert.multibody.Spherical` joint between its two
anchors, a ``weld`` a :class:`~dalembert.multibody.Fixed` joint at the relative pose
MuJoCo's compiler gave it (that of ``qpos0``, or ``relpose``). The compiled data are
read: for a ``connect`` the anchor in body 1's frame, then in body 2's; for a ``weld``
the anchor in body 2's, then in body 1's, then body 2's orientation relative to
body 1's (``w, x, y, z``). An equality between sites takes the sites' frames.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..joints import Fixed, Joint, Spherical
from ..rotations import rotation_matrix
from .bodies import ReferencePose, identifier

CONNECT, WELD = 0, 1


@dataclass
class ImportedEqualities:
    """The loops read, and the equalities left out."""

    joints: list[Joint] = field(default_factory=list)
    unsupported: list[str] = field(default_factory=list)


def read_equalities(pose: ReferencePose, taken: set[str]) -> ImportedEqualities:
    """Every active ``connect`` and ``weld`` of the model as a joint.

    Parameters
    ----------
    pose
        The model at its reference pose, with its dalembert bodies.
    taken
        Names already given (the joints' are added).
    """
    import mujoco

    model = pose.model
    out = ImportedEqualities()
    for e in range(model.neq):
        kind, name = int(model.eq_type[e]), model.equality(e).name
        what = f"equality {name or e!r}"
        if kind not in (CONNECT, WELD):
            out.unsupported.append(f"{what} ({mujoco.mjtEq(kind).name[5:].lower()})")
            continue
        if not model.eq_active0[e]:
            out.unsupported.append(f"{what} (inactive at the start)")
            continue
        data = np.asarray(model.eq_data[e], dtype=float)
        ids = int(model.eq_obj1id[e]), int(model.eq_obj2id[e])
        if int(model.eq_objtype[e]) == int(mujoco.mjtObj.mjOBJ_SITE):
            frames = [(int(model.site_bodyid[s]), model.site_pos[s].copy(),
                       rotation_matrix(model.site_quat[s])) for s in ids]
            rel = np.eye(3)
        else:
            first = data[0:3] if kind == CONNECT else data[3:6]
            second = data[3:6] if kind == CONNECT else data[0:3]
            frames = [(ids[0], first, np.eye(3)), (ids[1], second, np.eye(3))]
            rel = np.eye(3) if kind == CONNECT else rotation_matrix(data[6:10])
        (k1, p1, R1), (k2, p2, R2) = frames
        a, b = pose.body_of(k1), pose.body_of(k2)
        if a is b:
            continue  # within one rigid body (or both on the ground): it always holds
        joint_name = identifier(name, f"{'connect' if kind == CONNECT else 'weld'}{e}", taken)
        point_a, point_b = pose.to_body(k1, p1), pose.to_body(k2, p2)
        if kind == CONNECT:
            out.joints.append(Spherical(joint_name, a, b, point_a, point_b))
            continue
        # body 2's frame axes as seen on body 1 (through the relative orientation) and on
        # body 2 itself: the weld keeps the two parallel
        frame_a = [pose.to_body_direction(k1, R1 @ rel @ e_) for e_ in np.eye(3)[[2, 0]]]
        frame_b = [pose.to_body_direction(k2, R2 @ e_) for e_ in np.eye(3)[[2, 0]]]
        out.joints.append(Fixed(joint_name, a, b, point_a, point_b, axis_a=frame_a[0],
                                axis_b=frame_b[0], ref_a=frame_a[1], ref_b=frame_b[1]))
    return out
