"""Spray tank: variable liquid mass and its force on the frame (thesis "sloshing-effects").

Mass from the nozzle flow command q (L/s, clamped to [0, nozzle_max_flow]) by backward
rectangular integration ``m_k = max(0, m_{k-1} - ρ q_k dt)``; a floating-point residue below
``EMPTY_EPS_KG`` (1e-9 kg, 1 µL of water) left by the subtractions is snapped to exactly 0, so a
tank drained for exactly volume / flow is empty (``empty`` True, ``level_l`` 0). The liquid pushes on the frame
at the tank mount with ``F = m (g - a_mount)`` (world ENU, g the gravity vector pointing
down): at rest the liquid weight, a jump at lift-off, the weight again in a steady climb.

Sloshing (``TankSpec.slosh``, beyond the thesis): the equivalent mechanical model of the
first lateral mode of an upright cylindrical tank (Abramson, NASA SP-106; Dodge, "The New
Dynamic Behavior of Liquids in Moving Containers", 2000). The tank is a cylinder of inner
height H = ``tank_height_m`` and radius R from the capacity (``π R² H``); the fill depth is
h = V/(π R²). With ξ = 1.841 (first root of J1'):

* pendulum mass ``m1 = m 2 tanh(ξ h/R) / (ξ (ξ² - 1) h/R)`` (the rest moves rigidly),
* pendulum length ``L1 = R / (ξ tanh(ξ h/R))``, natural frequency ``ω1² = g_eff / L1``,
* damping ratio ``ζ = slosh_damping_ratio``.

The bob's horizontal displacement x (world ENU, small angles) obeys
``ẍ + 2ζω1 ẋ + ω1² x = -a_h`` (a_h: horizontal mount acceleration, g_eff the vertical
component of g - a), integrated semi-implicitly at the step of the last :meth:`Tank.update`.
The bob adds ``-m1 ẍ`` to the force; its moment about the hinge is neglected (the force acts
at the mount). At rest and in steady flight the model reduces to the thesis' ``m (g - a)``.

Coupling to the rigid body (:class:`TankCoupling`, every physics step): the liquid is not part of the
rigid body, so the mount's acceleration is that of vehicle + liquid under this step's forces,
``a_mount = a_cm + α × r + ω × (ω × r)`` with ``a_cm = g + (F_ext + F_c) / (M + m)``
(:func:`mount_acceleration`); the ground-contact force of the last step comes from the finite-difference
acceleration, ``F_c = M (a - g) - F_ext,prev - F_tank,prev`` (:func:`contact_force`, M the rigid mass).
"""

from __future__ import annotations

import math
from typing import final

from vinecli.constants import STANDARD_GRAVITY
from vinecli.errors import SpecError
from vinecli.frames import BodyFrame, Vec3
from vinecli.specs.vehicle import TankSpec

__all__ = ["EMPTY_EPS_KG", "Tank", "TankCoupling", "contact_force", "mount_acceleration", "slosh_parameters"]

XI1 = 1.841
#: liquid mass below which the tank counts as empty (floating-point residue of the drain sum), kg
EMPTY_EPS_KG = 1e-9


def slosh_parameters(
    level_l: float, capacity_l: float, height_m: float, g: float = STANDARD_GRAVITY
) -> tuple[float, float, float]:
    """(pendulum mass fraction m1/m, length L1 m, ω1 rad/s) of the first slosh mode.

    Upright cylinder of height ``height_m`` and capacity ``capacity_l`` filled with ``level_l``.
    """
    area = capacity_l * 1e-3 / height_m
    r = math.sqrt(area / math.pi)
    h = max(level_l * 1e-3 / area, 1e-6)
    th = math.tanh(XI1 * h / r)
    frac = min(1.0, 2.0 * th / (XI1 * (XI1 * XI1 - 1.0) * h / r))
    length = r / (XI1 * th)
    return frac, length, math.sqrt(g / length)


class Tank:
    """Liquid in the spray tank. ``fill_l`` litres at start (0 ≤ fill ≤ capacity)."""

    def __init__(self, spec: TankSpec, fill_l: float) -> None:
        if not 0.0 <= fill_l <= spec.capacity_l * (1 + 1e-9):
            raise SpecError(f"tank fill {fill_l} L outside [0, {spec.capacity_l}] L")
        self.spec = spec
        self.rho = float(spec.liquid_density_kgm3)
        self._kg_per_l = self.rho * 1e-3
        self.capacity_l = float(spec.capacity_l)
        self.max_flow_lps = float(spec.nozzle_max_flow_lps)
        self.mount_m: Vec3 = tuple(float(c) for c in spec.mount_m)  # type: ignore[assignment]
        self.mass_kg = min(fill_l, self.capacity_l) * self._kg_per_l
        self.flow_lps = 0.0
        self.flow_cmd_lps = 0.0
        self._dt = 0.0
        self.slosh = bool(spec.slosh)
        self.zeta = float(spec.slosh_damping_ratio)
        self._x = [0.0, 0.0]  # bob displacement, m, world ENU horizontal
        self._v = [0.0, 0.0]
        self.slosh_force: Vec3 = (0.0, 0.0, 0.0)
        self._slosh_key: tuple[float, float] | None = None
        self._slosh_mode = (0.0, 1.0, 0.0)
        self.gravity_force: Vec3 = (0.0, 0.0, 0.0)
        self.inertial_force: Vec3 = (0.0, 0.0, 0.0)
        self.force: Vec3 = (0.0, 0.0, 0.0)

    @property
    def level_l(self) -> float:
        """Liquid volume, litres."""
        return self.mass_kg / self._kg_per_l

    @property
    def empty(self) -> bool:
        """True when no liquid is left."""
        return self.mass_kg <= 0.0

    @property
    def slosh_displacement(self) -> tuple[float, float]:
        """Horizontal displacement of the slosh pendulum bob (m, ENU x, y)."""
        return (self._x[0], self._x[1])

    def refill(self, fill_l: float) -> None:
        """The ground crew fills the tank to ``fill_l`` litres (clamped to the capacity); the
        liquid is at rest afterwards (slosh state cleared)."""
        self.mass_kg = min(max(float(fill_l), 0.0), self.capacity_l) * self._kg_per_l
        self.flow_lps = 0.0
        self._x = [0.0, 0.0]
        self._v = [0.0, 0.0]

    def update(self, flow_cmd_lps: float, dt: float) -> float:
        """Drain for ``dt`` s at the commanded flow (L/s); returns the new mass (kg)."""
        self.flow_cmd_lps = flow_cmd_lps
        q = min(max(flow_cmd_lps, 0.0), self.max_flow_lps)
        m0 = self.mass_kg
        m1 = m0 - self._kg_per_l * q * dt
        if m1 < EMPTY_EPS_KG:  # never below 0; a rounding residue of the sum counts as empty
            m1 = 0.0
        self.mass_kg = m1
        self.flow_lps = (m0 - m1) / (self._kg_per_l * dt) if dt > 0 else 0.0
        self._dt = dt
        return m1

    def force_world(self, g_enu: Vec3, a_mount_enu: Vec3) -> Vec3:
        """Force of the liquid on the frame (N, world ENU) at the mount: ``m (g - a)`` (+ slosh).

        ``g_enu`` gravity vector (e.g. (0, 0, -9.80665)), ``a_mount_enu`` the mount's acceleration.
        """
        m = self.mass_kg
        gx, gy, gz = g_enu
        ax, ay, az = a_mount_enu
        self.gravity_force = (m * gx, m * gy, m * gz)
        ix, iy, iz = -m * ax, -m * ay, -m * az
        if self.slosh and m > 0.0 and self._dt > 0.0:
            sx, sy = self._slosh_step(m, gx, gy, gz, ax, ay, az)
            self.slosh_force = (sx, sy, 0.0)
            ix += sx
            iy += sy
        else:
            self.slosh_force = (0.0, 0.0, 0.0)
        self.inertial_force = (ix, iy, iz)
        f = (m * gx + ix, m * gy + iy, m * gz + iz)
        self.force = f
        return f

    def _slosh_step(
        self, m: float, gx: float, gy: float, gz: float, ax: float, ay: float, az: float
    ) -> tuple[float, float]:
        g_eff = max(0.0, -(gz - az))
        g_nom = math.sqrt(gx * gx + gy * gy + gz * gz)
        key = (m, g_nom)
        if key != self._slosh_key:  # the mode only changes with the fill (and gravity)
            self._slosh_key = key
            self._slosh_mode = slosh_parameters(self.level_l, self.capacity_l, self.spec.tank_height_m, g_nom)
        frac, length, w0 = self._slosh_mode
        m1 = frac * m
        w2 = g_eff / length
        c = 2.0 * self.zeta * w0
        # horizontal excitation: mount acceleration minus any horizontal gravity component
        ex, ey = ax - gx, ay - gy
        dt = self._dt
        n = max(1, math.ceil(math.sqrt(w2) * dt / 0.2))
        h = dt / n
        x0, x1 = self._x
        v0, v1 = self._v
        a0 = a1 = 0.0
        for _ in range(n):
            a0 = -w2 * x0 - c * v0 - ex
            a1 = -w2 * x1 - c * v1 - ey
            v0 += h * a0
            v1 += h * a1
            x0 += h * v0
            x1 += h * v1
        self._x = [x0, x1]
        self._v = [v0, v1]
        return (-m1 * a0, -m1 * a1)


def contact_force(rigid_mass: float, acc: Vec3, g: Vec3, f_ext: Vec3, f_tank: Vec3) -> Vec3:
    """Ground-contact force on the rigid body over the last step, N ENU: ``M (a - g) - F_ext - F_tank``
    (``acc`` its finite-difference acceleration, ``f_ext`` and ``f_tank`` the forces applied then)."""
    return (rigid_mass * (acc[0] - g[0]) - f_ext[0] - f_tank[0], rigid_mass * (acc[1] - g[1]) - f_ext[1] - f_tank[1],
            rigid_mass * (acc[2] - g[2]) - f_ext[2] - f_tank[2])


def mount_acceleration(f_ext: Vec3, f_contact: Vec3, inv_mass: float, g: Vec3, alpha: Vec3, omega: Vec3,
                       r: Vec3) -> Vec3:
    """Acceleration of the point ``r`` (m from the centre of mass, ENU) of vehicle + liquid under
    ``f_ext + f_contact`` (N) with ``inv_mass`` = 1 / (M + m): ``a_cm + α × r + ω × (ω × r)``, m/s² ENU."""
    ox, oy, oz = omega
    lx, ly, lz = alpha
    rx, ry, rz = r
    cx, cy, cz = oy * rz - oz * ry, oz * rx - ox * rz, ox * ry - oy * rx  # ω × r
    return ((f_ext[0] + f_contact[0]) * inv_mass + g[0] + (ly * rz - lz * ry) + (oy * cz - oz * cy),
            (f_ext[1] + f_contact[1]) * inv_mass + g[1] + (lz * rx - lx * rz) + (oz * cx - ox * cz),
            (f_ext[2] + f_contact[2]) * inv_mass + g[2] + (lx * ry - ly * rx) + (ox * cy - oy * cx))


@final
class TankCoupling:
    """The liquid's force on the frame, step after step (module doc): remembers the forces of the last
    step to recover the ground contact. ``airborne``: the vehicle starts in the air (no contact at t = 0;
    on the ground the contact carries everything at first)."""

    def __init__(self, tank: Tank, rigid_mass: float, g: Vec3, airborne: bool) -> None:
        self.tank = tank
        self.rigid_mass = rigid_mass
        self.g = g
        self.mount: Vec3 = tank.mount_m
        self.first = True
        self.airborne = airborne
        self.f_ext: Vec3 = (0.0, 0.0, 0.0)
        self.f_tank: Vec3 = (0.0, 0.0, 0.0)

    def force(self, frame: BodyFrame, acc: Vec3, alpha: Vec3, omega: Vec3, f_ext: Vec3) -> tuple[Vec3, Vec3]:
        """(force N, mount position m from the centre of mass), world ENU, for this step: the body at attitude
        ``frame`` with finite-difference acceleration ``acc`` and angular acceleration ``alpha``, turning at
        ``omega`` (world), under ``f_ext`` (N: every force of this step but the liquid's)."""
        tank, g, m_rigid = self.tank, self.g, self.rigid_mass
        if not self.first:
            cc = contact_force(m_rigid, acc, g, self.f_ext, self.f_tank)
        elif self.airborne:
            cc = (0.0, 0.0, 0.0)
        else:  # resting: the ground carries everything
            m_all = m_rigid + tank.mass_kg
            cc = (-m_all * g[0], -m_all * g[1], -m_all * g[2])
        self.first = False
        self.f_ext = f_ext
        inv_m = 1.0 / (m_rigid + tank.mass_kg)
        mx, my, mz = self.mount
        r = frame.to_world(mx, my, mz)
        f = tank.force_world(g, mount_acceleration(f_ext, cc, inv_m, g, alpha, omega, r))
        self.f_tank = f
        return f, r
