"""The whole simulated robot on one clock: the controller's ``Hardware`` and the scenario's handles.

``hardware`` is all the controller sees (the same bundle the Linux backend gives). Everything
else is for scenarios and tools: the RC transmitter, the higher-level computer, the bus with its
log and faults, the DAC, the PWM channels and GPIO lines with their histories, and the vehicle.
Randomness (which byte a corrupted IBUS frame flips) comes from ``seed``, so runs reproduce.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from bywire.command_table import COMMAND_TYPES
from bywire.config import DacOutput
from bywire.control.rc_mapping import RcMapping
from bywire.hal.hardware import OUTPUT_NAMES, DigitalOutputs, Hardware, sensors_fitted
from bywire.hal.ports import Clock
from bywire.hal.simulated.can_bus import DEFAULT_BITRATE_BPS, SimCanBus
from bywire.hal.simulated.can_port import SimCanPort
from bywire.hal.simulated.dac import SimDac6574
from bywire.hal.simulated.estop import SimEstopButton
from bywire.hal.simulated.gpio_pwm import SimDigitalOut, SimPwmChannel
from bywire.hal.simulated.hlc import SimHigherLevelComputer
from bywire.hal.simulated.impostor import SimImpostor, impostor_node
from bywire.hal.simulated.rc_transmitter import SimRcTransmitter
from bywire.hal.simulated.timers import SimClock
from bywire.hal.simulated.uart import SimUart
from bywire.hal.simulated.vehicle import (
    SimPressureSensor,
    SimSteeringEncoder,
    SimVehicle,
    SimWheelSpeedSensor,
    VehicleWiring,
)
from bywire.hal.simulated.vehicle_model import VehicleConfig
from bywire.model import Command, MovementCommand
from bywire.protocol import dbc, ibus

if TYPE_CHECKING:
    from bywire.config import RobotConfig

STEERING_PERIOD_S = 0.020
DEFAULT_HYDROBRAKE_PERIOD_S = 0.001
CONTROLLER_NODE = "bywire"
SOCKETCAN_TX_QUEUE = 10  # the controller is a Linux SocketCAN node: txqueuelen defaults to 10
HLC_NODE = "hlc"


class WorldClock(SimClock, Clock, Protocol):
    """A clock the simulator schedules on and the controller waits on (both our clocks)."""

    def advance(self, duration_s: float) -> None:
        """Run every timer in the next `duration_s` (a port stalled inside a write)."""
        ...


@dataclass(frozen=True, slots=True)
class SimPwm:
    """The two PWM outputs."""

    steering: SimPwmChannel
    hydrobrake: SimPwmChannel


@dataclass(slots=True)
class SimWorld:
    """Every simulated part, wired together; build it with ``SimWorld.create``."""

    clock: WorldClock
    hardware: Hardware
    bus: SimCanBus
    controller_can: SimCanPort
    hlc: SimHigherLevelComputer
    uart: SimUart
    rc: SimRcTransmitter
    dac: SimDac6574
    pwm: SimPwm
    gpio: dict[str, SimDigitalOut]
    vehicle: SimVehicle
    wheel_sensor: SimWheelSpeedSensor
    pressure_sensor: SimPressureSensor
    steering_encoder: SimSteeringEncoder
    impostors: dict[type[Command], SimImpostor]  # a second sender on each command id
    estop: SimEstopButton  # read by the controller only where the robot file wires an E-stop

    @property
    def impostor(self) -> SimImpostor:
        """The second sender on the movement id (the one that asks for throttle)."""
        return self.impostors[MovementCommand]

    @property
    def throttle_volts(self) -> float:
        """The DAC volts on the motor controllers' throttle input, wherever the robot wires it."""
        return self.vehicle.wiring.throttle_volts()

    @property
    def regen_volts(self) -> float:
        """The DAC volts on the motor controllers' regenerative brake input."""
        return self.vehicle.wiring.regen_volts()

    @classmethod
    def create(
        cls,
        clock: WorldClock,
        *,
        drive_dac: DacOutput | None = None,
        hydrobrake_period_s: float = DEFAULT_HYDROBRAKE_PERIOD_S,
        seed: int = 0,
        rc_mapping: RcMapping | None = None,
        rc_frame_period_s: float = ibus.FRAME_PERIOD_S,
        can_bitrate_bps: int = DEFAULT_BITRATE_BPS,
        vehicle_config: VehicleConfig | None = None,
        bus_log_limit: int | None = 20_000,
        sensors: bool = True,
        estop: bool = False,
    ) -> SimWorld:
        """Build the robot; nothing runs until ``start()``.

        The controller's CAN port wakes the clock on every frame and its acceptance filter passes
        the command ids only, like the hardware filter the thesis' controller sets up. Its
        transmit queue is SocketCAN's (10 frames), not bxCAN's three mailboxes: a full set of
        six reports fits, and an unplugged bus still fills it within two report periods.
        """
        bus = SimCanBus(clock, bitrate_bps=can_bitrate_bps, log_limit=bus_log_limit)
        controller_can = bus.attach(
            CONTROLLER_NODE,
            True,
            accept_ids=dbc.received_ids(),
            tx_mailboxes=SOCKETCAN_TX_QUEUE,
        )
        hlc = SimHigherLevelComputer(clock, bus.attach(HLC_NODE, accept_ids=dbc.report_ids()))
        impostors = {  # a node each, so a second sender on one id leaves another's running
            kind: SimImpostor(clock, bus.attach(impostor_node(kind), accept_ids=()), hlc)
            for kind in COMMAND_TYPES
        }
        uart = SimUart(clock)
        rc = SimRcTransmitter(
            clock, uart, period_s=rc_frame_period_s, mapping=rc_mapping, seed=seed
        )
        wired = DacOutput() if drive_dac is None else drive_dac  # `[drive.dac]`: Vref, channels
        dac = SimDac6574(clock, vref_volts=wired.vref_volts)
        dac.on_stall = clock.advance  # the robot goes on while the controller hangs in a write
        pwm = SimPwm(
            SimPwmChannel(clock, STEERING_PERIOD_S, "steering"),
            SimPwmChannel(clock, hydrobrake_period_s, "hydrobrake"),
        )
        gpio = {name: SimDigitalOut(clock, name) for name in OUTPUT_NAMES}
        wiring = VehicleWiring(
            dac,
            gpio["motors_enable"],
            gpio["motors_forward"],
            gpio["motors_reverse"],
            gpio["ebrake_release"],
            pwm.steering,
            pwm.hydrobrake,
            throttle_channel=wired.throttle_channel,
            regen_channel=wired.regen_channel,
        )
        vehicle = SimVehicle(clock, wiring, vehicle_config)
        wheel_sensor = SimWheelSpeedSensor(vehicle)
        pressure_sensor = SimPressureSensor(vehicle)
        steering_encoder = SimSteeringEncoder(vehicle)
        button = SimEstopButton()
        hardware = Hardware(
            clock=clock,
            can=controller_can,
            rc_uart=uart,
            dac=dac,
            steering_pwm=pwm.steering,
            hydrobrake_pwm=pwm.hydrobrake,
            outputs=DigitalOutputs.of(gpio),
            # Unfitted, the parts still simulate (a fault changes nothing); nothing reads them.
            wheel_speeds=wheel_sensor if sensors else None,
            hydrobrake_pressure_bar=pressure_sensor if sensors else None,
            steering_encoder_norm=steering_encoder if sensors else None,
            estop_line=button if estop else None,
        )
        return cls(
            clock,
            hardware,
            bus,
            controller_can,
            hlc,
            uart,
            rc,
            dac,
            pwm,
            gpio,
            vehicle,
            wheel_sensor,
            pressure_sensor,
            steering_encoder,
            impostors,
            button,
        )

    @classmethod
    def from_robot(
        cls, clock: WorldClock, robot: RobotConfig, *, bus_log_limit: int | None = 0
    ) -> SimWorld:
        """The simulated robot wired as a robot configuration says (DAC channels, brake PWM
        period, DAC reference, CAN bit rate, RC mapping, the sensors its backend fits, and
        `[sim]`: seed, IBUS frame period, top speed; `[vehicle]`: its geometry)."""
        return cls.create(
            clock,
            drive_dac=robot.drive.dac,
            hydrobrake_period_s=1.0 / robot.hydrobrake.pwm.frequency_hz,
            seed=robot.sim.seed,
            rc_mapping=robot.rc.mapping,
            rc_frame_period_s=robot.sim.rc_frame_period_s,
            can_bitrate_bps=robot.can.bitrate_bps,
            vehicle_config=VehicleConfig(
                top_speed_mps=robot.sim.top_speed_mps,
                wheelbase_m=robot.vehicle.wheelbase_m,
                track_m=robot.vehicle.track_m,
                max_steering_angle_rad=robot.vehicle.max_steering_angle_rad,
            ),
            bus_log_limit=bus_log_limit,
            sensors=sensors_fitted(robot.backend),
            estop=robot.estop.wired,
        )

    @property
    def sensors_fitted(self) -> bool:
        return self.hardware.wheel_speeds is not None

    def output(self, name: str) -> SimDigitalOut | SimPwmChannel:
        """A GPIO line, or the "steering" or "hydrobrake" PWM channel, by its name."""
        if name in ("steering", "hydrobrake"):
            channel: SimPwmChannel = getattr(self.pwm, name)
            return channel
        return self.gpio[name]

    def start(self, *, rc: bool = True, hlc: bool = True, vehicle: bool = True) -> None:
        """Start the transmitter, the higher-level computer and the vehicle from now."""
        if rc:
            self.rc.start()
        if hlc:
            self.hlc.start()
        if vehicle:
            self.vehicle.start()

    def stop(self) -> None:
        """Stop every simulated device (frames already on the wire still arrive)."""
        self.rc.stop()
        self.hlc.silence()
        self.vehicle.stop()
        for impostor in self.impostors.values():
            impostor.stop()
        self.bus.stop_flood()
