"""Point-cloud readers: LAS/LAZ (laspy + lazrs), PLY, PCD, XYZ text.

Every reader returns a :class:`RawCloud` in the file's own coordinates and units (feet stay
feet here); :mod:`vinecli.terrain.pointcloud.units` turns them into metres. Readers validate
what they read: a truncated or malformed file raises :class:`~vinecli.errors.TerrainError`
naming the file instead of returning garbage points (Open3D's PLY reader, for example,
silently returns zero-filled points for a truncated ASCII file, so PLY and uncompressed PCD
are parsed here with numpy; Open3D reads only LZF-compressed PCD).
"""

from __future__ import annotations

import logging
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.errors import InputError, TerrainError
from vinecli.inputs import note_input, require_regular_file

log = logging.getLogger(__name__)

#: File extensions understood by :func:`read_cloud` (lower case, with dot) -> format name.
CLOUD_EXTENSIONS: dict[str, str] = {
    ".las": "las",
    ".laz": "laz",
    ".ply": "ply",
    ".pcd": "pcd",
    ".xyz": "xyz",
    ".txt": "xyz",
    ".csv": "xyz",
}


@dataclass
class RawCloud:
    """Points exactly as stored in the file.

    ``xyz`` is (N, 3) float64 in the file's CRS units (may contain NaN/inf);
    ``classification`` is (N,) uint8 or None; ``crs`` is a :class:`pyproj.CRS` or None;
    ``vertical_unit_factor`` is metres per Z unit when the file states it separately
    (LAS GeoTIFF VerticalUnitsGeoKey), else None.
    """

    path: Path
    format: str
    xyz: np.ndarray
    classification: np.ndarray | None = None
    crs: Any = None
    vertical_unit_factor: float | None = None
    header: dict[str, Any] = field(default_factory=dict)


def read_cloud(path: str | Path) -> RawCloud:
    """Read a point cloud by extension; raise TerrainError/InputError naming the file on bad input."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in CLOUD_EXTENSIONS:
        known = ", ".join(sorted(CLOUD_EXTENSIONS))
        raise InputError(f"unknown point-cloud extension '{path.suffix or '(none)'}' (expected one of {known})",
                         path=path)
    require_regular_file(path, "file")
    note_input(path, "point cloud")
    fmt = CLOUD_EXTENSIONS[ext]
    reader = {"las": _read_las, "laz": _read_las, "ply": _read_ply, "pcd": _read_pcd, "xyz": _read_xyz}[fmt]
    cloud = reader(path)
    cloud.format = fmt
    if len(cloud.xyz) == 0:
        raise TerrainError("empty point cloud (0 points)", path=path)
    return cloud


# --------------------------------------------------------------------------- LAS / LAZ

#: EPSG linear unit codes that may appear in the LAS GeoTIFF VerticalUnitsGeoKey (4099).
_EPSG_LINEAR_UNITS = {9001: 1.0, 9002: 0.3048, 9003: 1200.0 / 3937.0, 9036: 1000.0}


def _read_las(path: Path) -> RawCloud:
    import laspy

    try:
        with laspy.open(path) as reader:
            header = reader.header
            n = int(header.point_count)
            crs = _las_crs(header, path)
            vfactor = _las_vertical_unit(header)
            info = {
                "las_version": f"{header.version.major}.{header.version.minor}",
                "point_format": int(header.point_format.id),
                "scales": [float(s) for s in header.scales],
                "offsets": [float(o) for o in header.offsets],
                "header_points": n,
            }
            if n == 0:
                return RawCloud(path, "las", np.empty((0, 3)), None, crs, vfactor, info)
            las = reader.read()
    except TerrainError:
        raise
    except Exception as exc:  # noqa: BLE001 - laspy/lazrs raise many types for corrupt files
        raise TerrainError(f"cannot read LAS/LAZ ({type(exc).__name__}: {exc})", path=path) from exc
    xyz = np.column_stack((np.asarray(las.x, dtype=np.float64), np.asarray(las.y, dtype=np.float64),
                           np.asarray(las.z, dtype=np.float64)))
    if len(xyz) != n:
        raise TerrainError(f"LAS header says {n} points but {len(xyz)} were read (truncated file?)", path=path)
    classification = np.asarray(las.classification, dtype=np.uint8)
    return RawCloud(path, "las", xyz, classification, crs, vfactor, info)


def _las_crs(header: Any, path: Path) -> Any:
    """CRS from the LAS VLRs (WKT or GeoTIFF keys), or None. A broken CRS record is only logged."""
    try:
        return header.parse_crs()
    except Exception as exc:  # noqa: BLE001 - pyproj/laspy raise various types for odd CRS records
        log.warning("%s: cannot parse the CRS record (%s); treating coordinates as metres", path, exc)
        return None


def _las_vertical_unit(header: Any) -> float | None:
    """Metres per Z unit from GeoTIFF key 4099 (VerticalUnitsGeoKey) when present."""
    for vlr in header.vlrs:
        keys = getattr(vlr, "geo_keys", None)
        if not keys:
            continue
        for key in keys:
            if key.id == 4099 and key.tiff_tag_location == 0:
                return _EPSG_LINEAR_UNITS.get(int(key.value_offset))
    return None


# --------------------------------------------------------------------------- PLY

_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
    "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}
_CLASS_NAMES = ("classification", "class", "scalar_classification", "label")


def _read_ply(path: Path) -> RawCloud:
    with open(path, "rb") as f:
        magic = f.readline()
        if magic.strip() != b"ply":
            raise TerrainError("not a PLY file (missing 'ply' magic line)", path=path)
        fmt = None
        elements: list[tuple[str, int, list[tuple[str, str | None, str]]]] = []
        while True:
            line = f.readline()
            if not line:
                raise TerrainError("PLY header has no end_header line", path=path)
            words = line.decode("ascii", "replace").split()
            if not words or words[0] in ("comment", "obj_info"):
                continue
            if words[0] == "end_header":
                break
            if words[0] == "format" and len(words) >= 2:
                fmt = words[1]
            elif words[0] == "element" and len(words) == 3:
                elements.append((words[1], _int(words[2], path), []))
            elif words[0] == "property" and elements:
                if words[1] == "list" and len(words) == 5:
                    elements[-1][2].append((words[4], words[2], words[3]))
                elif len(words) == 3 and words[1] in _PLY_TYPES:
                    elements[-1][2].append((words[2], None, _PLY_TYPES[words[1]]))
                else:
                    raise TerrainError(f"unsupported PLY property line: {' '.join(words)}", path=path)
        body_start = f.tell()
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise TerrainError(f"unsupported PLY format {fmt!r}", path=path)
    v_index = next((i for i, e in enumerate(elements) if e[0] == "vertex"), None)
    if v_index is None:
        raise TerrainError("PLY file has no vertex element", path=path)
    if fmt != "ascii" and any(p[1] is not None for e in elements[:v_index] for p in e[2]):
        raise TerrainError("binary PLY with list elements before the vertices is not supported", path=path)
    _, n, props = elements[v_index]
    names = [p[0] for p in props]
    for axis in ("x", "y", "z"):
        if axis not in names:
            raise TerrainError(f"PLY vertex element has no '{axis}' property", path=path)
    if any(p[1] is not None for p in props):
        raise TerrainError("PLY vertex element with list properties is not supported", path=path)
    info = {"ply_format": fmt, "header_points": n}
    if n == 0:
        return RawCloud(path, "ply", np.empty((0, 3)), None, None, None, info)
    if fmt == "ascii":
        rows = _ascii_rows(path, body_start, n, len(props), skip=sum(e[1] for e in elements[:v_index]))
        cols = {name: rows[:, i] for i, name in enumerate(names)}
    else:
        order = "<" if fmt == "binary_little_endian" else ">"
        dtype = np.dtype([(name, order + t) for name, _, t in props])
        skip = 0
        for _, count, eprops in elements[:v_index]:
            skip += count * np.dtype([(nm, order + t) for nm, _, t in eprops]).itemsize
        size = path.stat().st_size
        need = body_start + skip + n * dtype.itemsize
        if size < need:
            raise TerrainError(f"PLY file is truncated ({size} bytes, header needs at least {need})", path=path)
        data = np.fromfile(path, dtype=dtype, count=n, offset=body_start + skip)
        cols = {name: data[name] for name in names}
    xyz = np.column_stack([np.asarray(cols[a], dtype=np.float64) for a in ("x", "y", "z")])
    cls_name = next((nm for nm in names if nm.lower() in _CLASS_NAMES), None)
    classification = None
    if cls_name is not None:
        classification = np.asarray(cols[cls_name]).astype(np.uint8)
    return RawCloud(path, "ply", xyz, classification, None, None, info)


def _ascii_rows(path: Path, offset: int, n: int, ncols: int, *, skip: int = 0) -> np.ndarray:
    """Parse ``n`` whitespace-separated rows of ``ncols`` numbers starting at byte ``offset``."""
    with open(path, "rb") as f:
        f.seek(offset)
        text = f.read().decode("ascii", "replace")
    lines = [ln for ln in text.splitlines() if ln.strip()][skip:]
    if len(lines) < n:
        raise TerrainError(f"file is truncated: header says {n} points, found {len(lines)} data lines", path=path)
    try:
        rows = np.loadtxt(lines[:n], dtype=np.float64, ndmin=2)
    except ValueError as exc:
        raise TerrainError(f"malformed point data ({exc})", path=path) from exc
    if rows.shape != (n, ncols):
        raise TerrainError(f"malformed point data: expected {ncols} values per point, got {rows.shape[1]}", path=path)
    return rows


def _int(text: str, path: Path) -> int:
    try:
        value = int(text)
    except ValueError as exc:
        raise TerrainError(f"bad count {text!r} in header", path=path) from exc
    if value < 0:
        raise TerrainError(f"negative count {value} in header", path=path)
    return value


# --------------------------------------------------------------------------- PCD

_PCD_TYPES = {("F", 4): "f4", ("F", 8): "f8", ("I", 1): "i1", ("I", 2): "i2", ("I", 4): "i4", ("I", 8): "i8",
              ("U", 1): "u1", ("U", 2): "u2", ("U", 4): "u4", ("U", 8): "u8"}


def _read_pcd(path: Path) -> RawCloud:
    header: dict[str, list[str]] = {}
    with open(path, "rb") as f:
        while True:
            line = f.readline()
            if not line:
                raise TerrainError("PCD header has no DATA line", path=path)
            words = line.decode("ascii", "replace").split()
            if not words or words[0].startswith("#"):
                continue
            header[words[0].upper()] = words[1:]
            if words[0].upper() == "DATA":
                break
        body_start = f.tell()
    for key in ("FIELDS", "POINTS", "DATA"):
        if key not in header or not header[key]:
            raise TerrainError(f"PCD header has no {key} line", path=path)
    fields = header["FIELDS"]
    nf = len(fields)
    sizes = [_int(s, path) for s in header.get("SIZE", ["4"] * nf)]
    types = header.get("TYPE", ["F"] * nf)
    counts = [_int(c, path) for c in header.get("COUNT", ["1"] * nf)]
    if not (len(sizes) == len(types) == len(counts) == nf):
        raise TerrainError("PCD header FIELDS/SIZE/TYPE/COUNT lengths differ", path=path)
    n = _int(header["POINTS"][0], path)
    data_kind = header["DATA"][0].lower()
    for axis in ("x", "y", "z"):
        if axis not in fields:
            raise TerrainError(f"PCD file has no '{axis}' field", path=path)
    info = {"pcd_data": data_kind, "header_points": n}
    if n == 0:
        return RawCloud(path, "pcd", np.empty((0, 3)), None, None, None, info)
    # Column index of each field's first value in a flattened row.
    starts = np.cumsum([0, *counts[:-1]])
    if data_kind == "ascii":
        rows = _ascii_rows(path, body_start, n, int(sum(counts)))
        cols = {name: rows[:, int(s)] for name, s in zip(fields, starts, strict=True)}
    elif data_kind == "binary":
        try:
            dtype = np.dtype([(name, "<" + _PCD_TYPES[(t.upper(), s)], (c,) if c > 1 else ())
                              for name, t, s, c in zip(fields, types, sizes, counts, strict=True)])
        except KeyError as exc:
            raise TerrainError(f"unsupported PCD field type/size {exc}", path=path) from exc
        size = path.stat().st_size
        need = body_start + n * dtype.itemsize
        if size < need:
            raise TerrainError(f"PCD file is truncated ({size} bytes, header needs at least {need})", path=path)
        data = np.fromfile(path, dtype=dtype, count=n, offset=body_start)
        cols = {name: data[name] for name in fields}
    elif data_kind == "binary_compressed":
        return _read_pcd_open3d(path, n, info)
    else:
        raise TerrainError(f"unsupported PCD DATA kind {data_kind!r}", path=path)
    xyz = np.column_stack([np.asarray(cols[a], dtype=np.float64) for a in ("x", "y", "z")])
    cls_name = next((nm for nm in fields if nm.lower() in _CLASS_NAMES), None)
    classification = None if cls_name is None else np.asarray(cols[cls_name]).astype(np.uint8)
    return RawCloud(path, "pcd", xyz, classification, None, None, info)


def _read_pcd_open3d(path: Path, n: int, info: dict[str, Any]) -> RawCloud:
    """LZF-compressed PCD through Open3D; a point-count mismatch means a corrupt file."""
    from vinecli.terrain.pointcloud.o3d import o3d

    pcd = o3d().io.read_point_cloud(str(path), format="pcd", remove_nan_points=False, remove_infinite_points=False)
    xyz = np.asarray(pcd.points, dtype=np.float64)
    if len(xyz) != n:
        raise TerrainError(f"corrupt compressed PCD: header says {n} points, Open3D read {len(xyz)}", path=path)
    return RawCloud(path, "pcd", xyz, None, None, None, info)


# --------------------------------------------------------------------------- XYZ text

_NUMBER = re.compile(r"^[\s,;]*[-+]?(\d|\.\d|nan|inf)", re.IGNORECASE)


def _read_xyz(path: Path) -> RawCloud:
    """Text with x y z in the first three columns, separated by whitespace, commas or semicolons.

    Lines starting with ``#`` and one non-numeric header line (``x,y,z``) are skipped; extra
    columns are ignored.
    """
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise InputError(f"cannot read ({exc.strerror})", path=path) from exc
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if lines and not _NUMBER.match(lines[0]):
        lines = lines[1:]  # header line such as "x,y,z"
    if not lines:
        return RawCloud(path, "xyz", np.empty((0, 3)), None, None, None, {"header_points": 0})
    delimiter = "," if "," in lines[0] else ";" if ";" in lines[0] else None
    try:
        rows = np.loadtxt(lines, dtype=np.float64, delimiter=delimiter, usecols=(0, 1, 2), ndmin=2)
    except (ValueError, IndexError) as exc:
        raise TerrainError(f"malformed XYZ text: {exc}", path=path) from exc
    return RawCloud(path, "xyz", rows, None, None, None, {"delimiter": delimiter or "whitespace"})
