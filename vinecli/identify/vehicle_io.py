"""Base vehicles in, fitted vehicles and result directories out (``vehicle fit`` and ``vehicle replay``)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import yaml

from vinecli.errors import SpecError
from vinecli.flightlog.read import read_flight_log
from vinecli.identify.base_vehicle import load_base
from vinecli.identify.fit_result import FitResult
from vinecli.identify.replay import ERROR_KEYS, ReplayResult, replay_log
from vinecli.outputs import Manifest, atomic_output_dir, jsonable, write_json
from vinecli.specs import YAML_DUMPER
from vinecli.vehicle import load_vehicle

__all__ = ["replay_report", "replay_summary", "replay_vehicle", "write_outputs"]

VEHICLE_YAML, FIT_JSON, REPLAY_JSON, FIT_HTML, REPLAY_HTML = "vehicle.yaml", "fit.json", "replay.json", "fit.html", "replay.html"


def replay_summary(rep: ReplayResult) -> dict[str, Any]:
    """The replay's headline errors for a vehicle's provenance: the vehicle's and each baseline's."""
    def pick(e: dict[str, Any]) -> dict[str, float | None]:
        return {k: (None if e.get(k) is None or e[k] != e[k] else float(e[k])) for k in ERROR_KEYS}

    return {"replay": pick(rep.errors["vehicle"]),
            "replay_baselines": {k: pick(v) for k, v in rep.errors.items() if k != "vehicle"}}


def replay_report(rep: ReplayResult, log_summary: dict[str, Any], vehicle: str, base: str | None) -> dict[str, Any]:
    """``replay.json``: the vehicle's errors at the top level, the baselines' beside them."""
    e = rep.errors["vehicle"]
    return {"schema": "vinecli.replay/1", "log": log_summary, "vehicle": vehicle, "base": base,
            **{k: e.get(k) for k in ERROR_KEYS}, "vehicle_errors": e,
            "baselines": {k: v for k, v in rep.errors.items() if k != "vehicle"},
            "windows": len(rep.windows), "window_s": (rep.windows[0][1] - rep.windows[0][0]) if rep.windows else None,
            "span_s": list(rep.span_s), "imu_offset_xy_mps2": list(rep.imu_offset_xy),
            "integration": "rigid body, semi-implicit Euler at 250 Hz, vinecli.flight laws (MotorBank, "
                           "aero.wind_drag, Battery), still air, no PyBullet",
            "notes": list(rep.notes)}


def _yaml_text(doc: dict[str, Any], header: list[str]) -> str:
    body = yaml.dump(jsonable(doc), Dumper=YAML_DUMPER, sort_keys=False, allow_unicode=True, width=110)
    return "".join(f"# {line}\n" for line in header) + body


def write_outputs(r: FitResult, out: Path, *, overwrite: bool, log_path: Path) -> Path:
    """Write the fit's directory atomically: vehicle.yaml, fit.json, replay.json, fit.html (+ figures)."""
    from vinecli.identify.page import fit_page, replay_page

    man = Manifest("vehicle fit", parameters={"log": str(log_path), "base": r.base.ref}, inputs=[log_path])
    header = [f"Fitted by vinecli vehicle fit to {log_path.name} ({r.log.info.firmware}).",
              "Every value here came from the log; the rest is the base vehicle's (fit.json says what and why)."]
    with atomic_output_dir(out, man, overwrite=overwrite) as tmp:
        (tmp / VEHICLE_YAML).write_text(_yaml_text(r.vehicle_yaml, header), encoding="utf-8")
        write_json(tmp / FIT_JSON, r.report)
        if r.replay is not None:
            write_json(tmp / REPLAY_JSON, replay_report(r.replay, r.log.summary(), r.vehicle_yaml["name"], r.base.ref))
        (tmp / FIT_HTML).write_text(fit_page(r), encoding="utf-8")
        if r.replay is not None:
            (tmp / REPLAY_HTML).write_text(replay_page(r.replay, r.log, r.vehicle_yaml["name"], r.base.ref),
                                           encoding="utf-8")
        # the fitted file must load as a vehicle from its own directory
        load_vehicle(tmp / VEHICLE_YAML)
    return out


def replay_vehicle(log_path: str | Path, vehicle: str | Path, out: str | Path, *, base: str | None = None,
                   window_s: float = 2.0, overwrite: bool = False) -> dict[str, Any]:
    """``vinecli vehicle replay``: replay ``log_path`` through ``vehicle`` and write replay.json and
    replay.html to ``out``; ``base`` defaults to the fitted vehicle's base (its provenance), else x500."""
    from vinecli.identify.page import replay_page
    from vinecli.outputs import check_output_target

    if not 0.2 <= window_s <= 60.0:
        raise SpecError(f"--window {window_s} s: use 0.2-60 s")
    spec = load_vehicle(vehicle)  # the vehicle and the base it names are inputs, known before the check
    base_ref = base or (spec.provenance.base if spec.provenance is not None else "x500")
    base_spec = load_base(base_ref).spec
    check_output_target(Path(out), overwrite=overwrite, inputs=[log_path], kind="vehicle replay")
    log = read_flight_log(log_path)
    for v in (spec, base_spec):
        if v.n_rotors != log.config.n_motors:
            raise SpecError(f"vehicle {v.name!r} has {v.n_rotors} rotors, the log flies {log.config.n_motors} motors",
                            path=str(vehicle))
    rep = replay_log(log, spec, base_spec, window_s=window_s)
    report = replay_report(rep, log.summary(), spec.name, base_ref)
    man = Manifest("vehicle replay", parameters={"log": str(log_path), "vehicle": str(vehicle), "base": base_ref,
                                                  "window_s": window_s}, inputs=[Path(log_path)])
    with atomic_output_dir(Path(out), man, overwrite=overwrite) as tmp:
        write_json(tmp / REPLAY_JSON, report)
        (tmp / REPLAY_HTML).write_text(replay_page(rep, log, spec.name, base_ref), encoding="utf-8")
    return json.loads(json.dumps(jsonable(report)))
