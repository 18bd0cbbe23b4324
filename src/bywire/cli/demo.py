"""`bywire demo`: every codec on simulated, deliberately damaged traffic, with its result checked.

A simulated RC transmitter sweeps its sticks and switches for one second; its IBUS byte stream is
damaged the ways §4.2.3 describes and fed to the real parser in random read sizes. A simulated
higher-level computer sends movement commands, some corrupted, through the real DBC codec. The
resulting throttle goes through the real DAC6574 encoder, and the CAN bit timing of the thesis'
robot is computed. The command exits 1 if any codec does not do what it promises.
"""

from __future__ import annotations

import argparse
import math
import random
from dataclasses import dataclass

from bywire.model import Gear, MovementCommand
from bywire.protocol import bittiming, dac6574, dbc, ibus

FRAME_COUNT = 130  # one second of a FlySky receiver at one frame every 7.7 ms


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--seed", type=int, default=7, help="random seed for read sizes and noise")


def run(args: argparse.Namespace) -> int:
    rng = random.Random(args.seed)
    print(f"bywire demo: every codec on simulated, deliberately damaged traffic (seed {args.seed})")
    checks = [rc_link(rng), can_commands(), dac_frames(), bit_timing()]
    failed = checks.count(False)
    print(f"\n{len(checks) - failed} of {len(checks)} checks passed")
    return 1 if failed else 0


# --- RC link ------------------------------------------------------------------------------------


def sweep_channels(index: int) -> tuple[int, ...]:
    """Table 3 channels at frame `index`: sticks sweep, switches step through their positions."""
    phase = 2 * math.pi * index / FRAME_COUNT
    steering = round(1500 + 500 * math.sin(phase))
    throttle = round(1500 + 400 * math.sin(2 * phase))
    mode = (1000, 1500, 2000)[index * 3 // FRAME_COUNT]
    return (steering, throttle, 1500, 1500, 1500, 1000, mode, 2000, 1000) + (1500,) * 5


@dataclass
class DamagedStream:
    """The byte stream and which frames in it remain intact."""

    data: bytearray
    intact: list[tuple[int, ...]]


def damaged_stream(rng: random.Random) -> DamagedStream:
    stream = DamagedStream(bytearray(), [])
    for index in range(FRAME_COUNT):
        channels = sweep_channels(index)
        frame = bytearray(ibus.encode_frame(channels))
        match index:
            case 0:
                frame = frame[10:]  # the receiver was already talking (Figure 16)
            case 20:
                stream.data += b"\x20"
            case 40:
                stream.data += b"\x20\x40"
            case 60:
                frame[rng.randrange(2, 30)] ^= 0x10
            case 80:
                frame = frame[:17]
            case 100:
                stream.data += rng.randbytes(12)
        stream.data += frame
        if index not in (0, 60, 80):
            stream.intact.append(channels)
    return stream


def rc_link(rng: random.Random) -> bool:
    stream = damaged_stream(rng)
    parser = ibus.IbusParser()
    received: list[tuple[int, ...]] = []
    position = 0
    while position < len(stream.data):
        size = rng.randint(1, 64)
        received += parser.feed(bytes(stream.data[position : position + size]))
        position += size
    stats = parser.stats
    ok = received == stream.intact
    print("\nRC link: FlySky IBUS, 32-byte frames (thesis Table 3)")
    print(f"  sent {FRAME_COUNT} frames as {len(stream.data)} bytes in reads of 1…64 bytes")
    print("  damage: starts mid-frame, stray 20 and 20 40, a flipped bit, a cut frame, garbage")
    print(f"  parser: {stats.frames} frames, {stats.checksum_errors} checksum errors,")
    print(f"          {stats.resyncs} resyncs, {stats.skipped_bytes} bytes skipped")
    print(f"  {_verdict(ok)} every one of the {len(stream.intact)} intact frames, nothing else")
    return ok


# --- CAN commands -------------------------------------------------------------------------------


def can_commands() -> bool:
    print("\nCAN commands: albert.dbc, 4-bit counter and CRC-8/SAE-J1850 on every command")
    previous: int | None = None
    outcomes: list[str] = []
    for counter, (label, data) in enumerate(_command_frames()):
        frame_id = dbc.frame_id(MovementCommand)
        try:
            command = dbc.decode_command(frame_id, data, previous)
        except dbc.CommandRejected as rejected:
            previous = rejected.counter if rejected.counter is not None else previous
            outcomes.append(f"rejected ({rejected.reason.value})")
        else:
            previous = command.counter
            outcomes.append("accepted")
        print(f"  #{counter:<2} {label:<28} {data.hex(' ')}  {outcomes[-1]}")
    expected = ["accepted"] * 3 + [
        "rejected (bad CRC)",
        "accepted",
        "rejected (repeated or skipped counter)",
        "rejected (wrong length)",
        "accepted",
    ]
    ok = outcomes == expected
    print(f"  {_verdict(ok)} the three corrupted frames, and only those, were rejected")
    return ok


def _command_frames() -> list[tuple[str, bytes]]:
    def movement(counter: int, steering: float, throttle: float) -> bytes:
        command = MovementCommand(steering, throttle, 0.0, Gear.FORWARD, counter)
        return dbc.encode_command(command)[1]

    good = [movement(counter, 0.25 * counter - 0.5, 0.1 * counter) for counter in range(6)]
    flipped = bytearray(good[3])
    flipped[1] ^= 0x04
    return [
        ("steer -0.50 throttle 0.0", good[0]),
        ("steer -0.25 throttle 0.1", good[1]),
        ("steer +0.00 throttle 0.2", good[2]),
        ("one bit flipped in transit", bytes(flipped)),
        ("steer +0.25 throttle 0.3", good[3]),
        ("the same frame again", good[3]),
        ("cut to 7 bytes", good[4][:7]),
        ("steer +0.50 throttle 0.4", good[4]),
    ]


# --- DAC and bit timing ---------------------------------------------------------------------------


def dac_frames() -> bool:
    print("\nDAC6574 at 0x4C: throttle on channel A, 0…5 V (frame: control, MSB, LSB)")
    ok = True
    for volts in (0.0, 1.25, 2.5, 5.0, 5.5):
        conversion = dac6574.code_from_volts(volts)
        frame = dac6574.encode_write(0, conversion.code)
        channel, code = dac6574.decode_write(frame)
        ok = ok and (channel, code) == (0, conversion.code)
        note = "  clamped, and reported" if conversion.clamped else ""
        print(f"  {volts:4.2f} V -> code {conversion.code:4} -> {frame.hex(' ')}{note}")
    ok = ok and dac6574.code_from_volts(5.5).clamped and not dac6574.code_from_volts(2.5).clamped
    print(f"  {_verdict(ok)} every frame decodes back to its channel and code")
    return ok


def bit_timing() -> bool:
    rows = bittiming.solutions(48_000_000, 500_000, 0.875)
    best = next(row for row in rows if row.recommended)
    ok = (best.brp, best.tseg1, best.tseg2, best.btr) == (6, 13, 2, 0x001C0005)
    print("\nCAN bit timing: 48 MHz bxCAN clock, 500 kbit/s, 87.5 % sample point (Figure 20)")
    print(
        f"  prescaler {best.brp}, Seg 1 {best.tseg1}, Seg 2 {best.tseg2}, CAN_BTR 0x{best.btr:08x}"
    )
    print(f"  {best.ip_link_bitrate('can0')}")
    print(f"  {_verdict(ok)} the thesis' setting")
    return ok


def _verdict(ok: bool) -> str:
    return "OK:" if ok else "FAILED: expected"
