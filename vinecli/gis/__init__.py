"""GIS files in and out: rows, field boundaries, fences and no-spray zones from GeoJSON, Shapefile, GeoPackage
and KML/KMZ in any CRS, into a world's local frame; rows and plan geometry back out as RFC 7946 GeoJSON
(WGS84 longitude/latitude) and GeoPackage.

* :mod:`vinecli.gis.georef` - local metres of a DSM or a world <-> WGS84 longitude/latitude and any CRS.
* :mod:`vinecli.gis.read` - features of a GIS file, checked, in the local frame.
* :mod:`vinecli.gis.write` - features in the local frame -> GeoJSON (RFC 7946) / GeoPackage.

May import the ground floor (constants, errors, frames, geo, inputs, outputs, types, ...), :mod:`vinecli.specs`, floor 2 and :mod:`vinecli.rows`. ``read.py`` is the reader, as in
:mod:`vinecli.flightlog`.
"""
