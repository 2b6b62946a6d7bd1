"""Andrews' squeezing mechanism (index 3): the IVP Test Set's 7-body problem as a System.

The formulas, constants, consistent initial values and the reference solution at
t = 0.03 are those of the Test Set for IVP Solvers (F. Mazzia, C. Magherini et al.,
University of Bari, problem "andrews", Fortran file ``andrews.f``;
https://archimede.uniba.it/~testset/problems/andrews.php), after E. Hairer and G.
Wanner, Solving Ordinary Differential Equations II, Section VII.7. The Test Set writes
the equations ``M(q) q'' = f(q, q') - G(q)^T lambda``, ``g(q) = 0``; here the System is
given its kinetic energy ``T = 1/2 q'^T M(q) q'`` (dalembert derives the velocity terms
of ``f``, which the Test Set writes out), the spring's potential ``c0/2 (l - l0)^2`` and
the motor's constant torque ``mom`` on ``beta`` (a potential ``-mom beta``), and the
Test Set's six position constraints ``g``.

Shared by the solver tests (imported by name).
"""

from __future__ import annotations

import sympy as sp

from dalembert import Holonomic, System, coordinates

M1, M2, M3, M4, M5, M6, M7 = .04325, .00365, .02373, .00706, .07050, .00706, .05498
XA, YA, XB, YB, XC, YC = -.06934, -.00227, -.03635, .03273, .014, .072
C0, L0, MOM = 4530.0, 7785e-5, 33e-3
I1, I2, I3, I4, I5, I6, I7 = 2.194e-6, 4.410e-7, 5.255e-6, 5.667e-7, 1.169e-5, 5.667e-7, 1.912e-5
D, DA, E, EA, RR, RA = 28e-3, 115e-4, 2e-2, 1421e-5, 7e-3, 92e-5
SS, SA, SB, SC, SD = 35e-3, 1874e-5, 1043e-5, 18e-3, 2e-2
TA, TB, U, UA, UB = 2308e-5, 916e-5, 4e-2, 1228e-5, 449e-5
ZF, ZT, FA = 2e-2, 4e-2, 1421e-5

NAMES = ("beta", "theta", "gamma", "phi", "delta", "omega", "epsilon")
#: Consistent initial positions (the velocities are 0), from the Test Set.
Q0 = (-0.0617138900142764496358948458001, 0.0, 0.455279819163070380255912382449,
      0.222668390165885884674473185609, 0.487364979543842550225598953530,
      -0.222668390165885884674473185609, 1.23054744454982119249735015568)
T_END = 0.03
#: The Test Set's reference positions and velocities at T_END (PSIDE at tolerance 1e-14).
Q_REF = (0.1581077119629904e+2, -0.1575637105984298e+2, 0.4082224013073101e-1,
         -0.5347301163226948e+0, 0.5244099658805304e+0, 0.5347301163226948e+0,
         0.1048080741042263e+1)
QD_REF = (0.1139920302151208e+4, -0.1424379294994111e+4, 0.1103291221937134e+2,
          0.1929337464421385e+2, 0.5735699284790808e+0, -0.1929337464421385e+2,
          0.3231791658026955e+0)


def build_andrews() -> System:
    """The squeezer as a System of the seven angles, six constraints."""
    q = coordinates(" ".join(NAMES))
    be, th, ga, ph, de, om, ep = q
    qd = sp.Matrix([c.diff() for c in q])
    mass = sp.zeros(7, 7)
    mass[0, 0] = M1 * RA**2 + M2 * (RR**2 - 2 * DA * RR * sp.cos(th) + DA**2) + I1 + I2
    mass[1, 0] = M2 * (DA**2 - DA * RR * sp.cos(th)) + I2
    mass[1, 1] = M2 * DA**2 + I2
    mass[2, 2] = M3 * (SA**2 + SB**2) + I3
    mass[3, 3] = M4 * (E - EA)**2 + I4
    mass[4, 3] = M4 * ((E - EA)**2 + ZT * (E - EA) * sp.sin(ph)) + I4
    mass[4, 4] = (M4 * (ZT**2 + 2 * ZT * (E - EA) * sp.sin(ph) + (E - EA)**2)
                  + M5 * (TA**2 + TB**2) + I4 + I5)
    mass[5, 5] = M6 * (ZF - FA)**2 + I6
    mass[6, 5] = M6 * ((ZF - FA)**2 - U * (ZF - FA) * sp.sin(om)) + I6
    mass[6, 6] = (M6 * ((ZF - FA)**2 - 2 * U * (ZF - FA) * sp.sin(om) + U**2)
                  + M7 * (UA**2 + UB**2) + I6 + I7)
    for i in range(7):
        for j in range(i):
            mass[j, i] = mass[i, j]
    kinetic = (qd.T * mass * qd)[0, 0] / 2
    xd = SD * sp.cos(ga) + SC * sp.sin(ga) + XB
    yd = SD * sp.sin(ga) - SC * sp.cos(ga) + YB
    length = sp.sqrt((xd - XC)**2 + (yd - YC)**2)
    potential = C0 / 2 * (length - L0)**2 - MOM * be
    rods = RR * sp.cos(be) - D * sp.cos(be + th), RR * sp.sin(be) - D * sp.sin(be + th)
    g = [rods[0] - SS * sp.sin(ga) - XB,
         rods[1] + SS * sp.cos(ga) - YB,
         rods[0] - E * sp.sin(ph + de) - ZT * sp.cos(de) - XA,
         rods[1] + E * sp.cos(ph + de) - ZT * sp.sin(de) - YA,
         rods[0] - ZF * sp.cos(om + ep) - U * sp.sin(ep) - XA,
         rods[1] - ZF * sp.sin(om + ep) + U * sp.cos(ep) - YA]
    return System(list(q), kinetic=kinetic, potential=potential,
                  constraints=[Holonomic(gi, name=f"g{i + 1}") for i, gi in enumerate(g)],
                  name="Andrews' squeezer")
