"""Built world -> Gazebo (gz-sim) SDF 1.9 world, so the thesis' toolchain can open it.

Contents: physics at the world's rate, the standard gz-sim systems, ``<spherical_coordinates>``
(EARTH_WGS84, ENU, origin lat/lon/elevation), ``<wind>`` (the law's mean vector) with the
wind-effects system, the terrain (``<heightmap>`` of the 16-bit PNG, size in metres and
``<pos>`` offset by the minimum elevation — gazebosim/docs#589; or one ``<mesh>`` per tile; or a
plane) and the vehicle model: base link, one link per rotor on a revolute joint driven by a
``gz-sim-multicopter-motor-model-system`` plugin (PX4 x500 style), and the tank link.
The tank's liquid and the thesis' "sloshing-effects" plugin have no gz-sim counterpart and
are not written.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from lxml import etree

from vinecli.flight.wind import heading_unit_enu
from vinecli.geo import GeoOrigin
from vinecli.specs.vehicle import VehicleSpec
from vinecli.specs.wind import ConstantWind, DrydenWind, GustWind, SinusoidWind, SumWind, WindLaw, WindSpec

__all__ = ["mean_wind_enu", "world_sdf"]


def _f(x: float) -> str:
    return f"{float(x):.9g}"


def _v(*xs: float) -> str:
    return " ".join(_f(x) for x in xs)


def _sub(parent: etree._Element, tag: str, text: str | None = None, **attrib: str) -> etree._Element:
    el = etree.SubElement(parent, tag, **attrib)
    if text is not None:
        el.text = text
    return el


def mean_wind_enu(law: WindLaw) -> tuple[float, float, float]:
    """Mean (steady) part of a wind law, m/s ENU (gusts and turbulence average to zero)."""
    if isinstance(law, ConstantWind):
        return tuple(float(c) for c in law.velocity_enu)  # type: ignore[return-value]
    if isinstance(law, SinusoidWind):
        ex, ey, _ = heading_unit_enu(law.heading_deg)
        return (law.mean_mps * ex, law.mean_mps * ey, 0.0)
    if isinstance(law, DrydenWind):
        ex, ey, _ = heading_unit_enu(law.heading_deg)
        return (law.mean_mps * ex, law.mean_mps * ey, 0.0)
    if isinstance(law, GustWind):
        return (0.0, 0.0, 0.0)
    if isinstance(law, SumWind):
        parts = [mean_wind_enu(t) for t in law.terms]
        return (sum(p[0] for p in parts), sum(p[1] for p in parts), sum(p[2] for p in parts))
    raise TypeError(type(law).__name__)


def _inertial(link: etree._Element, mass: float, ixx: float, iyy: float, izz: float) -> None:
    ine = _sub(link, "inertial")
    _sub(ine, "mass", _f(mass))
    i = _sub(ine, "inertia")
    for k, val in (("ixx", ixx), ("ixy", 0.0), ("ixz", 0.0), ("iyy", iyy), ("iyz", 0.0), ("izz", izz)):
        _sub(i, k, _f(val))


def _vehicle_model(world: etree._Element, v: VehicleSpec, pose: tuple[float, float, float, float]) -> None:
    model = _sub(world, "model", name=v.name)
    x, y, z, yaw = pose
    _sub(model, "pose", _v(x, y, z, 0.0, 0.0, yaw))
    base = _sub(model, "link", name="base_link")
    _inertial(base, v.frame.mass_kg, *v.frame.inertia_kgm2)
    _sub(base, "enable_wind", "true")  # WindEffects acts on links that opt in
    bx, by, bz = v.frame.collision_box_m
    cz = -v.frame.landing_gear_height_m + bz / 2.0
    for tag in ("collision", "visual"):
        el = _sub(base, tag, name=f"base_{tag}")
        _sub(el, "pose", _v(0, 0, cz, 0, 0, 0))
        geom = _sub(el, "geometry")
        box = _sub(geom, "box")
        _sub(box, "size", _v(bx, by, bz))
    m_r = v.motor.rotor_mass_kg
    r = 0.06
    for i, rotor in enumerate(v.rotors):
        name = f"rotor_{i}"
        link = _sub(model, "link", name=name)
        _sub(link, "pose", _v(*rotor.position_m, 0, 0, 0))
        _inertial(link, m_r, m_r * r * r / 4, m_r * r * r / 4, m_r * r * r / 2)
        vis = _sub(link, "visual", name=f"{name}_visual")
        cyl = _sub(_sub(vis, "geometry"), "cylinder")
        _sub(cyl, "radius", _f(r))
        _sub(cyl, "length", "0.005")
        joint = _sub(model, "joint", name=f"{name}_joint", type="revolute")
        _sub(joint, "parent", "base_link")
        _sub(joint, "child", name)
        axis = _sub(joint, "axis")
        _sub(axis, "xyz", _v(*rotor.axis))
        lim = _sub(axis, "limit")
        _sub(lim, "lower", "-1e+16")
        _sub(lim, "upper", "1e+16")
    if v.tank is not None:
        tank = _sub(model, "link", name="tank")
        _sub(tank, "pose", _v(*v.tank.mount_m, 0, 0, 0))
        _inertial(tank, 1e-6, 1e-9, 1e-9, 1e-9)
        j = _sub(model, "joint", name="tank_joint", type="fixed")
        _sub(j, "parent", "base_link")
        _sub(j, "child", "tank")
    mo = v.motor
    for i, rotor in enumerate(v.rotors):
        pl = _sub(model, "plugin", filename="gz-sim-multicopter-motor-model-system",
                  name="gz::sim::systems::MulticopterMotorModel")
        for tag, val in (
            ("robotNamespace", v.name),
            ("jointName", f"rotor_{i}_joint"),
            ("linkName", f"rotor_{i}"),
            ("turningDirection", rotor.spin),
            ("timeConstantUp", _f(mo.tau_up_s)),
            ("timeConstantDown", _f(mo.tau_down_s)),
            ("maxRotVelocity", _f(mo.w_max)),
            ("motorConstant", _f(mo.k_f)),
            ("momentConstant", _f(mo.k_m)),
            ("commandSubTopic", "command/motor_speed"),
            ("motorNumber", str(i)),
            ("rotorDragCoefficient", _f(mo.k_d)),
            ("rollingMomentCoefficient", _f(mo.k_roll)),
            ("rotorVelocitySlowdownSim", "10"),
            ("motorType", "velocity"),
        ):
            _sub(pl, tag, val)


def _canopy_models(world: etree._Element, canopy: Any, ground: Callable[[float, float], float]) -> None:
    """One static, visual-only model per hedge (porous: drones and drops pass through it in the simulator):
    a green box per row segment from the foliage base to its top above the ground beside the row."""
    for h in canopy.hedges:
        if h.width_m <= 0 or h.depth_m <= 0 or h.row >= len(canopy.rows):
            continue
        pts = canopy.rows[h.row]
        half = 0.5 * (canopy.spacing_m if math.isfinite(canopy.spacing_m) else 2.0 * h.width_m)
        model = _sub(world, "model", name=f"hedge_{h.row}")
        _sub(model, "static", "true")
        link = _sub(model, "link", name="foliage")
        for k, ((x0, y0), (x1, y1)) in enumerate(zip(pts[:-1], pts[1:], strict=False)):
            seg = math.hypot(x1 - x0, y1 - y0)
            if seg <= 0:
                continue
            yaw = math.atan2(y1 - y0, x1 - x0)
            cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
            nx, ny = -math.sin(yaw) * half, math.cos(yaw) * half
            z0 = min(ground(cx + nx, cy + ny), ground(cx - nx, cy - ny))  # the ground in the inter-rows
            vis = _sub(link, "visual", name=f"segment_{k}")
            _sub(vis, "pose", _v(cx, cy, z0 + 0.5 * (h.base_m + h.top_m), 0.0, 0.0, yaw))
            _sub(_sub(_sub(vis, "geometry"), "box"), "size", _v(seg, h.width_m, h.depth_m))
            mat = _sub(vis, "material")
            _sub(mat, "diffuse", "0.18 0.49 0.2 1")
            _sub(mat, "ambient", "0.1 0.3 0.1 1")
            _sub(vis, "transparency", "0.35")


# parameters: keyword-only options, each with its default (every part of the world the SDF file describes); a caller names the ones it sets
def world_sdf(
    *,
    name: str,
    origin: GeoOrigin,
    rate_hz: float,
    gravity: float,
    wind: WindSpec,
    terrain: dict[str, object],
    vehicle: VehicleSpec,
    spawn: tuple[float, float, float, float],
    canopy: Any = None,
    ground: Callable[[float, float], float] | None = None,
) -> str:
    """SDF 1.9 text. ``terrain``: {"kind", "heightmap_png", "size_m", "z_min", "z_max", "centre",
    "tiles": [relative paths], "flat_z", "size"}; paths relative to the world directory. ``canopy``: the
    rows' hedges (:class:`vinecli.spray.canopy.Canopy`), drawn on ``ground`` (terrain z at x, y)."""
    sdf = etree.Element("sdf", version="1.9")
    world = _sub(sdf, "world", name=name)
    phys = _sub(world, "physics", name=f"{int(round(rate_hz))}hz", type="ignored")
    _sub(phys, "max_step_size", _f(1.0 / rate_hz))
    _sub(phys, "real_time_factor", "1.0")
    for fn, cls in (
        ("gz-sim-physics-system", "Physics"),
        ("gz-sim-user-commands-system", "UserCommands"),
        ("gz-sim-scene-broadcaster-system", "SceneBroadcaster"),
        ("gz-sim-sensors-system", "Sensors"),
        ("gz-sim-imu-system", "Imu"),
        ("gz-sim-navsat-system", "NavSat"),
        ("gz-sim-wind-effects-system", "WindEffects"),
    ):
        _sub(world, "plugin", filename=fn, name=f"gz::sim::systems::{cls}")
    _sub(world, "gravity", _v(0, 0, -gravity))
    sc = _sub(world, "spherical_coordinates")
    _sub(sc, "surface_model", "EARTH_WGS84")
    _sub(sc, "world_frame_orientation", "ENU")
    _sub(sc, "latitude_deg", f"{origin.lat:.9f}")
    _sub(sc, "longitude_deg", f"{origin.lon:.9f}")
    _sub(sc, "elevation", _f(origin.alt))
    _sub(sc, "heading_deg", "0")
    w = _sub(world, "wind")
    _sub(w, "linear_velocity", _v(*mean_wind_enu(wind.law)))
    sun = _sub(world, "light", type="directional", name="sun")
    _sub(sun, "cast_shadows", "true")
    _sub(sun, "pose", _v(0, 0, 50, 0, 0, 0))
    _sub(sun, "diffuse", "0.9 0.9 0.9 1")
    _sub(sun, "direction", "-0.5 0.1 -0.9")

    tm = _sub(world, "model", name="terrain")
    _sub(tm, "static", "true")
    link = _sub(tm, "link", name="terrain_link")
    kind = terrain["kind"]
    if kind == "heightmap":
        sx, sy = terrain["size_m"]  # type: ignore[misc]
        zmin, zmax = float(terrain["z_min"]), float(terrain["z_max"])  # type: ignore[arg-type]
        cx, cy = terrain["centre"]  # type: ignore[misc]
        for tag in ("collision", "visual"):
            el = _sub(link, tag, name=f"terrain_{tag}")
            hm = _sub(_sub(el, "geometry"), "heightmap")
            _sub(hm, "uri", str(terrain["heightmap_png"]))
            _sub(hm, "size", _v(sx, sy, max(zmax - zmin, 1e-3)))
            _sub(hm, "pos", _v(cx, cy, zmin))
    elif kind == "tiles":
        _sub(tm, "pose", _v(*terrain.get("offset", (0.0, 0.0, 0.0)), 0.0, 0.0, 0.0))  # type: ignore[misc]
        tm.insert(1, tm[-1])  # <pose> before <link>
        for i, rel in enumerate(terrain["tiles"]):  # type: ignore[attr-defined]
            for tag in ("collision", "visual"):
                el = _sub(link, tag, name=f"tile_{i}_{tag}")
                mesh = _sub(_sub(el, "geometry"), "mesh")
                _sub(mesh, "uri", str(rel))
    else:
        size = float(terrain.get("size", 200.0))  # type: ignore[arg-type]
        _sub(link, "pose", _v(0, 0, float(terrain.get("flat_z", 0.0)), 0, 0, 0))  # type: ignore[arg-type]
        for tag in ("collision", "visual"):
            el = _sub(link, tag, name=f"ground_{tag}")
            pl = _sub(_sub(el, "geometry"), "plane")
            _sub(pl, "normal", "0 0 1")
            _sub(pl, "size", _v(size, size))
    if canopy is not None and ground is not None:
        _canopy_models(world, canopy, ground)
    _vehicle_model(world, vehicle, spawn)
    return etree.tostring(sdf, pretty_print=True, xml_declaration=True, encoding="utf-8").decode("utf-8")


def sdf_uris(path: Path) -> list[str]:
    """Every ``<uri>`` in an SDF file (for checks)."""
    tree = etree.parse(str(path))
    return [u.text or "" for u in tree.iter("uri")]
