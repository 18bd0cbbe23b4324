"""Headless textual pilot: teleop key presses drive a whole simulated robot, in virtual time."""

from __future__ import annotations

import asyncio
from dataclasses import dataclass

from textual.pilot import Pilot
from textual.widgets import Static

from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.timers import PeriodicTimer
from bywire.hal.simulated.world import SimWorld
from bywire.model import ControlMode, Gear
from bywire.protocol import dbc
from bywire.protocol.secoc import SecocKey
from bywire.runtime.loop import Runtime
from bywire.runtime.settings import RuntimeConfig
from bywire.security.freshness import FreshnessStore
from bywire.security.session import TRIP_IDS, SecocReceiver, SecocSigner
from bywire.teleop.app import TeleopApp
from bywire.teleop.frames import SEND_PERIOD_S
from bywire.teleop.reports import speed_mps
from tests.netbus.sim_port_bus import SimPortBus

THROTTLE_CHANNEL = 0
TRIP = 12


@dataclass
class Rig:
    """A simulated robot whose higher-level computer is the teleop app, ticked by the clock."""

    clock: VirtualClock
    world: SimWorld
    runtime: Runtime
    app: TeleopApp
    shown_commands: str = ""

    @classmethod
    def build(cls, key: SecocKey | None = None) -> Rig:
        """`key`: authenticated commands, teleop signing, the controller verifying."""
        clock = VirtualClock()
        world = SimWorld.create(clock)
        receiver = None if key is None else SecocReceiver(key, TRIP, dbc.command_ids())
        runtime = Runtime(world.hardware, RuntimeConfig(), secoc=receiver)
        accepted = (*dbc.report_ids(), *(TRIP_IDS if key is not None else ()))
        port = world.bus.attach("teleop", accept_ids=accepted, tx_mailboxes=6)
        signer = None if key is None else SecocSigner(key, FreshnessStore(key))
        app = TeleopApp(
            SimPortBus(port), now=clock.now, auto_tick=False, notifier=False, signer=signer
        )
        return cls(clock, world, runtime, app)

    def start(self) -> None:
        """Teleop ticks at 50 Hz; the RC transmitter arms the robot: STOP, then CAN."""
        PeriodicTimer(self.clock, SEND_PERIOD_S, lambda _tick_s: self.app.tick()).start()
        rc = self.world.rc

        def switch_to_stop_in_forward() -> None:
            rc.set_mode(ControlMode.STOP)
            rc.set_gear(Gear.FORWARD)

        self.clock.call_at(0.1, switch_to_stop_in_forward)
        self.clock.call_at(0.2, lambda: rc.set_mode(ControlMode.CAN))
        self.world.start(hlc=False)

    async def run_for(self, pilot: Pilot[None], duration_s: float) -> None:
        self.runtime.run(until_s=self.clock.now() + duration_s)
        await pilot.pause()

    def mode(self) -> ControlMode | None:
        """The robot's mode now (a call, not a property: it changes as the clock runs)."""
        outputs = self.runtime.outputs
        return None if outputs is None else outputs.mode

    def max_throttle_volts(self, after_s: float, before_s: float) -> float:
        volts = [
            value
            for stamp_s, channel, value in self.world.dac.history
            if channel == THROTTLE_CHANNEL and after_s <= stamp_s < before_s
        ]
        return max(volts, default=0.0)

    def panel(self, widget_id: str) -> str:
        return str(self.app.query_one(widget_id, Static).content)


async def _drive(rig: Rig) -> None:
    async with rig.app.run_test() as pilot:
        rig.shown_commands = ""
        rig.start()
        await rig.run_for(pilot, 0.5)
        assert rig.mode() is ControlMode.CAN
        assert "mode CAN" in rig.panel("#reports")

        await pilot.press("f", "up", "up", "up", "up", "up")
        assert rig.app.state.throttle_norm == 0.5
        started_s = rig.clock.now()
        await rig.run_for(pilot, 0.5)
        assert rig.max_throttle_volts(started_s, rig.clock.now()) > 0.0
        assert min(rig.world.vehicle.wheel_speeds()) > 0.0
        speed = speed_mps(rig.app.view)
        assert speed is not None
        assert speed > 0.0
        reports = rig.panel("#reports")
        assert "mode CAN  gear FORWARD" in reports
        assert f"speed {speed:+.2f} m/s" in reports
        assert "errors none" in reports

        # Dead man's rule: no key for a while and the throttle ramps back to zero.
        await rig.run_for(pilot, 2.0)
        assert rig.app.state.throttle_norm == 0.0
        end_s = rig.clock.now()
        assert rig.max_throttle_volts(end_s - 0.5, end_s) == 0.0

        await pilot.press("s")
        await rig.run_for(pilot, 0.3)
        assert rig.mode() is ControlMode.STOP
        reports = rig.panel("#reports")
        assert "mode STOP" in reports
        assert "LATCHED" in reports
        assert "REMOTE_STOP" in reports

        await pilot.press("s", "e")
        await rig.run_for(pilot, 0.3)
        assert rig.mode() is ControlMode.CAN
        assert "mode CAN" in rig.panel("#reports")
        rig.shown_commands = rig.panel("#commands")


def test_key_presses_move_the_simulated_robot_and_the_panel_shows_its_reports() -> None:
    asyncio.run(_drive(Rig.build()))


def test_signed_key_presses_move_a_robot_that_verifies_them() -> None:
    rig = Rig.build(SecocKey(bytes(range(16))))
    asyncio.run(_drive(rig))
    assert rig.runtime.can.auth_failures == {}
    assert rig.app.frames_sent % 2 == 0  # every command with its cryptographic PDU
    assert rig.app.signer is not None
    assert rig.app.signer.trip == TRIP  # the one the robot announced with its reports
    assert f"SecOC: signing in trip {TRIP}" in rig.shown_commands
