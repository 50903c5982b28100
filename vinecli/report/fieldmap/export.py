"""``gis export`` with its map: the run's GIS layers (:func:`vinecli.runs.gis_out.export_run_gis`) and, beside
them, the same field map the report shows, as one offline page ``FILE.gpkg.html`` next to ``FILE.gpkg`` (or
``FILE.geojson.html``: a GeoPackage and a GeoJSON export of one run keep a map each; open it in a browser, the
GeoPackage in QGIS)."""

from __future__ import annotations

from pathlib import Path

__all__ = ["export_run_gis_with_map", "map_path"]


def map_path(out: Path | str) -> Path:
    """Where the map of a GIS export ``out`` goes: ``out`` with ``.html`` appended."""
    out = Path(out)
    return out.with_name(out.name + ".html")


def export_run_gis_with_map(run_dir: Path | str, out: Path | str, *, overwrite: bool = False, with_map: bool = True
                            ) -> list[Path]:
    """Write the GIS layers of ``run_dir`` to ``out`` and (``with_map``) its field map to :func:`map_path`; both
    targets are checked and the map built before anything is written. Returns the files written."""
    from vinecli.output_guard import check_output_file
    from vinecli.outputs import write_text_atomic
    from vinecli.report.fieldmap.map_page import standalone_page
    from vinecli.report.fieldmap.run_map import run_map
    from vinecli.runs.gis_out import export_run_gis

    page = None
    if with_map:
        check_output_file(map_path(out), overwrite=overwrite, inputs=[run_dir, out])
        data = run_map(run_dir)
        page = standalone_page(data, f"vinecli field map — {data.get('title', '')}")
    written = [export_run_gis(run_dir, out, overwrite=overwrite)]
    if page is not None:
        write_text_atomic(map_path(out), page)
        written.append(map_path(out))
    return written
