"""A fault campaign: a sequence of timed actions on the simulated robot, judged by the oracle.

Each step waits its delay, then does one thing an operator, the higher-level computer or the
world can do: move a stick or a switch (or arm deliberately), bounce the switch, lose or corrupt
the RC link, send or stop CAN commands, ask for a remote stop or a re-enable, let a second node
send on the computer's id, make DAC writes fail or hang, kill the wheel-speed sensor. The real
controller runs on virtual time with its watchdog on the simulated clock; the `HazardOracle`
checks the hardware after every pass of its loop.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import cast

from bywire.hal.sim.clock import VirtualClock
from bywire.hal.sim.hlc import Corruption
from bywire.hal.sim.timers import PeriodicTimer
from bywire.hal.sim.world import SimWorld
from bywire.model import ControlMode, Gear, MovementCommand
from bywire.runtime.app import Runtime
from bywire.runtime.settings import RuntimeConfig
from bywire.runtime.watchdog import POLL_S
from bywire.sim.oracle import HazardOracle

WATCHDOG_S = 0.200
ARM_HOLD_S = 0.060  # how long `arm` holds the switch at STOP: eight frames
HANDOVER_LEAD_S = 0.045  # the computer's new set-point is on the bus before the switch moves


@dataclass(frozen=True, slots=True)
class Step:
    """Wait `delay_s`, then do `action` with `value`."""

    delay_s: float
    action: str
    value: object = None


@dataclass(slots=True)
class CampaignResult:
    """What one campaign did and what the oracle found."""

    oracle: HazardOracle
    simulated_s: float
    runtime: Runtime


class Campaign:
    """One robot, one sequence of steps, one oracle."""

    def __init__(self, config: RuntimeConfig | None = None) -> None:
        self.clock = VirtualClock()
        self.world = SimWorld.create(self.clock)
        base = config or RuntimeConfig()
        self.runtime = Runtime(
            self.world.hardware, replace(base, watchdog_s=WATCHDOG_S), watchdog_thread=False
        )
        self.oracle = HazardOracle(self.world)
        self.runtime.on_cycle.append(self.oracle.observe)
        self._remote_stop = False
        self._can_throttle = 0.0
        self._can_gear = Gear.FORWARD
        self.world.rc.set_gear(Gear.FORWARD)
        self._send_movement()
        watchdog = self.runtime.watchdog
        if watchdog is not None:

            def check(_tick_s: float) -> None:
                watchdog.check()

            PeriodicTimer(self.clock, POLL_S, check).start()
        self._handlers: dict[str, Callable[[object], None]] = {
            "switch": self._do_switch,
            "rc_throttle": self._do_rc_throttle,
            "rc_gear": self._do_rc_gear,
            "rc_steer": self._do_rc_steer,
            "arm": self._do_arm,
            "flick": self._do_flick,
            "handover": self._do_handover,
            "chatter": self._do_chatter,
            "rc_link": self._do_rc_link,
            "rc_failsafe": self._do_rc_failsafe,
            "rc_implausible": self._do_rc_implausible,
            "can_throttle": self._do_can_throttle,
            "can_gear": self._do_can_gear,
            "can_link": self._do_can_link,
            "can_repeat": self._do_can_repeat,
            "remote_stop": self._do_remote_stop,
            "re_enable": self._do_re_enable,
            "impostor": self._do_impostor,
            "dac": self._do_dac,
            "stall": self._do_stall,
            "wheel_sensor": self._do_wheel_sensor,
        }
        """Every action a step may name, with what it does."""

    def run(self, steps: list[Step], tail_s: float = 0.5) -> CampaignResult:
        """Play the steps, then `tail_s` more; the oracle has seen every pass."""
        at_s = 0.0
        for step in steps:
            at_s += step.delay_s
            self.clock.call_at(at_s, self._action(step))
        self.world.start()
        self.runtime.run(until_s=at_s + tail_s)
        self.world.stop()
        return CampaignResult(self.oracle, at_s + tail_s, self.runtime)

    # --- the actions ------------------------------------------------------------------------------

    def _action(self, step: Step) -> Callable[[], None]:
        handler = self._handlers[step.action]
        return lambda: handler(step.value)

    @property
    def _now(self) -> float:
        return self.clock.now()

    def _do_switch(self, value: object) -> None:
        mode = cast(ControlMode, value)
        self.world.rc.set_mode(mode)
        self._note_switch(mode)

    def _note_switch(self, mode: ControlMode) -> None:
        oracle, now = self.oracle, self._now
        oracle.set_switch(mode, now)
        if mode is ControlMode.CAN and oracle.faults & {"can_lost", "can_impostor", "remote_stop"}:
            oracle.stop_event("can_lost", now)

    def _do_rc_throttle(self, value: object) -> None:
        pedal = cast(float, value)
        self.world.rc.set_pedal(pedal)
        self.oracle.set_throttle(ControlMode.RC, max(pedal, 0.0), self._now)

    def _do_rc_steer(self, value: object) -> None:
        self.world.rc.set_steering(cast(float, value))

    def _do_rc_gear(self, value: object) -> None:
        self.world.rc.set_gear(cast(Gear, value))

    def _do_arm(self, value: object) -> None:
        """A deliberate act: switch to STOP, hold it, source at zero throttle, switch over."""
        mode = cast(ControlMode, value)
        self._do_switch(ControlMode.STOP)

        def move() -> None:
            if mode is ControlMode.RC:
                self._do_rc_throttle(0.0)
            else:
                self._do_can_throttle(0.0)
            self._do_switch(mode)

        self.clock.call_at(self._now + ARM_HOLD_S, move)

    def _do_flick(self, value: object) -> None:
        """The switch through STOP and straight back after `value` seconds (sticks as they are)."""
        back = self.oracle.switch
        self._do_switch(ControlMode.STOP)
        if back is not ControlMode.STOP:
            self.clock.call_at(self._now + cast(float, value), lambda: self._do_switch(back))

    def _do_handover(self, value: object) -> None:
        """The switch from one driving source to the other (from STOP to RC), the incoming
        source asking for throttle `value` since a little before (the computer already
        commanding when the operator hands over; the stick moved with the switch)."""
        other = ControlMode.CAN if self.oracle.switch is ControlMode.RC else ControlMode.RC
        if other is ControlMode.RC:
            self._do_rc_throttle(value)
            self._do_switch(other)
            return
        self._do_can_throttle(value)
        self.clock.call_at(self._now + HANDOVER_LEAD_S, lambda: self._do_switch(other))

    def _do_chatter(self, value: object) -> None:
        self.world.rc.chatter_next_frames(cast(int, value))
        self.oracle.stop_event("switch_stop", self._now)

    def _do_rc_link(self, up: object) -> None:
        if up:
            self.world.rc.link_restored()
        else:
            self.world.rc.link_lost()
        self.oracle.fault("rc_link_lost", not up, self._now)

    def _do_rc_failsafe(self, on: object) -> None:
        rc = self.world.rc
        if on:
            mapping = rc.mapping
            rc.failsafe({mapping.failsafe.channel: mapping.failsafe.below_raw - 50})
        else:
            rc.failsafe_off()
        self.oracle.fault("rc_failsafe", bool(on), self._now)

    def _do_rc_implausible(self, value: object) -> None:
        self.world.rc.implausible_next_frames(cast(int, value))
        self.oracle.stop_event("rc_implausible", self._now)

    def _send_movement(self) -> None:
        self.world.hlc.set_movement(0.0, self._can_throttle, 0.0, self._can_gear)

    def _do_can_throttle(self, value: object) -> None:
        self._can_throttle = cast(float, value)
        self._send_movement()
        self.oracle.set_throttle(ControlMode.CAN, self._can_throttle, self._now)

    def _do_can_gear(self, value: object) -> None:
        self._can_gear = cast(Gear, value)
        self._send_movement()

    def _do_can_link(self, up: object) -> None:
        if up:
            self.world.hlc.start()
        else:
            self.world.hlc.silence()
        self._can_fault("can_lost", not up)
        if up and self._remote_stop:  # a request made while silent arrives now
            self.oracle.fault("remote_stop", True, self._now)

    def _can_fault(self, kind: str, active: bool) -> None:
        oracle, now = self.oracle, self._now
        if oracle.switch is ControlMode.CAN or not active:
            oracle.fault(kind, active, now)
        else:
            oracle.faults.add(kind)  # blocks arming into CAN; RC drives on
            oracle.fault_changed_at = now

    def _do_can_repeat(self, value: object) -> None:
        self.world.hlc.corrupt_next(cast(int, value), Corruption.REPEATED_COUNTER, MovementCommand)

    def _do_remote_stop(self, on: object) -> None:
        self._remote_stop = bool(on)
        self.world.hlc.set_control(self._remote_stop, re_enable=False)
        if not self._remote_stop or "can_lost" not in self.oracle.faults:
            self.oracle.fault("remote_stop", self._remote_stop, self._now)  # arriving: every mode

    def _do_re_enable(self, _value: object) -> None:
        """Re-enable requested: 0 in the frames now, 1 from two command periods later."""
        hlc = self.world.hlc
        hlc.set_control(self._remote_stop, re_enable=False)

        def rise() -> None:
            hlc.set_control(self._remote_stop, re_enable=True)
            self.oracle.re_enable(self._now)

        self.clock.call_at(self._now + 0.045, rise)

    def _do_impostor(self, value: object) -> None:
        frames = cast(int, value)
        self.world.impostor.start(frames)
        self._can_fault("can_impostor", True)
        # Over when its last frame is sent: the controller may trust the id again soon after
        # (a window of good frames), and the oracle must never think a fault lasts longer.
        end_s = self._now + frames * 0.020
        self.clock.call_at(end_s, lambda: self._can_fault("can_impostor", False))

    def _do_dac(self, how: object) -> None:
        dac = self.world.dac
        if how == "restore":
            dac.stop_failing()
            self.oracle.fault("dac_fail", False, self._now)
            return
        if how == "fail":
            dac.fail_writes()
        else:
            dac.fail_pattern((True, False))
        self.oracle.fault("dac_fail", True, self._now)

    def _do_stall(self, value: object) -> None:
        stall_s = cast(float, value)
        self.world.dac.stall_next_write(stall_s)
        if stall_s > WATCHDOG_S:
            # The next DAC write (within one control period) hangs; the watchdog's poll trips.
            self.oracle.stall(self._now, self._now + 0.010 + WATCHDOG_S + 2 * POLL_S)

    def _do_wheel_sensor(self, alive: object) -> None:
        if alive:
            self.world.wheel_sensor.restore()
        else:
            self.world.wheel_sensor.die()
            self.oracle.sensor_dead = True
