"""Flight logs users already have, read into one neutral structure in vinecli's frames and units.

:func:`~vinecli.flightlog.read.read_flight_log` opens a PX4 ULog (:mod:`~vinecli.flightlog.ulog`, pyulog) or
an ArduPilot DataFlash ``.bin`` (:mod:`~vinecli.flightlog.dataflash`, pymavlink) into a
:class:`~vinecli.flightlog.flight_log.FlightLog`; :mod:`~vinecli.flightlog.ulog_write` and
:mod:`~vinecli.flightlog.dataflash_write` write one back out (a simulated flight as the logs a real one leaves).
"""
