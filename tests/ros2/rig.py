"""The bridge's CAN side driving a whole simulated robot on virtual time: the real controller,
real frames on the simulated bus, the bridge's `CanLink` ticked every 20 ms by the clock, and a
planner stand-in that offers set-points as the rclpy node would (arrival on the same clock)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from bywire.config.vehicle import VehicleSection
from bywire.hal.simulated.can_bus import LoggedFrame
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.timers import PeriodicTimer
from bywire.hal.simulated.world import SimWorld
from bywire.model import ControlMode, Gear, MovementCommand
from bywire.protocol import dbc
from bywire.protocol.secoc import SecocKey
from bywire.ros2.link import CanLink
from bywire.ros2.setpoint import Setpoint
from bywire.ros2.settings import BridgeSettings, Geometry
from bywire.runtime.loop import Runtime
from bywire.runtime.settings import RuntimeConfig
from bywire.security.freshness import FreshnessStore
from bywire.security.session import TRIP_IDS, SecocReceiver, SecocSigner
from bywire.teleop.frames import SEND_PERIOD_S
from tests.netbus.sim_port_bus import SimPortBus

NODE = "ros2"
ARMED_AT_S = 0.3  # the transmitter's switch: STOP at 0.1 s, CAN at 0.2 s, debounced by then


@dataclass
class Sample:
    """The robot at one instant, seen from outside the bridge (the simulator's truth)."""

    time_s: float
    speed_mps: float
    mode: ControlMode | None
    latched: bool  # the controller's own latched causes, not what the bridge was told
    flags: int = 0  # the controller's own error flags


TRIP = 3  # the simulated controller's trip counter, announced with its reports


@dataclass
class Rig:
    clock: VirtualClock
    world: SimWorld
    runtime: Runtime
    link: CanLink
    sent: list[LoggedFrame] = field(default_factory=list)
    samples: list[Sample] = field(default_factory=list)

    @classmethod
    def build(cls, settings: BridgeSettings | None = None, key: SecocKey | None = None) -> Rig:
        clock = VirtualClock()
        world = SimWorld.create(clock)
        receiver = None if key is None else SecocReceiver(key, TRIP, dbc.command_ids())
        runtime = Runtime(world.hardware, RuntimeConfig(), secoc=receiver)
        accepted = (*dbc.report_ids(), *(TRIP_IDS if key is not None else ()))
        port = world.bus.attach(NODE, accept_ids=accepted, tx_mailboxes=6)
        signer = None if key is None else SecocSigner(key, FreshnessStore(key))
        link = CanLink(
            SimPortBus(port),
            settings or BridgeSettings(),
            Geometry.of(VehicleSection()),
            signer=signer,
            now=clock.now,
            notifier=False,
        )
        rig = cls(clock, world, runtime, link)
        world.bus.add_monitor(rig._note)
        return rig

    def _note(self, frame: LoggedFrame) -> None:
        if frame.sender == NODE:
            self.sent.append(frame)

    def start(self) -> None:
        """The bridge ticks at 50 Hz; the transmitter arms the robot into CAN mode."""
        PeriodicTimer(self.clock, SEND_PERIOD_S, self._tick).start()
        PeriodicTimer(self.clock, 0.01, lambda _tick_s: self._sample()).start()
        rc = self.world.rc
        self.clock.call_at(0.1, lambda: rc.set_mode(ControlMode.STOP))
        self.clock.call_at(0.2, lambda: rc.set_mode(ControlMode.CAN))
        self.world.start(hlc=False)

    def _tick(self, _tick_s: float) -> None:
        self.link.tick()

    def _sample(self) -> None:
        outputs = self.runtime.outputs
        mode = None if outputs is None else outputs.mode
        latched = outputs is not None and bool(outputs.causes)
        speed = self.world.vehicle.state.speed_mps
        flags = 0 if outputs is None else outputs.error_flags
        self.samples.append(Sample(self.clock.now(), speed, mode, latched, flags))

    def run_until(self, until_s: float) -> None:
        """Run the whole robot to `until_s` (one call per test: a run starts from safe outputs)."""
        self.runtime.run(until_s=until_s)

    def at(self, when_s: float, action: Callable[[], object]) -> None:
        def call() -> None:
            action()

        self.clock.call_at(when_s, call)

    def publish(
        self,
        speed_mps: float,
        start_s: float,
        end_s: float,
        *,
        steering_norm: float | None = 0.0,
        stamp_lag_s: float = 0.0,
        period_s: float = 0.05,
    ) -> None:
        """A planner at 20 Hz from `start_s` until before `end_s`; `stamp_lag_s`: each message's
        header stamp is this old when it arrives."""

        def send() -> None:
            now_s = self.clock.now()
            if now_s >= end_s:
                return
            self.link.offer(Setpoint(speed_mps, steering_norm, now_s, stamp_lag_s))
            self.clock.call_at(now_s + period_s, send)

        self.clock.call_at(start_s, send)

    def movements(self, after_s: float = 0.0) -> list[MovementCommand]:
        """Every movement command the bridge put on the bus after `after_s`, decoded."""
        movement_id = dbc.frame_id(MovementCommand)
        decoded = []
        for frame in self.sent:
            if frame.arbitration_id == movement_id and frame.time_s >= after_s:
                command = dbc.decode_command(frame.arbitration_id, frame.data, None)
                if isinstance(command, MovementCommand):
                    decoded.append(command)
        return decoded

    def speeds(self, after_s: float, before_s: float) -> list[float]:
        return [s.speed_mps for s in self.samples if after_s <= s.time_s < before_s]

    def modes(self, after_s: float, before_s: float = float("inf")) -> set[ControlMode | None]:
        return {s.mode for s in self.samples if after_s <= s.time_s < before_s}

    def first(self, flag: int, after_s: float = 0.0) -> float:
        """When the controller first raised `flag` after `after_s` (inf: never)."""
        raised = [s.time_s for s in self.samples if s.time_s >= after_s and s.flags & flag]
        return min(raised, default=float("inf"))

    def throttle_volts(self, after_s: float) -> list[float]:
        """The throttle DAC's output from `after_s` on: the volts it held then, and every change
        after (volts)."""
        writes = [(t, volts) for t, channel, volts in self.world.dac.history if channel == 0]
        held = [volts for t, volts in writes if t <= after_s][-1:] or [0.0]
        return held + [volts for t, volts in writes if t > after_s]

    def gear(self) -> Gear:
        return self.link.snapshot().decision.pedals.gear  # type: ignore[union-attr]
