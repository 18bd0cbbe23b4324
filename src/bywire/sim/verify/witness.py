"""The campaign's witness: tells the oracle what each event applied to the simulated robot means
for the outputs: where the switch went, what each source asks for, which faults began or ended
(each fault by its own rule, `fault_rules.RULES`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from bywire.control.dac_health import DAC_TRANSFERS_PER_PASS
from bywire.control.rc_mapping import RcMapping
from bywire.hal.simulated.clock import VirtualClock
from bywire.model import ControlMode
from bywire.ros2.bridge import Decision
from bywire.ros2.link import Snapshot
from bywire.runtime.watchdog import POLL_S as WATCHDOG_POLL_S
from bywire.sim.scenario import Event
from bywire.sim.verify.fault_rules import IMPOSTOR_PERIOD_S, RULES
from bywire.sim.verify.oracle import HazardOracle, OracleCause
from bywire.sim.verify.oracle.causes import CAN_ONLY, CAN_SILENT
from bywire.sim.verify.oracle.requirements import SLOW_TRANSFER_S

RC, CAN, STOP = ControlMode.RC, ControlMode.CAN, ControlMode.STOP


@dataclass(slots=True)
class OracleWitness:
    """Tells the oracle what an event applied to the world means for the outputs."""

    oracle: HazardOracle
    clock: VirtualClock
    authenticated: bool = False  # commands signed: a second sender without the key is harmless
    remote_stop: bool = False
    re_enable: bool = False
    sender_started_s: float | None = None  # the newest start of the movement id's second sender
    harmful_sender: bool = False  # it is sending frames the controller can take (`second_sender`)
    bridge: bool = False  # the computer is the ROS 2 bridge: its periods tell (`bridge_period`)
    _sent: tuple[float, float] | None = None  # the bridge's last throttle and steering
    mapping: RcMapping = field(default_factory=RcMapping)  # the robot's switch calibration
    switch_moved_s: float | None = None  # the newest event that set the mode switch

    def __call__(self, event: Event, now: float) -> None:
        values = event.values
        match event.kind:
            case "rc":
                self._rc(values, now)
            case "hlc" | "hlc_control" if self.bridge:
                return  # the simulated computer is not running: the bridge sends
            case "hlc":
                self._hlc(values, now)
            case "hlc_control":
                self._hlc_control(values, now)
            case "hlc_lights" | "planner" | "bridge_service" | "world":
                # the lights demand nothing of the drive; the bridge's periods tell; the road's
                # grade is judged by its effect, the true speed (H11)
                return
            case "fault":
                RULES[str(values["fault"])](self, values, now)
            case _:
                raise ValueError(f"an event the oracle does not know: {event.kind!r}")

    def _rc(self, values: dict[str, Any], now: float) -> None:
        oracle = self.oracle
        if "throttle" in values:
            oracle.set_throttle(RC, max(float(values["throttle"]), 0.0), now)
        if "steering" in values:
            oracle.set_steering(RC, float(values["steering"]), now)
        if "mode_raw" in values:
            self._mode_raw(int(values["mode_raw"]), now)
        if "mode" in values:
            self.switch_moved_s = now
            self._switch(ControlMode[str(values["mode"]).upper()], now)

    def _switch(self, mode: ControlMode, now: float) -> None:
        """The mode switch moved to `mode` (by its nominal pulse or any other in its band)."""
        oracle = self.oracle
        oracle.set_switch(mode, now)
        if mode is CAN and oracle.faults.any_of(CAN_ONLY):
            oracle.switched_to_lost_can(now)

    def _mode_raw(self, raw: int, now: float) -> None:
        """The mode switch's pulse set to `raw`: in a position's band, that position; between
        two driving positions with the switch at one of them, a switch in transit, which reads
        as that position for the debounce's frames and then as STOP (R-SWITCH, issue 41); any
        other value, STOP at once. Between positions, STOP is no stay at STOP (row 72)."""
        self.switch_moved_s = now
        oracle, timing = self.oracle, self.oracle.timing
        banded, neighbours = self._read(raw, oracle.switch)
        if banded is not None:
            self._switch(banded, now)
            return
        if oracle.switch is STOP or oracle.switch not in neighbours or STOP in neighbours:
            oracle.set_switch_between(now)
            return
        stop_s = now + timing.debounce_frames * timing.frame_s  # the last frame it may hold

        def stops() -> None:
            if self.switch_moved_s == now:  # not moved since
                oracle.set_switch_between(stop_s)

        self.clock.call_at(stop_s, stops)

    def _read(
        self, raw: int, switch_at: ControlMode
    ) -> tuple[ControlMode | None, tuple[ControlMode, ...]]:
        """The mode whose band holds `raw` (`switch_at`'s widened by the hysteresis; None:
        none), and the modes whose nominal pulses are the nearest on either side of it (none
        beyond the ends)."""
        switch, modes = self.mapping.mode_switch, self.mapping.mode_positions
        count = len(switch.positions_raw)
        by_pulse = sorted(
            (switch.positions_raw[count - 1 - i if switch.reverse else i], modes[i])
            for i in range(count)
        )
        for pulse, mode in by_pulse:
            reach = switch.hysteresis_raw if mode is switch_at else 0
            if abs(raw - pulse) <= switch.band_raw + reach:
                return mode, ()
        below = [mode for pulse, mode in by_pulse if pulse < raw][-1:]
        above = [mode for pulse, mode in by_pulse if pulse > raw][:1]
        neighbours = (*below, *above)
        return None, neighbours if len(neighbours) == 2 else ()

    def _hlc(self, values: dict[str, Any], now: float) -> None:
        if "throttle" in values:
            self.oracle.set_throttle(CAN, float(values["throttle"]), now)
        if "steering" in values:
            self.oracle.set_steering(CAN, float(values["steering"]), now)

    def _hlc_control(self, values: dict[str, Any], now: float) -> None:
        oracle = self.oracle
        remote_stop, re_enable = bool(values["remote_stop"]), bool(values["re_enable"])
        if remote_stop != self.remote_stop:
            self.remote_stop = remote_stop
            if not remote_stop or not oracle.faults.any_of(CAN_SILENT):
                oracle.fault(OracleCause.REMOTE_STOP, remote_stop, now)  # arriving: every mode
        if re_enable and not self.re_enable:
            oracle.re_enable(now)
        self.re_enable = re_enable

    def bridge_period(self, decision: Decision, _snapshot: Snapshot, now: float) -> None:
        """One period of the bridge's link: what its frames ask for, told as the simulated
        computer's events are (each change, as it goes out)."""
        sent = (decision.pedals.throttle_norm, decision.steering_norm)
        if sent != self._sent:
            self._sent = sent
            self._hlc({"throttle": sent[0], "steering": sent[1]}, now)
        control = {"remote_stop": decision.remote_stop, "re_enable": decision.re_enable}
        if (self.remote_stop, self.re_enable) != (decision.remote_stop, decision.re_enable):
            self._hlc_control(control, now)

    # --- what the fault rules ask of it (`fault_rules.py`) ---------------------------------------

    def can_fault(self, cause: OracleCause, active: bool, now: float) -> None:
        """A CAN-bound fault begins or ends: beginning away from CAN, it refuses an arming into
        CAN and RC drives on. The computer falling silent may catch a remote stop it was asked
        for before any ControlCommand frame carried it: that one arrives when it sends again."""
        if active and cause in CAN_SILENT:
            self._unsent_remote_stop(now)
        if self.oracle.switch is CAN or not active:
            self.oracle.fault(cause, active, now)
        else:
            self.oracle.fault_elsewhere(cause, now)

    def _unsent_remote_stop(self, now: float) -> None:
        """A remote stop asked for less than a ControlCommand period (and its frame) ago may not
        have gone out before the silence (found by tests/system/test_sequences.py: a stop asked
        at 0.944 s and the computer silent at 0.959 s, no frame between: the oracle demanded a
        stop no frame had asked for). It may still have gone out, so it is withdrawn as a fault
        that may have passed unseen: allowed, not demanded, and asked again by `can_back`."""
        faults = self.oracle.faults
        began = faults.began.get(OracleCause.REMOTE_STOP)
        if began is None or OracleCause.REMOTE_STOP not in faults:
            return
        if now - began[0] < faults.unnoticed_s(OracleCause.REMOTE_STOP):
            self.oracle.fault(OracleCause.REMOTE_STOP, False, now)

    def can_back(self, cause: OracleCause, now: float) -> None:
        self.can_fault(cause, False, now)
        if self.remote_stop and not self.oracle.faults.any_of(CAN_SILENT):
            self.oracle.fault(
                OracleCause.REMOTE_STOP, True, now
            )  # a request made while silent arrives

    def second_sender(self, frames: int, keyed: bool, now: float) -> None:
        """A second sender on the movement id. The id has one (`SimWorld.impostors`): a new
        start takes it over, so the frames of one before it stop now."""
        self.sender_started_s = now
        if self.authenticated and not keyed:  # its frames never verify: no effect of its own
            if self.harmful_sender:
                self.harmful_sender = False
                self.can_fault(OracleCause.CAN_IMPOSTOR, False, now)
            return
        self.harmful_sender = True
        self.can_fault(OracleCause.CAN_IMPOSTOR, True, now)
        # Over when its last frame is sent: the controller may trust the id again soon after
        # (a window of good frames), and the oracle must never think a fault lasts longer.
        end_s = now + frames * IMPOSTOR_PERIOD_S

        def over() -> None:
            if self.sender_started_s == now:  # not taken over since: these were its last frames
                self.harmful_sender = False
                self.can_fault(OracleCause.CAN_IMPOSTOR, False, end_s)

        self.clock.call_at(end_s, over)

    def dac_restored(self, now: float) -> None:
        self.oracle.fault(OracleCause.DAC_FAIL, False, now)
        self.oracle.fault(OracleCause.DAC_SLOW, False, now)
        self.oracle.slow_writes(0.0)

    def slow_dac(self, transfer_s: float, now: float) -> None:
        """Every DAC transfer crawls: one within the file's budget delays no stop past its
        promise (the deadlines already allow for the transfers); one past it may make each pass
        that writes the DAC that much longer; one slower than any robot file's budget is a
        fault (category 0)."""
        oracle = self.oracle
        legal = transfer_s <= oracle.timing.dac_transfer_s
        oracle.slow_writes(0.0 if legal else DAC_TRANSFERS_PER_PASS * transfer_s)
        if transfer_s > SLOW_TRANSFER_S:
            oracle.hang(now, now + oracle.timing.driving_period_s + transfer_s)
            oracle.fault(OracleCause.DAC_SLOW, True, now)
        else:  # ordinary transfers again: a crawl before is over (its latch is the switch's)
            oracle.fault(OracleCause.DAC_SLOW, False, now)

    def stall(self, stall_s: float, now: float) -> None:
        """The next DAC write (within one control period) hangs for `stall_s`: past the
        watchdog's limit, its poll trips."""
        timing = self.oracle.timing
        if stall_s > timing.watchdog_s:
            trips_s = now + timing.control_period_s + timing.watchdog_s + 2 * WATCHDOG_POLL_S
            self.oracle.stall(now, trips_s)
        else:
            self.oracle.hang(now, now + timing.control_period_s + stall_s)
