"""The field map of a run (Leaflet, offline): terrain, rows, the flown path, the deposition and canopy deposit, the
fence and no-spray zones, events and failed checks, in WGS84 through the world's georeference.

* :mod:`~vinecli.report.fieldmap.run_map` - :data:`~vinecli.report.fieldmap.run_map.LAYERS` and ``run_map``;
* :mod:`~vinecli.report.fieldmap.map_model` - layers, rasters, legends -> the browser's data;
* :mod:`~vinecli.report.fieldmap.map_page` - the HTML: Leaflet (vendored, BSD-2-Clause) and the map script inlined;
* the layers: :mod:`~vinecli.report.fieldmap.vector_layers`, :mod:`~vinecli.report.fieldmap.raster_layers`,
  :mod:`~vinecli.report.fieldmap.mark_layers`.

May import the floors below the report (gis, runs, spray, the frames) and the report's loader, text and figure
scales; never the report's assembly (``assemble``, ``html``), which imports it.
"""
