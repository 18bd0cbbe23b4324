"""A campaign's steps and the scenario events they become: the buffer each action writes into
(`actions.py` says what each action writes)."""

from __future__ import annotations

import builtins
import heapq
from dataclasses import dataclass, field
from typing import Any

from bywire.config import RobotConfig
from bywire.model import ControlMode
from bywire.sim.scenario import Event


@dataclass(frozen=True, slots=True)
class Step:
    """Wait `delay_s`, then do `action` with `value` (one of `VOCABULARY[action]`)."""

    delay_s: float
    action: str
    value: builtins.object = None  # not `object`: mypyc cannot load it at import (issue 43)


@dataclass(slots=True)
class StepEvents:
    """Timed scenario events as steps make them, following what they do to the switch and the
    remote stop request (a flick returns to where the switch was, a re-enable repeats the
    request, a handover goes to the other source)."""

    robot: RobotConfig
    events: list[Event] = field(default_factory=list)
    switch: ControlMode = ControlMode.STOP
    remote_stop: bool = False
    pending: list[tuple[float, int, Event]] = field(default_factory=list)
    order: int = 0

    def start(self) -> None:
        """Power-up: the RC gear forward, the computer at rest."""
        self.emit(Event(0.0, "rc", {"gear": "forward"}))
        start = {"steering": 0.0, "throttle": 0.0, "brake": 0.0, "gear": "forward"}
        self.emit(Event(0.0, "hlc", start))

    def flush(self, until_s: float) -> None:
        """Emit the later events due by `until_s`, in time order."""
        while self.pending and self.pending[0][0] <= until_s:
            self.emit(heapq.heappop(self.pending)[2])

    def emit(self, event: Event) -> None:
        if event.kind == "rc" and "mode" in event.values:
            self.switch = ControlMode[event.values["mode"].upper()]
        if event.kind == "hlc_control":
            self.remote_stop = event.values["remote_stop"]
        self.events.append(event)

    def later(self, at_s: float, kind: str, values: dict[str, Any]) -> None:
        self.order += 1
        at_s = round(at_s, 6)
        heapq.heappush(self.pending, (at_s, self.order, Event(at_s, kind, values)))

    def fault(self, at_s: float, fault: str, **values: Any) -> None:
        self.emit(Event(at_s, "fault", {"fault": fault, "count": 1, **values}))
