"""The car axis (IVP Test Set, index 3; Hairer and Wanner, Solving ODEs II, VII.7) as a
dalembert System, with the Test Set's reference solution at ``t = 3``.

The Test Set writes it as ``k u' = F + G^T lambda`` with ``k = M eps^2 / 2`` on all four
velocities, the springs' forces ``(L0 - Ll) xl / Ll`` ... (those of the potential
``(Ll - L0)^2 / 2 + (Lr - L0)^2 / 2``), gravity ``-k g`` on ``yl`` and ``yr`` and the
constraints

    psi1 = xb xl + yb yl = 0,        psi2 = (xl - xr)^2 + (yl - yr)^2 - L^2 = 0

with ``yb = r sin(w t)``, ``xb = sqrt(L^2 - yb^2)`` (the bump moves the right spring's
end); its multipliers enter as ``lambda1 (xb, yb, 0, 0) + lambda2 (2 (xl - xr), 2 (yl -
yr), -2 (xl - xr), -2 (yl - yr))``, that is ``A^T lambda`` with ``A = dpsi/dq`` of the
constraints written as above: dalembert's sign and scale (``M qdd = f + A^T lambda``,
``M = k I``), so the reference multipliers compare one to one.

Reference: the Test Set's ``caraxis`` reference at ``t = 3`` (22 digits, computed by
GAMD in quadruple precision; the values of the Test Set's documentation and of
deTestSet's ``reference("caraxis")``).
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from dalembert import Holonomic, System, coordinates
from dalembert import t as time

#: ``(xl, yl, xr, yr)`` at ``t = 3``.
REFERENCE_POSITIONS = np.array([0.493455784275402809122e-1, 0.496989460230171153861,
                                0.104174252488542151681e1, 0.373911027265361256927])
#: ``(ul, vl, ur, vr)`` at ``t = 3``.
REFERENCE_VELOCITIES = np.array([-0.770583684040972357970e-1, 0.744686658723778553466e-2,
                                 0.175568157537232222276e-1, 0.770341043779251976443])
#: ``(lambda1, lambda2)`` at ``t = 3``.
REFERENCE_MULTIPLIERS = np.array([-0.473688659084893324729e-2, -0.110468033125734368808e-2])

#: The Test Set's consistent start: ``xl = 0, yl = 1/2, xr = 1, yr = 1/2``,
#: ``ul = ur = -1/2, vl = vr = 0``.
Q0 = [0.0, 0.5, 1.0, 0.5]
QD0 = [-0.5, 0.0, -0.5, 0.0]


def build() -> System:
    """The car axis with the Test Set's values (``eps = 1e-2``, ``M = 10``, ``L = 1``,
    ``L0 = 1/2``, ``r = 0.1``, ``w = 10``, ``g = 1``)."""
    xl, yl, xr, yr = coordinates("xl yl xr yr")
    eps, mass, L, L0, r, w, g = 1e-2, 10.0, 1.0, 0.5, 0.1, 10.0, 1.0
    k = mass * eps**2 / 2
    yb = r * sp.sin(w * time)
    xb = sp.sqrt(L**2 - yb**2)
    left = sp.sqrt(xl**2 + yl**2)
    right = sp.sqrt((xr - xb) ** 2 + (yr - yb) ** 2)
    return System(
        [xl, yl, xr, yr],
        kinetic=k / 2 * sum(c.diff() ** 2 for c in (xl, yl, xr, yr)),
        potential=(left - L0) ** 2 / 2 + (right - L0) ** 2 / 2 + k * g * (yl + yr),
        constraints=[Holonomic(xb * xl + yb * yl, name="axle"),
                     Holonomic((xl - xr) ** 2 + (yl - yr) ** 2 - L**2, name="bar")],
    )
