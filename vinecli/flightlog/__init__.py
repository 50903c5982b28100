"""Flight logs users already have, read into one neutral structure in vinecli's frames and units.

:func:`~vinecli.flightlog.read.read_flight_log` opens a PX4 ULog (:mod:`~vinecli.flightlog.ulog`, pyulog) or an
ArduPilot DataFlash ``.bin`` (:mod:`~vinecli.flightlog.dataflash`, pymavlink) into a
:class:`~vinecli.flightlog.flight_log.FlightLog` (array helpers: :mod:`~vinecli.flightlog.arrays`);
:mod:`~vinecli.flightlog.ulog_write` and :mod:`~vinecli.flightlog.dataflash_write` write one back out,
:mod:`~vinecli.flightlog.from_run` from a run's time series (a simulated flight as the logs a real one leaves).

May import the ground floor (constants, errors, frames, geo, inputs, outputs, types, ...) and :mod:`vinecli.specs`. ``read.py`` is the reader, as in :mod:`vinecli.gis`.
"""
