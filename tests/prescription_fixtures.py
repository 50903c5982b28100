"""Prescription maps over the known-truth vineyard (tests/canopy_fixtures.py), in CRSs other than its DSM's:
three zones by latitude band (GeoPackage in Web Mercator, Shapefile and GeoJSON in WGS84), a rate GeoTIFF in
Web Mercator, and real ISO 11783-10 TaskData written with the ``isoxml`` package (treatment zones, grids of
type 1 and 2). Rates are known per local y band: south of y = -5 m 150 L/ha, to y = 5 m 200, north 250."""

from __future__ import annotations

from decimal import Decimal
from pathlib import Path

import numpy as np

from vinecli.gis.georef import Georef

ZONES = ((-16.0, -5.0, 150.0), (-5.0, 5.0, 200.0), (5.0, 16.0, 250.0))  # local y0, y1, rate L/ha
X_SPAN = (-8.0, 8.0)


def zone_rate(y: float) -> float:
    return next(r for a, b, r in ZONES if a <= y < b)


def _rings(georef: Georef, crs: str) -> list[list[tuple[float, float]]]:
    x0, x1 = X_SPAN
    return [georef.to_crs([(x0, a), (x1, a), (x1, b), (x0, b)], crs) for a, b, _ in ZONES]


def write_zones(path: Path, georef: Georef, crs: str, *, column: str = "rate", rates: list | None = None,
                driver: str | None = None) -> Path:
    """The three zones as polygons in ``crs`` with ``column`` (default the true rates)."""
    import pyogrio.raw
    from shapely.geometry import Polygon

    vals = rates if rates is not None else [r for *_, r in ZONES]
    geoms = np.array([Polygon(r).wkb for r in _rings(georef, crs)], dtype=object)
    col = np.array(vals, dtype=object if any(isinstance(v, str) for v in vals) else np.float64)
    names = np.array(["south", "middle", "north"], dtype=object)
    pyogrio.raw.write(path, geoms, [col, names], [column, "name"], driver=driver, crs=crs, geometry_type="Polygon")
    return path


def write_rate_raster(path: Path, georef: Georef, crs: str = "EPSG:3857", cell: float = 1.0,
                      scale: float = 1.0) -> Path:
    """A rate GeoTIFF in ``crs`` whose cells carry the zone rate of their centre (x ``scale``)."""
    import rasterio
    from rasterio.transform import from_origin

    corners = georef.to_crs([(X_SPAN[0], -16.0), (X_SPAN[1], 16.0)], crs)
    (ex0, ny0), (ex1, ny1) = corners
    nx, ny = int(np.ceil((ex1 - ex0) / cell)), int(np.ceil((ny1 - ny0) / cell))
    z = np.zeros((ny, nx), dtype=np.float32)
    for j in range(ny):
        for i in range(nx):
            yc = ny1 - (j + 0.5) * cell
            _, yl = georef.from_crs([(ex0 + (i + 0.5) * cell, yc)], crs)[0]
            z[j, i] = zone_rate(min(max(yl, -16.0), 15.999)) * scale
    with rasterio.open(path, "w", driver="GTiff", width=nx, height=ny, count=1, dtype="float32", crs=crs,
                       transform=from_origin(ex0, ny1, cell, cell), nodata=-1.0) as ds:
        ds.write(z, 1)
    return path


def _iso(kind: str, georef: Georef, *, ddi: int = 1, rate_scale: float = 1.0):
    import isoxml.models.base.v4 as iso
    from isoxml.converter.shapely_geom import ShapelyConverterV4
    from shapely.geometry import Polygon

    def pdv(rate_lpha: float):
        raw = int(round(rate_lpha * rate_scale / 0.01 / 0.01))  # L/ha -> mm³/m² -> units of 0.01
        return iso.ProcessDataVariable(process_data_ddi=ddi.to_bytes(2, "big"), process_data_value=raw)

    zones = [iso.TreatmentZone(code=k + 1, designator=f"zone {k + 1}", process_data_variables=[pdv(r)])
             for k, (*_, r) in enumerate(ZONES)]
    task = iso.Task(id="TSK1", designator="spray", status=iso.TaskStatus.Planned)
    bins: dict[str, bytes] = {}
    if kind == "zones":
        conv = ShapelyConverterV4()
        for z, ring in zip(zones, _rings(georef, "EPSG:4326"), strict=True):
            z.polygons = [conv.to_iso_polygon(Polygon(ring), iso.PolygonType.TreatmentZone)]
        task.treatment_zones = zones
    else:
        (w, s), (e, n) = georef.to_lonlat([(X_SPAN[0], -16.0), (X_SPAN[1], 16.0)])
        ncol, nrow = 4, 16
        dlon, dlat = (e - w) / ncol, (n - s) / nrow
        lat_c = s + (np.arange(nrow) + 0.5) * dlat
        y_c = [georef.from_lonlat([(0.5 * (w + e), la)])[0][1] for la in lat_c]
        codes = np.array([[next(k + 1 for k, (a, b, _) in enumerate(ZONES) if a <= min(max(y, -16), 15.99) < b)] * ncol
                          for y in y_c], dtype=np.uint8)  # row 0 south
        grid = iso.Grid(minimum_north_position=Decimal(f"{s:.9f}"), minimum_east_position=Decimal(f"{w:.9f}"),
                        cell_north_size=dlat, cell_east_size=dlon, maximum_column=ncol, maximum_row=nrow,
                        filename="GRD00001", type=iso.GridType.GridType1 if kind == "grid1" else iso.GridType.GridType2)
        if kind == "grid1":
            bins["GRD00001"] = codes.tobytes()
            task.treatment_zones = zones
        else:
            raw = np.array([[int(round(ZONES[c - 1][2] * rate_scale / 0.01 / 0.01)) for c in r] for r in codes],
                           dtype=np.int32)
            bins["GRD00001"] = raw.tobytes()
            template = iso.TreatmentZone(code=9, designator="rates", process_data_variables=[pdv(0.0)])
            task.treatment_zones = [template]
            grid.treatment_zone_code = 9
        grid.filelength = len(bins["GRD00001"])
        task.grids = [grid]
    td = iso.Iso11783TaskData(management_software_manufacturer="vinecli tests", management_software_version="1",
                              data_transfer_origin=iso.Iso11783TaskDataDataTransferOrigin.FMIS, tasks=[task])
    return td, bins


def write_taskdata(folder: Path, georef: Georef, kind: str, **kw: object) -> Path:
    """Real TaskData (``TASKDATA.XML`` + ``GRD00001.bin``) in ``folder``: ``kind`` zones | grid1 | grid2."""
    from isoxml.util.isoxml_io import isoxml_to_dir

    folder.mkdir(parents=True, exist_ok=True)
    td, bins = _iso(kind, georef, **kw)  # type: ignore[arg-type]
    isoxml_to_dir(folder, td, bins)
    return folder / "TASKDATA.XML"
