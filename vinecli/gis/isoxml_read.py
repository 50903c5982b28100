"""ISO 11783-10 TaskData prescriptions (``TASKDATA.XML`` and its ``GRD*.bin`` grids), read with the ``isoxml``
package (Josephinum Research, PyPI), into a :class:`~vinecli.gis.prescription.RateMap`; docs/dose.md.

The first task (TSK) that carries a prescription is used: its grid (GRD) when it has one, else its treatment
zones (TZN) with polygons. Rates are the process data variables (PDV) of DDI 1, *Setpoint Volume Per Area
Application Rate*, in mm³/m² at a resolution of 0.01 (ISO 11783-11); 1 mm³/m² = 0.01 L/ha. Other DDIs (mass or
count per area, ...) are refused as units vinecli cannot spray.

* Grid type 1: one byte per cell, the code of the treatment zone whose PDV gives the rate;
* grid type 2: one 32-bit integer per cell (per PDV of the grid's treatment zone, GRD attribute J), the rate;
* cells are ``GridCellNorthSize`` x ``GridCellEastSize`` degrees (WGS84) from the grid's south-west corner
  (``GridMinimumNorthPosition``, ``GridMinimumEastPosition``), stored row by row from the south, west to east
  (as ADAPT's ISOv4Plugin reads them);
* the task's ``DefaultTreatmentZoneCode`` gives the rate where the map prescribes nothing.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from vinecli.errors import InputError
from vinecli.gis.georef import Georef
from vinecli.gis.rate_map import MAX_RATE_LPHA, MIN_RATE_LPHA, RateMap, check_rate

__all__ = ["DDI_SETPOINT_VOLUME_PER_AREA", "LPHA_PER_MM3_M2", "prescription_task", "read_isoxml"]

#: ISO 11783-11 DDI 1: Setpoint Volume Per Area Application Rate, mm³/m², resolution 0.01
DDI_SETPOINT_VOLUME_PER_AREA = 1
#: L/ha per mm³/m² (1e-6 L per m², 1e4 m² per ha)
LPHA_PER_MM3_M2 = 0.01


def _load(path: Path) -> tuple[Any, dict[str, Any]]:
    from isoxml.util.isoxml_io import isoxml_from_path

    folder = path if path.is_dir() else path.parent
    if not (folder / "TASKDATA.XML").is_file():
        raise InputError("no TASKDATA.XML here", path=path)
    try:
        from lxml import etree

        etree.parse(str(folder / "TASKDATA.XML"))  # well-formed (isoxml's parser would read a truncated file)
        return isoxml_from_path(folder)
    except Exception as exc:  # noqa: BLE001 - xsdata/lxml parse errors, isoxml's asserts on references
        msg = " ".join(str(exc).split()) or type(exc).__name__
        raise InputError(f"broken ISO-XML TaskData: {msg[:200]}", path=folder / "TASKDATA.XML") from None


def _ddi(pdv: Any) -> int:
    return int.from_bytes(pdv.process_data_ddi, "big")


def _zone_rate(tzn: Any, path: Path) -> float | None:
    """L/ha of a treatment zone's DDI 1 PDV; None without PDVs; InputError for other units."""
    from isoxml.models.ddi_entities import DDEntity

    pdvs = list(tzn.process_data_variables)
    if not pdvs:
        return None
    for p in pdvs:
        if _ddi(p) == DDI_SETPOINT_VOLUME_PER_AREA:
            raw = float(p.process_data_value) * DDEntity.from_id(DDI_SETPOINT_VOLUME_PER_AREA).bit_resolution
            return check_rate(raw * LPHA_PER_MM3_M2, f"treatment zone {tzn.code}", path)
    d = _ddi(pdvs[0])
    try:
        e = DDEntity.from_id(d)
        what = f"{e.name}, {e.unit}"
    except KeyError:
        what = "not in the data dictionary"
    raise InputError(f"treatment zone {tzn.code}: unknown units: DDI {d} ({what}); vinecli sprays volume per area "
                     "(DDI 1, mm³/m²)", path=path)


def _grid(task: Any, grid: Any, bins: dict[str, Any], tzn_rates: dict[int, float | None], path: Path
          ) -> np.ndarray:
    """The grid's rates (rows from the south), L/ha, NaN where none."""
    from isoxml.converter.np_grid import to_numpy_array
    from isoxml.models.ddi_entities import DDEntity

    data = bins.get(grid.filename)
    if not isinstance(data, bytes):
        raise InputError(f"grid {grid.filename}: its binary file {grid.filename}.bin is missing", path=path)
    kind = str(grid.type.value)
    shape = f"{grid.maximum_row} x {grid.maximum_column} cells of type {kind}"
    if kind == "1":
        try:
            codes = to_numpy_array(data, grid)
        except ValueError:
            raise InputError(f"grid {grid.filename}: {len(data)} bytes for {shape}", path=path) from None
        lut = np.full(256, np.nan)
        for code, rate in tzn_rates.items():
            lut[code] = np.nan if rate is None else rate
        return lut[codes]
    tzn = next((z for z in task.treatment_zones if z.code == grid.treatment_zone_code), None)
    if tzn is None:
        raise InputError(f"grid {grid.filename} (type 2): its treatment zone {grid.treatment_zone_code} is missing",
                         path=path)
    ddis = [_ddi(p) for p in tzn.process_data_variables]
    if DDI_SETPOINT_VOLUME_PER_AREA not in ddis:
        _zone_rate(tzn, path)  # names the units it has
        raise InputError(f"grid {grid.filename}: no process data variables", path=path)
    try:
        arr = to_numpy_array(data, grid, ddi_list=[DDEntity.from_id(d) for d in ddis], scale=True)
    except (ValueError, KeyError):
        raise InputError(f"grid {grid.filename}: {len(data)} bytes for {shape} with {len(ddis)} values each",
                         path=path) from None
    vals = np.asarray(arr, dtype=np.float64).reshape(int(grid.maximum_row), int(grid.maximum_column), -1)
    rates = vals[:, :, ddis.index(DDI_SETPOINT_VOLUME_PER_AREA)] * LPHA_PER_MM3_M2
    finite = rates[np.isfinite(rates)]
    bad = finite[(finite < 0) | (finite > MAX_RATE_LPHA) | ((finite > 0) & (finite < MIN_RATE_LPHA))]
    if bad.size:
        check_rate(float(bad[0]), f"grid {grid.filename} ({bad.size} cells)", path)
    return rates


def _tasks(task_data: Any) -> list[Any]:
    return [t for t in task_data.tasks if t.grids or any(z.polygons for z in t.treatment_zones)]


def prescription_task(task_data: Any) -> Any:
    """The task of ``task_data`` whose prescription vinecli reads: the first with a grid or zone polygons."""
    return _tasks(task_data)[0]


def read_isoxml(path: Path, georef: Georef) -> RateMap:
    """The prescription of the TaskData at ``path`` (``TASKDATA.XML`` or its folder); see the module docstring."""
    from rasterio.transform import Affine

    task_data, refs = _load(path)
    tasks = _tasks(task_data)
    if not tasks:
        raise InputError("the TaskData has no task with a grid or treatment-zone polygons", path=path)
    task = tasks[0]
    notes = [f"task {task.id} {task.designator or ''}".strip() + (f" (of {len(tasks)})" if len(tasks) > 1 else "")]
    rates = {int(z.code): _zone_rate(z, path) for z in task.treatment_zones}
    default = rates.get(task.default_treatment_zone_code) if task.default_treatment_zone_code is not None else None
    if task.grids:
        g = task.grids[0]
        grid = _grid(task, g, refs, rates, path)
        south, west = float(g.minimum_north_position), float(g.minimum_east_position)
        dlat, dlon = float(g.cell_north_size), float(g.cell_east_size)
        to_pixel = ~Affine(dlon, 0.0, west, 0.0, dlat, south)  # row 0 south
        notes.append(f"grid type {g.type.value}, {g.maximum_column} x {g.maximum_row} cells")
        return RateMap(path, f"isoxml-grid{g.type.value}", georef, default, grid=grid, to_pixel=to_pixel,
                       grid_crs="EPSG:4326", notes=notes)
    zones = _zones(task, rates, georef, path)
    notes.append(f"{len(zones)} treatment-zone polygons")
    return RateMap(path, "isoxml-zones", georef, default, zones=zones, notes=notes)


def _zones(task: Any, rates: dict[int, float | None], georef: Georef, path: Path
           ) -> list[tuple[list[tuple[float, float]], float, str, list[list[tuple[float, float]]]]]:
    from isoxml.converter.shapely_geom import ShapelyConverterV3, ShapelyConverterV4

    conv = ShapelyConverterV4() if type(task).__module__.split(".")[-2] == "v4" else ShapelyConverterV3()
    out = []
    for z in task.treatment_zones:
        rate = rates.get(int(z.code))
        for pln in z.polygons:
            try:
                poly = conv.to_shapely_polygon(pln)
            except (ValueError, NotImplementedError) as exc:
                raise InputError(f"treatment zone {z.code}: bad polygon ({exc})", path=path) from None
            if rate is None:
                raise InputError(f"treatment zone {z.code}: a polygon without a rate (no PDV)", path=path)
            ring = [(float(x), float(y)) for x, y in list(poly.exterior.coords)[:-1]]
            holes = [georef.from_crs([(float(x), float(y)) for x, y in list(i.coords)[:-1]], "EPSG:4326")
                     for i in poly.interiors]
            out.append((georef.from_crs(ring, "EPSG:4326"), rate, z.designator or str(z.code), holes))
    return out
