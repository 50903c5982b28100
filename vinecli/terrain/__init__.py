"""Terrain: DSM rasters -> heightmaps and mesh tiles; point clouds -> meshes.

Modules are imported on demand (rasterio, pydelatin, open3d are heavy); see
:mod:`vinecli.terrain.heightmap`, :mod:`vinecli.terrain.tiles`, :mod:`vinecli.terrain.info`
and :mod:`vinecli.terrain.pointcloud`.
"""
