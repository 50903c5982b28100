"""``vinecli plan swath``: the effective swath of a vehicle's sprayer, its patterns and CV (library side).

Writes ``OUT/swath.json`` (the single-pass cross-track patterns of both pass directions, the CV of the
back-and-forth and racetrack overlapped patterns against the lane spacing, the effective swath and its
CV, the single-pass width, the footprint) and ``OUT/swath.png`` (three panels: the single-pass pattern,
the overlapped pattern at the effective swath, CV against spacing), atomically. Computed by
:func:`vinecli.spray.swath.swath_pattern`, the model the runs use. Metres, L/ha relative to the mean.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.errors import check_range
from vinecli.outputs import Manifest, atomic_output_dir, jsonable
from vinecli.specs.limits import MAX_DISTANCE_M, MAX_HEIGHT_M, MAX_SPEED_MPS

__all__ = ["SWATH_JSON", "SWATH_PNG", "SwathReport", "swath_figure", "swath_report"]

SWATH_JSON = "swath.json"
SWATH_PNG = "swath.png"


@dataclass(frozen=True)
class SwathReport:
    """What ``plan swath`` computed and wrote."""

    vehicle: str
    height_agl_m: float
    speed_mps: float
    crosswind_mps: float
    effective_m: float
    cv_at_effective: float
    cv_limit: float
    geometric_m: float
    single_pass_width_m: float
    footprint_radius_m: float
    pitch_deg: float
    files: list[Path]


def swath_figure(pattern: Any, vehicle: str) -> bytes:
    """PNG of the single-pass pattern, the overlapped pattern at the effective swath and CV against spacing."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from vinecli.report.figure_base import DPI, png_bytes
    from vinecli.spray.swath import overlapped

    fig = Figure(figsize=(9.0, 10.0), dpi=DPI)
    FigureCanvasAgg(fig)
    ax1, ax2, ax3 = fig.subplots(3, 1)
    fig.subplots_adjust(left=0.1, right=0.96, top=0.92, bottom=0.06, hspace=0.38)
    eff = pattern.effective_m
    scale = eff if eff == eff else 1.0  # k(y) x S: the rate relative to the asked one at that spacing
    ax1.plot(pattern.y_m, pattern.forward * scale, label="pass along +x")
    ax1.plot(pattern.y_m, pattern.backward * scale, "--", label="pass along -x")
    ax1.axvspan(-0.5 * pattern.geometric_m, 0.5 * pattern.geometric_m, color="0.9", zorder=0, label="cone swath")
    wet = np.flatnonzero(np.maximum(pattern.forward, pattern.backward) > 1e-3 * float(pattern.forward.max()))
    if wet.size:
        ax1.set_xlim(float(pattern.y_m[wet[0]]) - 1.0, float(pattern.y_m[wet[-1]]) + 1.0)
    ax1.set_xlabel("cross-track position, m (left of a pass along +x positive)")
    ax1.set_ylabel("rate / asked at the\neffective swath")
    ax1.set_title(f"single pass: geometric swath {pattern.geometric_m:.2f} m, footprint radius "
                  f"{pattern.footprint_radius_m:.2f} m, pitch {pattern.pitch_deg:.1f} deg", fontsize=10)
    ax1.legend(fontsize=8, loc="upper right")
    if eff == eff:
        y, rel = overlapped(pattern, eff)
        span = np.concatenate([y, y + y[-1] + (y[1] - y[0])])
        ax2.plot(span, np.concatenate([rel, rel]), color="#2ca02c")
        cv = float(np.std(rel))
        ax2.axhline(1.0, color="0.4", lw=0.8)
        ax2.axhspan(1.0 - cv, 1.0 + cv, color="#2ca02c", alpha=0.12, label=f"±CV ({cv:.1%})")
        for k in range(5):
            ax2.axvline(k * eff, color="0.6", lw=0.6, ls=":")
        ax2.set_ylim(0.0, max(1.5, float(rel.max()) * 1.05))
        ax2.legend(fontsize=8, loc="lower right")
    ax2.set_xlabel("cross-track position, m (two back-and-forth periods; dotted: the passes)")
    ax2.set_ylabel("deposit / mean")
    ax2.set_title(f"overlapped, back and forth, every {eff:.2f} m (the effective swath)", fontsize=10)
    ax3.plot(pattern.spacing_m, pattern.cv_back_and_forth * 100, label="back and forth")
    ax3.plot(pattern.spacing_m, pattern.cv_racetrack * 100, ":", label="racetrack")
    ax3.axhline(pattern.cv_limit * 100, color="#d62728", lw=0.8, label=f"limit {pattern.cv_limit:.0%}")
    if eff == eff:
        ax3.axvline(eff, color="#2ca02c", lw=1.0, label=f"effective swath {eff:.2f} m")
    ax3.set_ylim(0.0, min(100.0, float(np.nanmax(pattern.cv_back_and_forth)) * 100 * 1.05))
    ax3.set_xlabel("lane spacing, m")
    ax3.set_ylabel("CV of the overlapped deposit, %")
    ax3.legend(fontsize=8, loc="upper left")
    fig.suptitle(f"{vehicle}: {pattern.height_agl_m:g} m above the crop, {pattern.speed_mps:g} m/s, crosswind "
                 f"{pattern.crosswind_mps:g} m/s", fontsize=11)
    return png_bytes(fig)


#: what each option may be: (option, lowest, highest, lowest excluded)
_RANGES = {"height_agl_m": ("--height", 0.0, MAX_HEIGHT_M, True), "speed_mps": ("--speed", 0.0, MAX_SPEED_MPS, True),
           "crosswind_mps": ("--crosswind", -MAX_SPEED_MPS, MAX_SPEED_MPS, False),
           "cv_limit": ("--cv-limit", 0.0, 1.0, True), "band_m": ("--band", 0.0, MAX_DISTANCE_M, True)}


def _check_options(**values: float) -> None:
    """SpecError (exit 2, one line naming the option) for a value outside its range or not finite."""
    for key, v in values.items():
        opt, lo, hi, open_lo = _RANGES[key]
        check_range(opt, v, lo, hi, open_lo=open_lo)


# parameters: keyword-only options, each with its default, one per `vinecli vehicle swath` option; a caller names the ones it sets
def swath_report(vehicle: str | Path, out: Path, *, height_agl_m: float, speed_mps: float, crosswind_mps: float = 0.0,
                 cv_limit: float = 0.10, band_m: float = 0.6, air_density: float = 1.225,
                 overwrite: bool = False) -> SwathReport:
    """Compute the swath of ``vehicle`` (a name in vehicles/ or a path) and write ``out`` (module docstring)."""
    from vinecli.outputs import check_output_target
    from vinecli.spray.swath import swath_pattern
    from vinecli.vehicle import load_vehicle

    _check_options(height_agl_m=height_agl_m, speed_mps=speed_mps, crosswind_mps=crosswind_mps, cv_limit=cv_limit,
                   band_m=band_m)
    veh = load_vehicle(str(vehicle))
    check_output_target(Path(out), overwrite=overwrite, kind="plan swath")  # before the work
    pat = swath_pattern(veh, height_agl_m, speed_mps, crosswind_mps=crosswind_mps, air_density=air_density,
                        cv_limit=cv_limit)
    w1 = pat.single_pass_width_m(band_m)
    doc = {
        "schema": "vinecli.swath/1", "vehicle": veh.name, "height_agl_m": height_agl_m, "speed_mps": speed_mps,
        "crosswind_mps": crosswind_mps, "air_density_kgm3": air_density, "cv_limit": cv_limit,
        "effective_swath_m": pat.effective_m, "cv_at_effective": pat.cv_at_effective,
        "geometric_swath_m": pat.geometric_m, "single_pass_width_m": w1, "band_m": band_m,
        "footprint_radius_m": pat.footprint_radius_m, "along_offset_m": pat.along_offset_m, "pitch_deg": pat.pitch_deg,
        "pattern": {"y_m": pat.y_m[::5].round(4).tolist(), "forward_per_m": pat.forward[::5].round(6).tolist(),
                    "backward_per_m": pat.backward[::5].round(6).tolist()},
        "cv": {"spacing_m": pat.spacing_m.tolist(), "back_and_forth": pat.cv_back_and_forth.round(5).tolist(),
               "racetrack": pat.cv_racetrack.round(5).tolist()},
    }
    manifest = Manifest(command="plan swath", parameters={"vehicle": str(vehicle), "height_agl_m": height_agl_m,
                                                          "speed_mps": speed_mps, "crosswind_mps": crosswind_mps,
                                                          "cv_limit": cv_limit})
    with atomic_output_dir(Path(out), manifest, overwrite=overwrite) as tmp:
        (tmp / SWATH_JSON).write_text(json.dumps(jsonable(doc), indent=1, allow_nan=False),  # RFC 8259: null
                                         encoding="utf-8")
        (tmp / SWATH_PNG).write_bytes(swath_figure(pat, veh.name))
    return SwathReport(veh.name, height_agl_m, speed_mps, crosswind_mps, pat.effective_m, pat.cv_at_effective,
                       cv_limit, pat.geometric_m, w1, pat.footprint_radius_m, pat.pitch_deg,
                       [Path(out) / SWATH_JSON, Path(out) / SWATH_PNG])
