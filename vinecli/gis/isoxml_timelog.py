"""An ISO 11783-10 TimeLog of an as-applied log, written with the ``isoxml`` package next to the grower's TaskData.

The folder gets the input ``TASKDATA.XML`` (and its grids) with, on the task that carried the prescription, a
``TIM`` (effective, the log's start and stop), a ``TLG`` reference ``TLG00001`` and a device ``DVC-1`` ("vinecli
simulated sprayer", one device element ``DET-1``); ``TLG00001.XML`` the binary log's header and ``TLG00001.BIN``
its records (ISO 11783-10 Annex D, little-endian): per record the time (uint32 ms since midnight, uint16 days
since 1980-01-01), the position north and east (int32, 1e-7 degree WGS84; status fixed in the header: 8, simulated)
and the data log values present (uint8 count, then uint8 DLV index and int32 value each):

* DLV 0: DDI 1, *Setpoint Volume Per Area Application Rate*, mm³/m² (1 mm³/m² = 0.01 L/ha): the prescription;
* DLV 1: DDI 2, *Actual Volume Per Area Application Rate*, mm³/m²: the rate the pump delivered (left out where the
  vehicle hovered or turned).

One record per line of the run's 1 Hz log (:mod:`vinecli.missions.as_applied`).
"""

from __future__ import annotations

import shutil
import struct
from collections.abc import Sequence
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

from vinecli.gis.georef import Georef
from vinecli.gis.isoxml_read import LPHA_PER_MM3_M2, prescription_task

__all__ = ["TIMELOG", "TIMELOG_DDIS", "write_timelog"]

TIMELOG = "TLG00001"
#: DDIs of the logged values, in DLV order: setpoint and actual volume per area, mm³/m²
TIMELOG_DDIS = (1, 2)
_EPOCH = datetime(1980, 1, 1, tzinfo=UTC)


def _record(t: datetime, lat: float, lon: float, values: Sequence[tuple[int, int]]) -> bytes:
    day = t - _EPOCH
    ms = int(round((day.seconds + day.microseconds * 1e-6) * 1000.0))
    out = struct.pack("<IHii", ms, day.days, int(round(lat * 1e7)), int(round(lon * 1e7)))
    out += struct.pack("<B", len(values))
    for i, v in values:
        out += struct.pack("<Bi", i, v)
    return out


def write_timelog(folder: Path, taskdata: Path, log: Sequence[dict[str, Any]], georef: Georef,
                  start: datetime | None = None) -> Path:
    """Write the TimeLog of ``log`` (the 1 Hz as-applied log: ``t_s``, ``x``, ``y`` world m, ``prescribed_lpha``,
    ``pump_lpha``) into ``folder`` beside a copy of ``taskdata`` (module docstring); ``start``: the log's time 0
    (default now, UTC)."""
    import isoxml.models.base.v3 as iso3
    import isoxml.models.base.v4 as iso4
    from isoxml.util.isoxml_io import isoxml_from_path, isoxml_to_dir
    from xsdata.formats.dataclass.serializers import XmlSerializer
    from xsdata.formats.dataclass.serializers.config import SerializerConfig
    from xsdata.models.datatype import XmlDateTime

    src = taskdata if taskdata.is_dir() else taskdata.parent
    task_data, refs = isoxml_from_path(src)
    iso: Any = iso4 if ".v4" in type(task_data).__module__ else iso3
    folder.mkdir(parents=True, exist_ok=True)
    t0 = (start or datetime.now(UTC)).replace(microsecond=0)
    lonlat = georef.to_lonlat([(float(p["x"]), float(p["y"])) for p in log]) if log else []
    blob = b""
    for p, (lon, lat) in zip(log, lonlat, strict=True):
        vals = [(0, int(round(float(p["prescribed_lpha"]) / LPHA_PER_MM3_M2)))]
        if isinstance(p.get("pump_lpha"), (int, float)):
            vals.append((1, int(round(float(p["pump_lpha"]) / LPHA_PER_MM3_M2))))
        blob += _record(t0 + timedelta(seconds=float(p["t_s"])), lat, lon, vals)
    stop = t0 + timedelta(seconds=float(log[-1]["t_s"]) if log else 0.0)
    device = iso.Device(id="DVC-1", designator="vinecli simulated sprayer", client_name=bytes(8),
                        structure_label=b"VINECLI".hex().upper()[:14], localization_label=bytes(7).hex().upper(),
                        elements=[iso.DeviceElement(id="DET-1", object_id=1, type=iso.DeviceElementType.Device,
                                                    designator="sprayer", number=0, parent_object_id=0)])
    task_data.devices.append(device)
    task = prescription_task(task_data)
    task.times.append(iso.Time(start=XmlDateTime.from_datetime(t0), stop=XmlDateTime.from_datetime(stop),
                               type=iso.TimeType.Effective))
    task.time_logs.append(iso.TimeLog(filename=TIMELOG, filelength=len(blob), type=iso.TimeLogType.BinaryTimelogFileType1))
    header = iso.Time(start="", type=iso.TimeType.Effective,
                      positions=[iso.Position(north="", east="", status=iso.PositionStatus.SimulateMode)],
                      data_log_values=[iso.DataLogValue(process_data_ddi=d.to_bytes(2, "big"), process_data_value="",
                                                        device_element_id_ref="DET-1") for d in TIMELOG_DDIS])
    isoxml_to_dir(folder, task_data, {k: v for k, v in refs.items() if isinstance(v, bytes) and not k.startswith("TLG")})
    for f in src.iterdir():  # files isoxml does not carry (attached files): kept as they were
        if f.is_file() and not (folder / f.name).exists() and f.suffix.lower() != ".xml":
            shutil.copy2(f, folder / f.name)
    xml = XmlSerializer(config=SerializerConfig(indent="  ")).render(header)
    (folder / f"{TIMELOG}.XML").write_text(xml, encoding="utf-8")
    (folder / f"{TIMELOG}.BIN").write_bytes(blob)
    return folder
