"""The fit's and the replay's figures (matplotlib object API, no pyplot state): PNG bytes each."""

from __future__ import annotations

import io
from typing import Any

import numpy as np

from vinecli.flightlog.flight_log import FlightLog
from vinecli.identify.battery_fit import charge_ah
from vinecli.identify.fit_result import FitResult
from vinecli.identify.power import cube_sum
from vinecli.identify.replay import ReplayResult

__all__ = ["fit_figures", "replay_figures"]

DPI = 100
C_LOG, C_FIT, C_BASE, C_MEAN = "#444444", "#1f77b4", "#d62728", "#2ca02c"


def _figure(w: float, h: float, rows: int = 1, cols: int = 1, sharex: bool = False) -> tuple[Any, Any]:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(w, h), dpi=DPI)
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, cols, sharex=sharex, squeeze=False)
    fig.subplots_adjust(left=0.09, right=0.91, top=0.90, bottom=0.11, hspace=0.3, wspace=0.28)
    return fig, axes


def _png(fig: Any) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, metadata={"Software": None})
    return buf.getvalue()


def _thrust(r: FitResult) -> bytes:
    s, th = r.samples, r.thrust
    fig, ax = _figure(10.0, 4.6, 1, 2)
    a = ax[0, 0]
    air = s.airborne
    um = np.nanmean(s.u[air], axis=1)
    sc = a.scatter(um, s.f_body[air, 2], c=s.speed[air], s=8, cmap="viridis", label="log (IMU, interval mean)")
    fig.colorbar(sc, ax=a, label="speed, m/s")
    uu = np.linspace(max(0.0, um.min() - 0.1), min(1.0, um.max() + 0.1), 100)
    a.plot(uu, th.specific_thrust(np.repeat(uu[:, None], th.n_rotors, axis=1)), color=C_FIT, lw=2, label="fitted curve")
    a.axhline(9.80665, color="k", ls=":", lw=1)
    a.axvline(th.hover_throttle.value, color=C_FIT, ls="--", lw=1, label=f"hover {th.hover_throttle.value:.3f}")
    a.set(xlabel="mean motor output u", ylabel="body-z specific force, m/s²", title="thrust per unit mass")
    a.legend(fontsize=8, loc="upper left")
    b = ax[0, 1]
    res = s.f_body[air, 2] - th.specific_thrust(s.u[air])
    b.plot(s.t_s[air], res, ".", ms=3, color=C_LOG)
    b.axhline(0.0, color="k", lw=0.8)
    b.set(xlabel="time, s", ylabel="residual, m/s²", title=f"residual (rms {th.rms_mps2:.2f} m/s²)")
    fig.suptitle("Thrust curve: f_z = theta sum (u_i + r)²")
    return _png(fig)


def _drag(r: FitResult) -> bytes:
    s, d = r.samples, r.drag
    air = s.airborne
    model = d.specific_force_xy(s, r.thrust.r.value)
    fig, ax = _figure(10.0, 5.4, 2, 1, sharex=True)
    for k, lab in enumerate("xy"):
        a = ax[k, 0]
        a.plot(s.t_s[air], s.f_body[air, k], ".", ms=3, color=C_LOG, label="log (IMU)")
        a.plot(s.t_s[air], model[air, k], ".", ms=3, color=C_FIT, label="fitted drag")
        a.set(ylabel=f"f_{lab} body, m/s²")
    ax[0, 0].legend(fontsize=8, loc="upper right")
    ax[1, 0].set(xlabel="time, s")
    w = np.hypot(*d.wind)
    fig.suptitle(f"In-plane specific force: drag (rms {d.rms_mps2:.2f} m/s², still air {d.rms_still_air_mps2:.2f}; "
                 f"steady wind {w:.1f} m/s)")
    return _png(fig)


def _battery(r: FitResult) -> bytes:
    b, bf = r.log.battery, r.battery
    assert b is not None and bf is not None
    fig, ax = _figure(10.0, 4.4)
    a = ax[0, 0]
    a.plot(b.t_s, b.voltage_v, ".", ms=4, color=C_LOG, label="log")
    if bf.current_logged:
        model = bf.ocv_start_v.value - bf.ocv_slope_v_per_ah.value * charge_ah(b) - bf.resistance_ohm.value * b.current_a
        a.plot(b.t_s, model, color=C_FIT, lw=1.5, label="E0 - k q - R I")
        a2 = a.twinx()
        a2.plot(b.t_s, b.current_a, color="#ff7f0e", lw=0.8, alpha=0.6)
        a2.set_ylabel("current, A", color="#ff7f0e")
    a.set(xlabel="time, s", ylabel="terminal voltage, V",
          title=f"pack: R = {bf.resistance_ohm.value * 1000:.0f} mOhm, E0 = {bf.ocv_start_v.value:.2f} V (rms {bf.rms_v:.2f} V)")
    a.legend(fontsize=8, loc="lower left")
    return _png(fig)


def _power(r: FitResult) -> bytes:
    s, b, pw = r.samples, r.log.battery, r.power
    assert b is not None and pw is not None
    fig, ax = _figure(10.0, 4.4, 1, 2)
    x = cube_sum(s.u, s.running, r.thrust.r.value)
    p_model = pw.a_w.value * x + pw.avionics_w.value
    a = ax[0, 0]
    a.plot(b.t_s, b.voltage_v * b.current_a, ".", ms=4, color=C_LOG, label="log V I")
    a.plot(s.t_s, p_model, color=C_FIT, lw=1, label="model")
    a.set(xlabel="time, s", ylabel="electrical power, W", title=f"power (rms {pw.rms_w:.0f} W)")
    a.legend(fontsize=8)
    e = pw.energy
    c = ax[0, 1]
    m = (b.t_s >= e["span_s"][0]) & (b.t_s <= e["span_s"][1])
    p = b.voltage_v[m] * b.current_a[m]
    c.plot(b.t_s[m], np.concatenate(([0.0], np.cumsum(0.5 * (p[1:] + p[:-1]) * np.diff(b.t_s[m])))) / 3600, color=C_LOG,
           label="log")
    ms = (s.t_s >= e["span_s"][0]) & (s.t_s <= e["span_s"][1])
    pm = p_model[ms]
    c.plot(s.t_s[ms], np.concatenate(([0.0], np.cumsum(0.5 * (pm[1:] + pm[:-1]) * np.diff(s.t_s[ms])))) / 3600,
           color=C_FIT, label="model")
    err = e.get("error_fraction")
    c.set(xlabel="time, s", ylabel="energy, Wh", title=f"energy ({err * 100:+.1f} %)" if err is not None else "energy")
    c.legend(fontsize=8)
    return _png(fig)


def fit_figures(r: FitResult) -> list[tuple[str, bytes]]:
    """(caption, PNG) of the fit page's figures."""
    out = [("Thrust curve per unit mass and its residual", _thrust(r)),
           ("In-plane specific force and the fitted drag", _drag(r))]
    if r.battery is not None:
        out.append(("Battery terminal voltage and its model", _battery(r)))
    if r.power is not None:
        out.append(("Electrical power and the flight's energy", _power(r)))
    return out


def replay_figures(rep: ReplayResult, log: FlightLog) -> list[tuple[str, bytes]]:
    """(caption, PNG) of the replay page's figures."""
    sr = rep.series
    t, inw = sr["t_s"], sr["in_window"]
    names = [n for n in ("vehicle", "base_unfitted") if n in sr]
    colors = {"vehicle": C_FIT, "base_unfitted": C_BASE}
    fig, ax = _figure(10.0, 6.4, 3, 1, sharex=True)
    for k, lab in enumerate("xyz"):
        a = ax[k, 0]
        a.plot(t[inw], sr["f_log"][inw, k], ".", ms=2.5, color=C_LOG, label="log (IMU)")
        for n in names:
            a.plot(t[inw], sr[n]["f"][inw, k], ".", ms=2.5, color=colors[n], label=n)
        a.set(ylabel=f"f_{lab}, m/s²")
    ax[0, 0].legend(fontsize=8, loc="upper right", ncol=3)
    ax[2, 0].set(xlabel="time, s")
    fig.suptitle("Specific force in the open-loop windows (body FLU)")
    figs = [("Specific force, log against the replays", _png(fig))]
    fig, ax = _figure(10.0, 4.0)
    a = ax[0, 0]
    mid = np.array([0.5 * (w0 + w1) for w0, w1 in rep.windows])
    for n, c in (*((n, colors[n]) for n in names), ("log_mean", C_MEAN)):
        a.plot(mid, np.linalg.norm(sr[n]["v_end_error"], axis=1), "o-", ms=3, color=c, label=n)
    a.set(xlabel="window centre, s", ylabel="|velocity error| at the end, m/s", yscale="log",
          title="velocity drift per open-loop window")
    a.legend(fontsize=8)
    figs.append(("Velocity drift per window", _png(fig)))
    bat = [n for n in names if f"{n}_battery" in sr]
    if bat and log.battery is not None:
        fig, ax = _figure(10.0, 4.0)
        a = ax[0, 0]
        a.plot(log.battery.t_s, log.battery.voltage_v, ".", ms=3, color=C_LOG, label="log")
        for n in bat:
            a.plot(sr[f"{n}_battery"]["t_s"], sr[f"{n}_battery"]["voltage_v"], color=colors[n], label=n)
        a.set(xlabel="time, s", ylabel="terminal voltage, V", title="battery voltage over the flight")
        a.legend(fontsize=8)
        figs.append(("Battery voltage, log against the replays", _png(fig)))
    return figs
