"""Terrain: DSM rasters -> heightmaps and mesh tiles; point clouds -> meshes; the height grid a world queries.

* :mod:`~vinecli.terrain.raster` (open and validate a DSM), :mod:`~vinecli.terrain.fill`, :mod:`~vinecli.terrain.crop`.
* :mod:`~vinecli.terrain.convert` (``vinecli terrain convert``): :mod:`~vinecli.terrain.heightmap` and
  :mod:`~vinecli.terrain.tiles` (with :mod:`~vinecli.terrain.tin`); :mod:`~vinecli.terrain.info`
  (``vinecli terrain info``).
* :mod:`vinecli.terrain.pointcloud`: point clouds (``vinecli terrain reconstruct``).
* :mod:`~vinecli.terrain.grid` (``TerrainGrid``, compiled with the kernel); :mod:`~vinecli.terrain.defaults` (the
  command line's defaults, light to import, as in :mod:`vinecli.identify`).

Measured limits and defaults: docs/terrain.md. May import the ground floor (constants, errors, frames, geo, inputs, outputs, types, ...) only. Modules are imported on demand (rasterio,
pydelatin, Open3D are heavy).
"""
