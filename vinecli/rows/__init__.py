"""Vine rows: detection on a DSM or height grid, the spray plan over them, and spray rates.

* :mod:`vinecli.rows.detect` - THE row detector (``detect_rows_grid``), row spacing.
* :mod:`vinecli.rows.spectrum`, :mod:`vinecli.rows.comb` - its direction/spacing spectrum and the comb model.
* :mod:`vinecli.rows.source` - rows from a DSM (with the CRS frame) or a world's height grid; GeoJSON.
* :mod:`vinecli.rows.plan` - THE spray plan (legs, turns, sorties), with :mod:`vinecli.rows.lanes`,
  :mod:`vinecli.rows.passes`, :mod:`vinecli.rows.stretches` and :mod:`vinecli.rows.no_spray`.
* :mod:`vinecli.rows.spray_rate` - flow for an application rate (L/ha) over a track width.
* :mod:`vinecli.rows.geometry` - polyline geometry.

Plain geometry: no PyBullet, no world loading, no autopilot. May import the ground floor (constants, errors, frames, geo, inputs, outputs, types, ...), :mod:`vinecli.specs` and floor 2
(:mod:`vinecli.terrain`, :mod:`vinecli.spray` for the effective swath).
"""
