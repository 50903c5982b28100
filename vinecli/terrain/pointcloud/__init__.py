"""Point clouds (LAS/LAZ, PLY, PCD, XYZ) -> terrain: read, put into metres, clean, mesh, grid into a DSM.

* :mod:`~vinecli.terrain.pointcloud.reconstruct`: ``vinecli terrain reconstruct``, the pipeline.
* :mod:`~vinecli.terrain.pointcloud.readers`: the file readers; :mod:`~vinecli.terrain.pointcloud.units`:
  feet and degrees to metres; :mod:`~vinecli.terrain.pointcloud.prep`: cleaning and spacing.
* :mod:`~vinecli.terrain.pointcloud.mesh`: ball pivoting and 2.5-D Delaunay (Open3D through
  :mod:`~vinecli.terrain.pointcloud.o3d`); :mod:`~vinecli.terrain.pointcloud.dsm`: a cloud gridded to a DSM.
* :mod:`~vinecli.terrain.pointcloud.cloud_info`: ``vinecli terrain info CLOUD``.

May import what :mod:`vinecli.terrain` may (the ground floor) and the rest of :mod:`vinecli.terrain`.
Modules are imported on use (laspy, Open3D and scipy are heavy).
"""
