"""A 4 s drive on opendbc's tesla_model3_party.dbc, built with cantools' encoder.

Neither cantools' nor opendbc's repository ships a timestamped real-car log, so this builds one
from a real car's DBC: speed ramps 0 -> 72 km/h, the wheels follow, the steering sweeps +-30 deg,
torque follows the speed, and the multiplexed VCFRONT_LVPowerState alternates its two mux values.
"""

from __future__ import annotations

import contextlib
import math
import sqlite3
from collections.abc import Mapping
from pathlib import Path

import can
import cantools
from cantools.database.can import Database, Message

DATA = Path(__file__).resolve().parents[1] / "data"
TESLA_DBC = DATA / "opendbc/tesla_model3_party.dbc"
START_S = 1_700_000_000.0
DURATION_S = 4.0
PERIOD_S = 0.02


def database() -> Database:
    loaded = cantools.database.load_file(TESLA_DBC)
    assert isinstance(loaded, Database)
    return loaded


def speed_kph(time_s: float) -> float:
    return 18.0 * time_s


def steering_deg(time_s: float) -> float:
    return 30.0 * math.sin(2 * math.pi * time_s / DURATION_S)


def _encode(message: Message, changes: Mapping[str, float], first_byte: int = 0) -> bytes:
    """Every signal of the message (of the mux value in `first_byte`) at zero raw, then changes."""
    zero = bytes([first_byte]) + bytes(message.length - 1)
    values = message.decode(zero, decode_choices=False)
    assert isinstance(values, dict)
    data: bytes = message.encode({**values, **changes}, strict=False)
    return data


def frames() -> list[can.Message]:
    loaded = database()
    speed = loaded.get_message_by_name("DI_speed")
    wheels = loaded.get_message_by_name("ESP_wheelSpeeds")
    steering = loaded.get_message_by_name("SCCM_steeringAngleSensor")
    torque = loaded.get_message_by_name("DI_torque")
    power = loaded.get_message_by_name("VCFRONT_LVPowerState")
    out: list[can.Message] = []
    for step in range(round(DURATION_S / PERIOD_S)):
        time_s = step * PERIOD_S
        kph = speed_kph(time_s)
        payloads = [
            (speed, _encode(speed, {"DI_vehicleSpeed": kph, "DI_speedCounter": step % 16})),
            (wheels, _encode(wheels, {f"ESP_wheelSpeed{w}": kph for w in ("FrL", "FrR")})),
            (steering, _encode(steering, {"SCCM_steeringAngle": steering_deg(time_s)})),
            (torque, _encode(torque, {"DI_torqueActual": 10.0 * time_s, "DI_axleSpeed": 40 * kph})),
        ]
        if step % 5 == 0:
            index = step // 5 % 2
            changes = {"VCFRONT_LVPowerStateIndex": index, "VCFRONT_vehiclePowerState": 3}
            payloads.append((power, _encode(power, changes, first_byte=index)))
        out += [
            can.Message(
                timestamp=START_S + time_s + 0.001 * offset,
                arbitration_id=message.frame_id,
                is_extended_id=False,
                data=data,
                channel="can0",
            )
            for offset, (message, data) in enumerate(payloads)
        ]
    return out


def write(path: Path) -> Path:
    """The drive in any format python-can writes (by suffix); returns `path`.

    `.db` is written in python-can's SqliteWriter table layout directly: the writer (4.6) drops
    the frames still queued in its thread when stopped.
    """
    if path.suffix == ".db":
        rows = [
            (m.timestamp, m.arbitration_id, m.is_extended_id, False, False, m.dlc, bytes(m.data))
            for m in frames()
        ]
        with contextlib.closing(sqlite3.connect(path)) as connection, connection:
            connection.execute(
                "CREATE TABLE messages (ts REAL, arbitration_id INTEGER, extended INTEGER,"
                " remote INTEGER, error INTEGER, dlc INTEGER, data BLOB)"
            )
            connection.executemany("INSERT INTO messages VALUES (?, ?, ?, ?, ?, ?, ?)", rows)
        return path
    with can.Logger(str(path)) as logger:
        for message in frames():
            logger.on_message_received(message)
    return path
