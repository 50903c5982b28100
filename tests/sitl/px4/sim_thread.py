"""Run ``run_simulation`` in a background thread so a MAVLink client can talk to the vehicle."""

from __future__ import annotations

import threading
from typing import Any

from vinecli.sim.runner import run_simulation


class SimThread:
    """``start()`` the run; ``stop()`` ends it as INTERRUPTED; ``join()`` returns the SimResult."""

    def __init__(self, world: Any, mission: Any, autopilot: Any, seed: int = 1) -> None:
        self.world, self.mission, self.autopilot, self.seed = world, mission, autopilot, seed
        self._stop = threading.Event()
        self.result: Any = None
        self.error: BaseException | None = None
        self._th = threading.Thread(target=self._run, name="sim", daemon=True)

    def _run(self) -> None:
        try:
            self.result = run_simulation(self.world, self.mission, self.autopilot, seed=self.seed,
                                         should_stop=self._stop.is_set)
        except BaseException as exc:  # noqa: BLE001 - re-raised in join()
            self.error = exc
        finally:
            self.autopilot.close()

    def start(self) -> SimThread:
        self._th.start()
        return self

    def stop(self) -> None:
        self._stop.set()

    def join(self, timeout: float = 60.0) -> Any:
        self._th.join(timeout)
        if self._th.is_alive():
            self._stop.set()
            self._th.join(10.0)
            raise TimeoutError("simulation thread did not finish")
        if self.error is not None:
            raise self.error
        return self.result
