"""Record a simulated run for `bywire replay`: tape the controller's ports, write the record.

`SimRunRecorder.attach(sim)` puts the controller of a `SimRun` on taped ports before it runs
(`SimRun.put_controller_on`: the controller rebuilt on the taped bundle exactly as the run
built it, so that taping changes nothing the run does); after the run,
`write()` saves the record (`bywire.hal.tape.run_record`).
"""

from __future__ import annotations

from pathlib import Path

from bywire.config import describe
from bywire.errors import ConfigError
from bywire.hal.simulated.clock import RealtimeClock
from bywire.hal.tape.run_record import SENSOR_NAMES, RecordHeader, write_record
from bywire.hal.tape.taped import Tape, taped_hardware
from bywire.sim.runner import SimRun


def check_record_path(path: Path) -> None:
    """ConfigError unless the record's folder exists (any name; `.gz` compresses)."""
    if not path.parent.is_dir():
        raise ConfigError(f"cannot write {path}: folder {path.parent} does not exist")


class SimRunRecorder:
    """The tape of one simulated run; create it with `attach` before `sim.run()`."""

    def __init__(self, sim: SimRun, tape: Tape, path: Path) -> None:
        self._sim = sim
        self.tape = tape
        self.path = path

    @classmethod
    def attach(cls, sim: SimRun, path: Path) -> SimRunRecorder:
        """Tape `sim`'s controller for a record at `path`; ConfigError for a folder that does not
        exist or a run paced by the wall clock, whose loop timing virtual-time replay could not
        reproduce."""
        check_record_path(path)
        if isinstance(sim.world.clock, RealtimeClock):
            raise ConfigError(
                f"cannot record {sim.scenario.name!r} for replay: it runs in real time"
                " (drop --realtime; scenarios that stall the loop always run in real time)"
            )
        tape = Tape(sim.world.clock)
        sim.put_controller_on(lambda hardware: taped_hardware(hardware, tape))
        return cls(sim, tape, path)

    def header(self) -> RecordHeader:
        sim, hardware = self._sim, self._sim.world.hardware
        return RecordHeader(
            scenario=sim.scenario.name,
            start_s=sim.started_at,
            end_s=sim.started_at + sim.duration_s,
            pwm_period_s={
                "steering": hardware.steering_pwm.period_s,
                "hydrobrake": hardware.hydrobrake_pwm.period_s,
            },
            sensors=tuple(name for name in SENSOR_NAMES if getattr(hardware, name) is not None),
            config_toml=describe(sim.robot),
            authenticated=sim.secoc is not None,
        )

    def write(self) -> int:
        """Write the record after the run; returns the number of events."""
        return write_record(self.path, self.header(), self.tape.events)
