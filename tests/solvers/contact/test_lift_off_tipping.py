"""A body resting on contacts lifted by a growing force at a point off its mass centre:
it leaves its contacts one after another, tipping in between.

References (minimal coordinates, integrated here at tight tolerance). A block ``2a``
wide and ``2b`` high, of mass ``m`` and inertia ``I = m (a^2 + b^2) / 3`` about its
centre ``(x, y)``, turned by ``theta`` (counterclockwise), rests on its bottom corners
``(-+a, -b)`` (body frame; "left" and "right") on the floor ``y = 0`` under gravity, and
a vertical force ``F = k t`` lifts it at the body point ``(c, d)`` (here its top right
corner, ``c = a``, ``d = b``). Its arm about the centre is ``f = c cos(theta) -
d sin(theta)``; write ``h = a sin(theta) + b cos(theta)`` and ``h' = a cos(theta) -
b sin(theta)`` (``h'' = -h``).

1. At rest on both corners: the vertical forces and the moments about the centre,
   ``N_l + N_r = m g - F`` and ``a (N_r - N_l) + c F = 0``, give
   ``N_{l,r} = (m g - F) / 2 +- c F / (2 a)``; with ``c > 0`` the right corner's force
   reaches 0 first, when ``F (a + c) = m g a`` (the moment about the left corner), at
   ``t1 = m g a / (k (a + c))``. No horizontal force acts, so friction holds nothing.
   There ``F``'s moment about the left corner equals the weight's: the block starts
   to turn from rest with no angular acceleration (the right corner's force falls
   through 0, a smooth start, no impact).
2. Tipping on the left corner (``theta > 0``), which stays on the floor:
   ``y = h``, ``y'' = h' theta'' - h theta'^2``. Its forces are ``N`` (normal) and
   ``H`` (along ``x``); Newton-Euler reads ``m x'' = H``, ``m y'' = N + F - m g``,
   ``I theta'' = -h' N + h H + f F`` (the corner sits at ``(-h', -h)`` from the
   centre).

   a. Frictionless (``H = 0``): ``x`` stays 0 (the corner slides) and, eliminating
      ``N``, ``(I + m h'^2) theta'' = h' (m h theta'^2 + F - m g) + f F``.
   b. With friction, sticking: the corner is a fixed pivot at ``(-a, 0)``,
      ``x = h' - a``, and the moments about it give
      ``(I + m (a^2 + b^2)) theta'' = (h' + f) F - m g h'``; ``H = m x''`` with
      ``x'' = -h theta'' - h' theta'^2``. ``H < 0`` while ``N`` falls to 0, so
      ``|H| / N`` grows without bound: no finite ``mu`` holds the corner until it
      lifts. With a rough corner (``mu`` infinite) the lift-off has no solution:
      held, it would pull; let go, the pull of ``H`` gone, it accelerates into the
      floor (free: ``y'' = F / m - g``, ``I theta'' = f F``, the corner's height
      ``y - h`` accelerating at ``y'' - h' theta'' + h theta'^2 < 0``). With a
      finite ``mu`` it slips first, when ``|H| = mu N`` (the reference's root),
      towards ``+x``.
   c. Then sliding (``H = -mu N``): with ``P = h' + mu h``,
      ``(I + m P h') theta'' = P (m h theta'^2 + F - m g) + f F`` and
      ``x'' = -mu N / m``; the corner's slip velocity ``x' + h theta'`` stays > 0.

   The block leaves the floor when ``N`` reaches 0 (the reference's root).
3. Free: ``x'' = 0``, ``y'' = F / m - g``, ``I theta'' = f F``; every corner stays
   above the floor (checked in the reference).

A box on its four bottom corners lifted at the middle of its top edge at ``+x`` (in
its plane of symmetry ``y = 0``) moves in the ``x, z`` plane as the block does
(``a, b`` its half length and height, ``I`` about its ``y`` axis), each pair of
corners across ``y = 0`` carrying the block's corner's forces, half each. At rest its
four normal forces are not unique (coplanar corners: rank 3): any ``N + s (1, -1, 1,
-1)`` (corners in turn around the box) holds it; the symmetric distribution, each
pair equal, is orthogonal to that null direction, so it is the minimum-norm one (the
library's). Its far pair's forces reach 0 together, it tips about the edge through
the near pair, and it leaves them together. Frictionless, the near pair's two normal
rows are independent; held by friction, its two corners fixed leave the box the turn
about the line through them (six rows, rank 5), their forces unique but for equal
and opposite ones along that line, which the symmetric ones (none along ``y``) are
again orthogonal to.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from dalembert import IntegrationWarning, System, Unilateral, coordinates
from dalembert import t as time
from dalembert.multibody import Force, Ground, Multibody, RigidBody, plane_contact

g = 9.81
X, Y, TH = coordinates("x y theta")
#: the reference's integration tolerances (the library's run is compared with it at 1e-10)
RTOL, ATOL = 1e-12, 1e-14


@dataclass(frozen=True)
class Block:
    """A block ``2a x 2b`` of mass ``m`` (inertia ``inertia`` about its centre) lifted
    by ``rate t`` at the body point ``(c, d)``, on corners with friction ``mu``."""

    a: float
    b: float
    m: float
    inertia: float
    c: float
    d: float
    rate: float
    mu: float

    @property
    def rest_ends(self) -> float:
        """``t1``: the far corner's force reaches 0 (moment balance)."""
        return self.m * g * self.a / (self.rate * (self.a + self.c))

    def resting_forces(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The left and right corners' normal forces at rest (phase 1)."""
        lift = self.rate * t
        share, moment = (self.m * g - lift) / 2, self.c * lift / (2 * self.a)
        return share + moment, share - moment

    def arms(self, theta: float) -> tuple[float, float, float]:
        """``h``, ``h'`` and the lift's arm ``f`` at ``theta``."""
        s, c = math.sin(theta), math.cos(theta)
        return self.a * s + self.b * c, self.a * c - self.b * s, self.c * c - self.d * s

    def sticking(self, t: float, theta: float, omega: float) -> tuple[float, float, float]:
        """``theta''``, ``N`` and ``H`` turning about the fixed left corner (2b)."""
        h, hp, f = self.arms(theta)
        lift = self.rate * t
        pivot = self.inertia + self.m * (self.a**2 + self.b**2)
        acc = ((hp + f) * lift - self.m * g * hp) / pivot
        xdd, ydd = -h * acc - hp * omega**2, hp * acc - h * omega**2
        return acc, self.m * ydd + self.m * g - lift, self.m * xdd

    def sliding(self, t: float, theta: float, omega: float) -> tuple[float, float, float]:
        """``theta''``, ``N`` and ``H = -mu N`` on the left corner sliding towards
        ``+x`` (2a with ``mu = 0``, 2c)."""
        h, hp, f = self.arms(theta)
        lift = self.rate * t
        p = hp + self.mu * h
        acc = (p * (self.m * h * omega**2 + lift - self.m * g) + f * lift) \
            / (self.inertia + self.m * p * hp)
        normal = self.m * (hp * acc - h * omega**2) + self.m * g - lift
        return acc, normal, -self.mu * normal


def _event(fun: Callable[[float, np.ndarray], float]) -> Callable[[float, np.ndarray], float]:
    """``fun`` as a terminal event, crossing 0 downwards."""
    fun.terminal, fun.direction = True, -1  # type: ignore[attr-defined]
    return fun


@dataclass
class Reference:
    """The block's motion by phases (see the module docstring): the switch instants
    (``t1``, the slip if it sticks, the lift-off), and the centre, angle and left
    corner's forces at any time."""

    block: Block
    instants: list[float]
    phases: list[tuple[float, Callable[[float], np.ndarray]]]

    @classmethod
    def of(cls, block: Block, end: float) -> Reference:
        t1 = block.rest_ends
        instants, phases = [t1], []
        state = np.zeros(2)  # theta, omega
        t0 = t1
        if block.mu > 0:  # 2b: sticking until |H| = mu N
            def stick(t: float, s: np.ndarray) -> list[float]:
                return [s[1], block.sticking(t, *s)[0]]

            def slips(t: float, s: np.ndarray) -> float:
                _, normal, along = block.sticking(t, *s)
                return block.mu * normal + along  # H < 0: |H| < mu N while > 0

            held = solve_ivp(stick, (t0, end), state, rtol=RTOL, atol=ATOL,
                             events=_event(slips), dense_output=True)
            t0, state = held.t_events[0][0], held.y_events[0][0]
            instants.append(t0)
            phases.append((t0, cls._pivoted(block, held.sol)))
        x0 = block.arms(state[0])[1] - block.a if block.mu > 0 else 0.0
        v0 = -block.arms(state[0])[0] * state[1] if block.mu > 0 else 0.0

        def slide(t: float, s: np.ndarray) -> list[float]:
            acc, _, along = block.sliding(t, s[1], s[3])
            return [s[2], s[3], along / block.m, acc]

        leaves = _event(lambda t, s: block.sliding(t, s[1], s[3])[1])
        slid = solve_ivp(slide, (t0, end), [x0, state[0], v0, state[1]], rtol=RTOL,
                         atol=ATOL, events=leaves, dense_output=True)
        t0 = slid.t_events[0][0]
        x, theta, vx, omega = slid.y_events[0][0]
        instants.append(t0)
        phases.append((t0, cls._slid(block, slid.sol)))
        h, hp, _ = block.arms(theta)

        def fly(t: float, s: np.ndarray) -> list[float]:
            f = block.arms(s[2])[2] * block.rate * t
            return [s[3], s[4], s[5], 0.0, block.rate * t / block.m - g, f / block.inertia]

        free = solve_ivp(fly, (t0, end), [x, h, theta, vx, hp * omega, omega], rtol=RTOL,
                         atol=ATOL, dense_output=True)
        flight = free.sol(np.linspace(t0, end, 401))
        for u, v in itertools.product((-block.a, block.a), (-block.b, block.b)):
            # every corner above the floor (the near one from 0 on)
            height = flight[1] + u * np.sin(flight[2]) + v * np.cos(flight[2])
            assert height[1:].min() > 0.0, (u, v)
        phases.append((end, lambda t: np.concatenate([free.sol(t)[:3], [0.0, 0.0]])))
        return cls(block, instants, phases)

    @staticmethod
    def _pivoted(block: Block, sol) -> Callable[[float], np.ndarray]:
        def at(t: float) -> np.ndarray:
            theta, omega = sol(t)
            h, hp, _ = block.arms(theta)
            _, normal, along = block.sticking(t, theta, omega)
            assert theta >= 0.0
            return np.array([hp - block.a, h, theta, normal, along])
        return at

    @staticmethod
    def _slid(block: Block, sol) -> Callable[[float], np.ndarray]:
        def at(t: float) -> np.ndarray:
            x, theta, vx, omega = sol(t)
            _, normal, along = block.sliding(t, theta, omega)
            assert vx + block.arms(theta)[0] * omega > -1e-12  # slipping towards +x
            assert theta >= 0.0  # the far corner above the floor (2 a sin(theta))
            return np.array([x, block.arms(theta)[0], theta, normal, along])
        return at

    def at(self, t: np.ndarray) -> np.ndarray:
        """Rows ``x, y, theta, N, H`` (the left corner's forces; the right corner's
        force is 0 from ``t1``) at each time."""
        out = np.empty((len(t), 5))
        t1 = self.instants[0]
        for i, ti in enumerate(t):
            if ti <= t1:
                out[i] = [0.0, self.block.b, 0.0, self.block.resting_forces(ti)[0], 0.0]
                continue
            out[i] = next(at for end, at in self.phases if ti <= end)(ti)
        return out


def planar(block: Block) -> System:
    """The block as a :class:`~dalembert.System` in ``x, y, theta``, its corners'
    gaps their heights, their sliding velocities along ``x``."""

    def point(u: float, v: float) -> tuple[sp.Expr, sp.Expr]:
        return (X + u * sp.cos(TH) - v * sp.sin(TH), Y + u * sp.sin(TH) + v * sp.cos(TH))

    corners = []
    for name, u in (("left", -block.a), ("right", block.a)):
        px, py = point(u, -block.b)
        options = {"friction": block.mu, "tangents": [px.diff(time)]} if block.mu else {}
        corners.append(Unilateral(py, name, **options))
    lifted_at = point(block.c, block.d)[1]
    return System([X, Y, TH], kinetic=block.m / 2 * (X.diff()**2 + Y.diff()**2)
                  + block.inertia / 2 * TH.diff()**2,
                  potential=block.m * g * Y - block.rate * time * lifted_at,
                  constraints=corners)


A, B, M, RATE = 0.2, 0.3, 1.0, 20.0
MU = 0.5  # slips at 0.370, while |H| / N grows from 0 without bound
END = 0.8
TIMES = np.linspace(0.0, END, 41)


def block_of(mu: float) -> Block:
    """The block ``0.4 x 0.6`` lifted at its top right corner."""
    return Block(A, B, M, M * (A**2 + B**2) / 3, A, B, RATE, mu)


def check_run(traj, ref: Reference, positions: np.ndarray, forces: dict[str, np.ndarray],
              order: list[tuple[int, ...]], tol: float = 1e-10) -> None:
    """The switches in ``order`` at the reference's instants (to ``tol / 10``), the
    ``x, y, theta`` in ``positions`` as the reference's at every output time (to
    ``tol``), the near (left) corner's forces ``forces`` (``"N"``, ``"H"``) and the far
    one's (``"far"``) as its (to ``tol`` times the weight), and every force exactly 0
    once it has left. Switches within rounding of each other are one: a pair of corners
    leaving together leaves as one, or one after the other within rounding of the
    instant, as the rounding of its symmetry falls."""
    assert traj.success, traj.message
    switches = [s for s, after in zip(traj.contacts.switches, [*traj.contacts.switches[1:], None])
                if after is None or after.t - s.t > 1e-12 * (1.0 + abs(s.t))]
    assert [s.closed for s in switches] == order
    found = np.array([s.t for s in switches[1:]])
    assert np.abs(found - ref.instants).max() < tol / 10, found - ref.instants
    expected = ref.at(traj.t)
    assert np.abs(positions - expected[:, :3]).max() < tol
    t1, off = ref.instants[0], ref.instants[-1]
    resting = traj.t <= t1
    assert resting.sum() > 5 and (traj.t > off).sum() > 5
    far = np.where(resting, ref.block.resting_forces(traj.t)[1], 0.0)
    scale = ref.block.m * g  # the forces' scale: the weight
    assert np.abs(forces["far"] - far).max() < tol * scale
    assert np.abs(forces["N"] - expected[:, 3]).max() < tol * scale
    if "H" in forces:
        assert np.abs(forces["H"] - expected[:, 4]).max() < tol * scale
    for force in forces.values():
        assert np.abs(force[traj.t > off]).max() == 0.0
    assert np.abs(forces["far"][traj.t > t1]).max() == 0.0


@pytest.mark.parametrize("backend", ["c", "python"])
@pytest.mark.parametrize("mu", [0.0, MU])
def test_a_block_lifted_at_a_corner_leaves_its_corners_one_after_the_other(mu, backend):
    """Both corners closed until ``t1``; then tipping on the left one, which slides
    (frictionless), or sticks until it slips (friction): the left corner alone, and
    free once its force reaches 0."""
    block = block_of(mu)
    ref = Reference.of(block, END)
    traj = planar(block).simulate((0.0, END), {X: 0.0, Y: B, TH: 0.0}, t_eval=TIMES,
                                  backend=backend)
    forces = {"N": traj.multiplier("left"), "far": traj.multiplier("right")}
    if mu:
        forces["H"] = traj.multiplier("left_friction_1")
        held = traj.multiplier("right_friction_1")  # nothing at rest, then open
        assert np.abs(held).max() < 1e-12 and np.abs(held[traj.t > ref.instants[0]]).max() == 0
    order = [(0, 1), (0,), (0,), ()] if mu else [(0, 1), (0,), ()]
    check_run(traj, ref, np.column_stack([traj["x"], traj["y"], traj["theta"]]), forces,
              order)


@pytest.mark.parametrize("backend", ["c", "python"])
def test_a_block_on_rough_corners_has_no_motion_past_its_lift_off(backend):
    """A rough floor (``mu`` infinite) holds the left corner until its normal force
    reaches 0 (2b, the reference's root), where ``H`` is not 0: held, the corner would
    pull; let go, the pull of ``H`` gone, it accelerates into the floor (the reference's
    free corner's acceleration < 0). No choice meets the complementarity conditions
    (with a finite ``mu`` it slips first): the run stops there, naming the corner."""
    block = block_of(math.inf)

    def stick(t: float, s: np.ndarray) -> list[float]:
        return [s[1], block.sticking(t, *s)[0]]

    leaves = _event(lambda t, s: block.sticking(t, *s)[1])
    held = solve_ivp(stick, (block.rest_ends, END), [0.0, 0.0], rtol=RTOL, atol=ATOL,
                     events=leaves)
    off, (theta, omega) = held.t_events[0][0], held.y_events[0][0]
    h, hp, f = block.arms(theta)
    lift = block.rate * off
    assert block.sticking(off, theta, omega)[2] < -1.0  # H, pulling the corner to -x
    # its height y - h accelerating, free: y'' = F / m - g, I theta'' = f F
    assert lift / block.m - g - hp * f * lift / block.inertia + h * omega**2 < -1.0
    with pytest.warns(IntegrationWarning, match="'left' can stay closed"):
        traj = planar(block).simulate((0.0, END), {X: 0.0, Y: B, TH: 0.0}, t_eval=TIMES,
                                      backend=backend)
    assert traj.status == "failed"
    switches = traj.contacts.switches
    assert [s.closed for s in switches[:2]] == [(0, 1), (0,)]
    instants = np.array([s.t for s in switches[1:3]])
    assert np.abs(instants - [block.rest_ends, off]).max() < 1e-11
    assert traj.t[-1] <= off


BOX_A, BOX_B, BOX_C, BOX_M = 0.2, 0.15, 0.1, 2.0
BOX_CORNERS = [(sx * BOX_A / 2, sy * BOX_B / 2) for sx, sy in [(-1, -1), (1, -1), (1, 1), (-1, 1)]]
NEAR, FAR = (0, 3), (1, 2)  # the corners at -x and at +x
#: How alike each pair's forces are, relative to the weight. Sliding from rest, the
#: near pair's friction takes its start direction (``+x``) until it slides at a small
#: speed, then its velocity's, whose part along ``y`` (0 but for rounding) is then a
#: relative 1e-9 of it: its friction pulls along ``y`` by that much, and its normal
#: forces differ to balance the moment, until the speed has grown.
PAIRED = 1e-9


def box_lifted(mu: float) -> tuple[Multibody, Block]:
    """The box ``0.2 x 0.15 x 0.1`` on its four bottom corners lifted by ``2 m g t``
    at the middle of its top edge at ``+x``, and its section in the ``x, z`` plane."""
    inertia = BOX_M / 12 * np.diag([BOX_B**2 + BOX_C**2, BOX_A**2 + BOX_C**2,
                                    BOX_A**2 + BOX_B**2])
    rate = 2 * BOX_M * g  # its far corners leave at t1 = 0.25
    body = RigidBody("box", BOX_M, inertia)
    corners = [plane_contact(f"c{k}", Ground(), body, point=(x, y, -BOX_C / 2), friction=mu)
               for k, (x, y) in enumerate(BOX_CORNERS)]
    box = Multibody([body], gravity=(0, 0, -g), contacts=corners,
                    forces=[Force(body, (0, 0, rate * time), point=(BOX_A / 2, 0, BOX_C / 2))])
    return box, Block(BOX_A / 2, BOX_C / 2, BOX_M, inertia[1, 1], BOX_A / 2, BOX_C / 2,
                      rate, mu)


@pytest.mark.parametrize("backend", ["c", "python"])
@pytest.mark.parametrize("mu", [0.0, MU])
def test_a_box_lifted_at_an_edge_leaves_its_far_corners_then_its_near_ones(mu, backend):
    """Its far pair leaves together at ``t1``, it tips about the near pair's edge
    (sliding, or sticking until both slip together), and leaves them together; each
    corner of a pair carries half the block's corner's force, and it neither moves
    along ``y`` nor turns about ``x`` or ``z``."""
    box, section = box_lifted(mu)
    ref = Reference.of(section, END)
    q0, qd0 = box.initial_state(positions={"box": (0, 0, BOX_C / 2)})
    # sliding from rest on two sliding velocities is stiff while slow (the direction of
    # v / |v| turns at |a_t| / |v|): the default method turns to Radau there, whose
    # values between its steps (the outputs, the state at the lift-off) are off by a
    # few 1e-10 at the default tolerance, by some 1e-12 at this one
    traj = box.simulate((0.0, END), q0, qd0, t_eval=TIMES, backend=backend,
                        rtol=1e-12 if mu else None)
    # turned about y by -theta (its +x side up): b0 = cos(theta / 2), b2 = -sin(theta / 2)
    theta = -2 * np.arctan2(traj["box_b2"], traj["box_b0"])
    # rounding, and the pull along y of PAIRED: the symmetric tipping amplifies
    # rounding, to 1e-13 .. 5e-11 at rtol from 5e-13 to 4e-12
    for part in ("y", "b1", "b3"):
        assert np.abs(traj[f"box_{part}"]).max() < 1e-10
    normal = [traj.multiplier(f"c{k}_1") for k in range(4)]
    scale = BOX_M * g
    for one, other in (NEAR, FAR):  # each pair alike
        assert np.abs(normal[one] - normal[other]).max() < PAIRED * scale
    forces = {"N": normal[NEAR[0]] + normal[NEAR[1]], "far": normal[FAR[0]] + normal[FAR[1]]}
    if mu:
        along = [traj.multiplier(f"c{k}_friction_1") for k in range(4)]
        across = [traj.multiplier(f"c{k}_friction_2") for k in range(4)]
        assert np.abs(along[NEAR[0]] - along[NEAR[1]]).max() < PAIRED * scale
        assert np.abs(np.concatenate(across)).max() < PAIRED * scale
        forces["H"] = along[NEAR[0]] + along[NEAR[1]]
    order = [(0, 1, 2, 3), NEAR, NEAR, ()] if mu else [(0, 1, 2, 3), NEAR, ()]
    check_run(traj, ref, np.column_stack([traj["box_x"], traj["box_z"], theta]), forces,
              order)
