"""Write the sample field's prescription maps (pipelines/maps/, docs/dose.md): what a grower would bring.

* ``sample-zones.gpkg``: three vigour zones (layer ``zones``, column ``rate_lpha``, L/ha) in Web Mercator
  (EPSG:3857; the DSM is UTM 16N): low vigour in the south (14 L/ha), medium across the middle (22 L/ha), high in
  the north (30 L/ha), split along slanted lines across the rows;
* ``sample-grid/TASKDATA.XML`` + ``GRD00001.bin``: an ISO 11783-10 TaskData (written with the ``isoxml``
  package) with one task whose grid (type 2, cells of ~4 m x 4 m in WGS84 degrees) carries the rate of each cell
  as DDI 1 (setpoint volume per area, mm³/m²): a vigour gradient from 12 L/ha (south-west) to 30 L/ha
  (north-east) in 2 L/ha steps.

    .venv/bin/python scripts/sample_prescriptions.py WORLD_DIR [--out pipelines/maps]

WORLD_DIR: worlds/vineyard-sample.yaml built (``vinecli world build``); its georeference places the maps.
"""

from __future__ import annotations

import argparse
from decimal import Decimal
from pathlib import Path

import numpy as np

from vinecli.gis.georef import world_dir_georef

ZONES = (("low vigour", 14.0), ("medium vigour", 22.0), ("high vigour", 30.0))
#: zone boundaries: y = y0 + slope x (world ENU m)
CUTS = ((-12.0, 0.4), (10.0, -0.3))
FIELD = (-12.0, 12.0, -36.0, 36.0)  # x0, x1, y0, y1: beyond the rows


def zone_polygons() -> list[list[tuple[float, float]]]:
    """The three zones as rings in world ENU m (south to north)."""
    x0, x1, y0, y1 = FIELD
    (a, sa), (b, sb) = CUTS
    south = [(x0, y0), (x1, y0), (x1, a + sa * x1), (x0, a + sa * x0)]
    middle = [(x0, a + sa * x0), (x1, a + sa * x1), (x1, b + sb * x1), (x0, b + sb * x0)]
    north = [(x0, b + sb * x0), (x1, b + sb * x1), (x1, y1), (x0, y1)]
    return [south, middle, north]


def write_zones(path: Path, georef: object) -> Path:
    import pyogrio.raw
    from shapely.geometry import Polygon

    rings = [georef.to_crs(r, "EPSG:3857") for r in zone_polygons()]  # type: ignore[attr-defined]
    geoms = np.array([Polygon(r).wkb for r in rings], dtype=object)
    pyogrio.raw.write(path, geoms, [np.array([r for _, r in ZONES]), np.array([n for n, _ in ZONES], dtype=object)],
                      ["rate_lpha", "name"], driver="GPKG", layer="zones", crs="EPSG:3857", geometry_type="Polygon")
    return path


def write_grid(folder: Path, georef: object, cell_m: float = 4.0) -> Path:
    import isoxml.models.base.v4 as iso
    from isoxml.util.isoxml_io import isoxml_to_dir

    x0, x1, y0, y1 = FIELD
    (w, s), (e, n) = georef.to_lonlat([(x0, y0), (x1, y1)])  # type: ignore[attr-defined]
    ncol, nrow = int(round((x1 - x0) / cell_m)), int(round((y1 - y0) / cell_m))
    dlon, dlat = (e - w) / ncol, (n - s) / nrow
    u = (np.arange(ncol) + 0.5) / ncol
    v = (np.arange(nrow) + 0.5) / nrow
    rates = 12.0 + 2.0 * np.round(9.0 * (0.3 * u[None, :] + 0.7 * v[:, None]))  # row 0 south, 12-30 L/ha
    raw = np.round(rates / 0.01 / 0.01).astype(np.int32)  # L/ha -> mm³/m² -> units of 0.01 (DDI 1)
    pdv = iso.ProcessDataVariable(process_data_ddi=(1).to_bytes(2, "big"), process_data_value=0)
    grid = iso.Grid(minimum_north_position=Decimal(f"{s:.9f}"), minimum_east_position=Decimal(f"{w:.9f}"),
                    cell_north_size=dlat, cell_east_size=dlon, maximum_column=ncol, maximum_row=nrow,
                    filename="GRD00001", filelength=raw.nbytes, type=iso.GridType.GridType2, treatment_zone_code=1)
    task = iso.Task(id="TSK1", designator="sample vineyard, vigour prescription", status=iso.TaskStatus.Planned,
                    treatment_zones=[iso.TreatmentZone(code=1, designator="rates", process_data_variables=[pdv])],
                    grids=[grid])
    td = iso.Iso11783TaskData(management_software_manufacturer="vinecli", management_software_version="1",
                              data_transfer_origin=iso.Iso11783TaskDataDataTransferOrigin.FMIS, tasks=[task])
    folder.mkdir(parents=True, exist_ok=True)
    isoxml_to_dir(folder, td, {"GRD00001": raw.tobytes()})
    return folder / "TASKDATA.XML"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("world", type=Path)
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent.parent / "pipelines" / "maps")
    a = ap.parse_args()
    georef = world_dir_georef(a.world)
    a.out.mkdir(parents=True, exist_ok=True)
    print(write_zones(a.out / "sample-zones.gpkg", georef))
    print(write_grid(a.out / "sample-grid", georef))


if __name__ == "__main__":
    main()
