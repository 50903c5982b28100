"""VehicleSpec -> URDF (lxml), loadable by PyBullet and Gazebo; standard tags only.

Links (body FLU, metres, origin = the frame's centre of mass):

* ``base_link``: the frame's mass and principal inertia, a collision box whose bottom is at
  ``-landing_gear_height_m`` (the skids), so the CoM rests ``landing_gear_height_m`` above the ground;
* ``rotor_<i>`` (i = 1..n, vehicle order): ``rotor_mass_kg`` as a thin disc, fixed joint at the hub;
* ``tank``: massless marker link at the tank mount (fixed joint). The liquid is **not** in the
  URDF: the tank model applies its weight and inertial force as an external force;
* ``payload``: the fixed payload mass at its position (only if the mass is > 0).

Rotors are fixed: the simulation applies thrust and torques as external forces (the rotors'
spin is not simulated, as docs/firmware-protocols.md §1 says of Gazebo).
"""

from __future__ import annotations

from pathlib import Path

from lxml import etree

from vinecli.specs.vehicle import VehicleSpec

__all__ = ["ROTOR_RADIUS_M", "link_names", "rigid_inertia", "vehicle_urdf", "write_urdf"]

#: visual/inertial radius of a rotor disc, m (only its mass matters for the dynamics)
ROTOR_RADIUS_M = 0.06


def _f(x: float) -> str:
    return repr(float(x))


def _vec(v: tuple[float, ...]) -> str:
    return " ".join(_f(c) for c in v)


def _inertial(parent: etree._Element, mass: float, ixx: float, iyy: float, izz: float) -> None:
    inertial = etree.SubElement(parent, "inertial")
    etree.SubElement(inertial, "origin", xyz="0 0 0", rpy="0 0 0")
    etree.SubElement(inertial, "mass", value=_f(mass))
    etree.SubElement(inertial, "inertia", ixx=_f(ixx), ixy="0", ixz="0", iyy=_f(iyy), iyz="0", izz=_f(izz))


def _fixed_joint(robot: etree._Element, name: str, child: str, xyz: tuple[float, float, float]) -> None:
    j = etree.SubElement(robot, "joint", name=name, type="fixed")
    etree.SubElement(j, "parent", link="base_link")
    etree.SubElement(j, "child", link=child)
    etree.SubElement(j, "origin", xyz=_vec(xyz), rpy="0 0 0")


def link_names(vehicle: VehicleSpec) -> list[str]:
    """Child link names in URDF (and PyBullet joint index) order."""
    names = [f"rotor_{i + 1}" for i in range(vehicle.n_rotors)]
    if vehicle.tank is not None:
        names.append("tank")
    if vehicle.payload.mass_kg > 0:
        names.append("payload")
    return names


def _rotor_inertia(m: float) -> tuple[float, float, float]:
    r = ROTOR_RADIUS_M
    return (m * r * r / 4.0, m * r * r / 4.0, m * r * r / 2.0)


def vehicle_urdf(vehicle: VehicleSpec) -> str:
    """URDF text for ``vehicle`` (see the module docstring for the links)."""
    robot = etree.Element("robot", name=vehicle.name)
    fr = vehicle.frame
    base = etree.SubElement(robot, "link", name="base_link")
    _inertial(base, fr.mass_kg, *fr.inertia_kgm2)
    bx, by, bz = fr.collision_box_m
    cz = -fr.landing_gear_height_m + bz / 2.0
    for tag in ("visual", "collision"):
        el = etree.SubElement(base, tag)
        etree.SubElement(el, "origin", xyz=_vec((0.0, 0.0, cz)), rpy="0 0 0")
        geom = etree.SubElement(el, "geometry")
        etree.SubElement(geom, "box", size=_vec((bx, by, bz)))
    m_r = vehicle.motor.rotor_mass_kg
    for i, rotor in enumerate(vehicle.rotors):
        name = f"rotor_{i + 1}"
        link = etree.SubElement(robot, "link", name=name)
        _inertial(link, m_r, *_rotor_inertia(m_r))
        vis = etree.SubElement(link, "visual")
        etree.SubElement(vis, "origin", xyz="0 0 0", rpy="0 0 0")
        geom = etree.SubElement(vis, "geometry")
        etree.SubElement(geom, "cylinder", radius=_f(ROTOR_RADIUS_M), length="0.005")
        _fixed_joint(robot, f"rotor_{i + 1}_joint", name, rotor.position_m)
    if vehicle.tank is not None:
        link = etree.SubElement(robot, "link", name="tank")
        _inertial(link, 0.0, 0.0, 0.0, 0.0)
        _fixed_joint(robot, "tank_joint", "tank", vehicle.tank.mount_m)
    if vehicle.payload.mass_kg > 0:
        link = etree.SubElement(robot, "link", name="payload")
        m = vehicle.payload.mass_kg
        _inertial(link, m, 1e-4 * m, 1e-4 * m, 1e-4 * m)
        _fixed_joint(robot, "payload_joint", "payload", vehicle.payload.position_m)
    return etree.tostring(robot, pretty_print=True, xml_declaration=True, encoding="utf-8").decode("utf-8")


def write_urdf(vehicle: VehicleSpec, path: Path) -> Path:
    """Write :func:`vehicle_urdf` to ``path`` and return it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(vehicle_urdf(vehicle), encoding="utf-8")
    return path


def rigid_inertia(vehicle: VehicleSpec) -> tuple[float, tuple[float, float, float], tuple[float, float, float]]:
    """(mass kg, CoM m FLU, diagonal inertia kg m² about that CoM) of all rigid links together.

    Off-diagonal terms are neglected (they vanish for symmetric rotor layouts).
    """
    parts: list[tuple[float, tuple[float, float, float], tuple[float, float, float]]] = [
        (vehicle.frame.mass_kg, (0.0, 0.0, 0.0), tuple(vehicle.frame.inertia_kgm2))  # type: ignore[list-item]
    ]
    m_r = vehicle.motor.rotor_mass_kg
    for rotor in vehicle.rotors:
        parts.append((m_r, tuple(rotor.position_m), _rotor_inertia(m_r)))  # type: ignore[arg-type]
    if vehicle.payload.mass_kg > 0:
        m = vehicle.payload.mass_kg
        parts.append((m, tuple(vehicle.payload.position_m), (1e-4 * m,) * 3))  # type: ignore[arg-type]
    mass = sum(p[0] for p in parts)
    com = tuple(sum(p[0] * p[1][k] for p in parts) / mass for k in range(3))
    ixx = iyy = izz = 0.0
    for m, (x, y, z), (a, b, c) in parts:
        dx, dy, dz = x - com[0], y - com[1], z - com[2]
        ixx += a + m * (dy * dy + dz * dz)
        iyy += b + m * (dx * dx + dz * dz)
        izz += c + m * (dx * dx + dy * dy)
    return mass, com, (ixx, iyy, izz)  # type: ignore[return-value]
