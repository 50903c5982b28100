"""Autopilot backends behind one interface (:class:`vinecli.autopilot.base.Autopilot`)."""
