"""Coordinate units of a point cloud: feet -> metres, degrees -> UTM metres, and the metric CRS.

Horizontal units come from the CRS axes (``pyproj.CRS.axis_info``), so CRSs without an EPSG
code (ESRI-style WKT such as the Autzen sample in international feet) are handled. Vertical
units come, in this order, from a vertical axis of the CRS (compound or 3-D CRS), the LAS
GeoTIFF VerticalUnitsGeoKey, or else are assumed equal to the horizontal units (the LAS
convention when nothing else is said). A cloud without CRS is taken as metres.

After conversion the coordinates are metres in :func:`metric_crs` of the source CRS: the same
datum and projection with every linear axis unit set to metre (for a projected CRS in feet,
``x_m = x_ft * 0.3048`` exactly, because PROJ applies the unit after the false easting, which
it keeps in metres).
"""

from __future__ import annotations

import logging
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from vinecli.terrain.pointcloud.readers import RawCloud

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class CloudUnits:
    """How file coordinates become metres.

    ``xy_to_m`` / ``z_to_m``: metres per file unit (1.0 for metres). ``z_source`` says where the
    vertical unit came from: ``crs``, ``geokey``, ``assumed-horizontal`` or ``no-crs``.
    ``geographic``: x/y are longitude/latitude degrees, reprojected to UTM.
    """

    xy_unit: str
    xy_to_m: float
    z_unit: str
    z_to_m: float
    z_source: str
    geographic: bool = False

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return asdict(self)


def cloud_units(raw: RawCloud) -> CloudUnits:
    """Units of ``raw`` from its CRS and LAS keys (see module docstring)."""
    crs = raw.crs
    if crs is None:
        return CloudUnits("metre (no CRS: assumed)", 1.0, "metre (no CRS: assumed)", 1.0, "no-crs")
    horizontal, vertical_axis = _split_axes(crs)
    geographic = bool(horizontal and horizontal[0].unit_name in ("degree", "grad", "radian") or crs.is_geographic)
    if geographic:
        xy_unit, xy_to_m = "degree", 1.0
    elif horizontal:
        xy_unit, xy_to_m = horizontal[0].unit_name, float(horizontal[0].unit_conversion_factor)
        if len(horizontal) > 1 and abs(horizontal[1].unit_conversion_factor - xy_to_m) > 1e-12:
            log.warning("%s: x and y axes have different units; using the x unit", raw.path)
    else:
        xy_unit, xy_to_m = "metre (CRS has no axes: assumed)", 1.0
    if vertical_axis is not None:
        z_unit, z_to_m, source = vertical_axis.unit_name, float(vertical_axis.unit_conversion_factor), "crs"
    elif raw.vertical_unit_factor is not None:
        z_to_m, source = raw.vertical_unit_factor, "geokey"
        z_unit = _unit_name(z_to_m)
    elif geographic:
        z_unit, z_to_m, source = "metre", 1.0, "assumed-metre"
    else:
        z_unit, z_to_m, source = xy_unit, xy_to_m, "assumed-horizontal"
    return CloudUnits(xy_unit, xy_to_m, z_unit, z_to_m, source, geographic)


def _split_axes(crs: Any) -> tuple[list[Any], Any]:
    """(horizontal axes, vertical axis or None) of a possibly compound CRS."""
    axes = list(crs.axis_info)
    vertical = next((a for a in axes if a.direction in ("up", "down")), None)
    horizontal = [a for a in axes if a.direction not in ("up", "down")]
    return horizontal, vertical


def _unit_name(factor: float) -> str:
    names = {1.0: "metre", 0.3048: "foot", 1200.0 / 3937.0: "US survey foot", 1000.0: "kilometre"}
    return next((n for f, n in names.items() if abs(f - factor) < 1e-12), f"{factor} m")


def metric_crs(crs: Any) -> Any:
    """The same CRS with every linear axis in metres (None stays None; a metric CRS is returned as is)."""
    if crs is None:
        return None
    from pyproj import CRS

    if all(a.unit_name == "metre" for a in crs.axis_info if a.unit_name not in ("degree", "radian", "grad")):
        return crs
    doc = crs.to_json_dict()
    _metres_in_place(doc)
    try:
        out = CRS.from_json_dict(doc)
    except Exception as exc:  # noqa: BLE001 - pyproj raises CRSError or ValueError on odd definitions
        log.warning("cannot build a metric version of CRS %r (%s); outputs carry no CRS", crs.name, exc)
        return None
    return out


def _metres_in_place(node: Any) -> None:
    """Set the unit of every linear coordinate-system axis in a PROJJSON tree to metre."""
    if isinstance(node, dict):
        cs = node.get("coordinate_system")
        changed = False
        if isinstance(cs, dict):
            for axis in cs.get("axis", []):
                unit = axis.get("unit")
                linear = (isinstance(unit, dict) and unit.get("type") == "LinearUnit") or unit in (
                    "foot", "US survey foot", "kilometre")
                if linear and unit != "metre":
                    axis["unit"] = "metre"
                    changed = True
        if changed and isinstance(node.get("name"), str):
            node["name"] = node["name"] + " (metre)"
        for key, value in node.items():
            if key != "coordinate_system":
                _metres_in_place(value)
    elif isinstance(node, list):
        for item in node:
            _metres_in_place(item)


def to_metres(xyz: np.ndarray, crs: Any, units: CloudUnits) -> tuple[np.ndarray, Any]:
    """File coordinates -> (metres (N, 3) float64, CRS of those metres or None).

    Projected/local CRS: scaled by the unit factors into :func:`metric_crs`. Geographic CRS:
    lon/lat reprojected to the WGS84 UTM zone at the cloud's centre (z scaled by ``z_to_m``).
    """
    out = np.empty_like(xyz, dtype=np.float64)
    if units.geographic:
        from pyproj import CRS, Transformer
        from pyproj.aoi import AreaOfInterest
        from pyproj.database import query_utm_crs_info

        lon, lat = float(np.mean(xyz[:, 0])), float(np.mean(xyz[:, 1]))
        infos = query_utm_crs_info(datum_name="WGS 84",
                                   area_of_interest=AreaOfInterest(lon, lat, lon, lat))
        utm = CRS.from_epsg(infos[0].code)
        source = crs.sub_crs_list[0] if crs.is_compound else crs
        tr = Transformer.from_crs(source, utm, always_xy=True)
        out[:, 0], out[:, 1] = tr.transform(xyz[:, 0], xyz[:, 1])
        out[:, 2] = xyz[:, 2] * units.z_to_m
        return out, utm
    out[:, :2] = xyz[:, :2] * units.xy_to_m
    out[:, 2] = xyz[:, 2] * units.z_to_m
    return out, metric_crs(crs)


def crs_summary(crs: Any, *, wkt: bool = True) -> dict[str, Any] | None:
    """Name, EPSG code (or None), compound flag and (optionally) WKT of a CRS for JSON outputs."""
    if crs is None:
        return None
    out = {"name": crs.name, "epsg": crs.to_epsg(), "is_compound": bool(crs.is_compound)}
    if wkt:
        out["wkt"] = crs.to_wkt()
    return out
