"""The cantools-generated C compiles warning-free and packs the very bytes the Python codec does."""

from __future__ import annotations

import random
import shutil
import subprocess
from pathlib import Path

import pytest

from bywire.cli.dbc import write_c_sources
from bywire.error_flags import ErrorFlag
from bywire.model import (
    ControlCommand,
    ErrorReport,
    Gear,
    LightsCommand,
    MovementCommand,
    StatusReport,
    WheelSpeedReport,
)
from bywire.protocol import dbc
from bywire.protocol.dbc_values import to_raw

GCC = shutil.which("gcc")
CFLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror"]

MOVEMENT = MovementCommand(-0.1234, 0.5, 1.0, Gear.REVERSE, counter=7)
CONTROL = ControlCommand(remote_stop=True, re_enable=True, counter=15)
LIGHTS = LightsCommand(turn_left=False, turn_right=True, hazard=True, low_beam=True, counter=0)
SPEEDS = WheelSpeedReport(left_mps=-1.5, right_mps=327.67, measured_valid=True)
STATUS = StatusReport(uptime_s=123456, overrun_count=7, rc_input_age_ms=4095, can_command_age_ms=9)
ERRORS = ErrorReport(ErrorFlag.TASK_CRASHED | ErrorFlag.RC_TIMEOUT | ErrorFlag.NOT_ARMED)


@pytest.fixture
def generated(tmp_path: Path) -> Path:
    if GCC is None:
        pytest.skip("gcc not found on PATH: the generated C cannot be compiled here")
    write_c_sources(dbc.database(), tmp_path, "albert")
    return tmp_path


def _crc_of(command: MovementCommand | ControlCommand | LightsCommand) -> int:
    return dbc.encode_command(command)[1][-1]


def _test_program() -> str:
    """Fill the generated structs with raw values written out here, pack, print hex per frame."""
    return f"""
#include <stdio.h>
#include "albert.h"

static void print_frame(const uint8_t *data, int size) {{
    for (int i = 0; i < size; i++) printf("%02x", data[i]);
    printf("\\n");
}}

int main(void) {{
    uint8_t buffer[8];
    struct albert_movement_command_t movement = {{
        .steering_norm = -1234, .throttle_norm = 5000, .brake_norm = 10000,
        .counter = 7, .gear = ALBERT_MOVEMENT_COMMAND_GEAR_REVERSE_CHOICE,
        .crc = {_crc_of(MOVEMENT)}u }};
    print_frame(buffer, albert_movement_command_pack(buffer, &movement, sizeof buffer));
    struct albert_control_command_t control = {{
        .remote_stop = 1, .re_enable = 1, .counter = 15, .crc = {_crc_of(CONTROL)}u }};
    print_frame(buffer, albert_control_command_pack(buffer, &control, sizeof buffer));
    struct albert_lights_command_t lights = {{
        .turn_left = 0, .turn_right = 1, .hazard = 1, .low_beam = 1, .counter = 0,
        .crc = {_crc_of(LIGHTS)}u }};
    print_frame(buffer, albert_lights_command_pack(buffer, &lights, sizeof buffer));
    struct albert_wheel_speed_report_t speeds = {{
        .left_mps = albert_wheel_speed_report_left_mps_encode(-1.5),
        .right_mps = 32767, .measured_valid = 1 }};
    print_frame(buffer, albert_wheel_speed_report_pack(buffer, &speeds, sizeof buffer));
    struct albert_status_report_t status = {{
        .uptime_s = 123456u, .overrun_count = 7u, .rc_input_age_ms = 4095u,
        .can_command_age_ms = 9u }};
    print_frame(buffer, albert_status_report_pack(buffer, &status, sizeof buffer));
    struct albert_error_report_t errors = {{ .task_crashed = 1, .rc_timeout = 1, .not_armed = 1 }};
    print_frame(buffer, albert_error_report_pack(buffer, &errors, sizeof buffer));
    return 0;
}}
"""


ENCODE_PROGRAM = """
#include <stdio.h>
#include "albert.h"

int main(void) {
    double value;
    while (scanf("%lf", &value) == 1) {
        printf("%d %d %d\\n",
               albert_movement_command_steering_norm_encode(value),
               albert_movement_command_throttle_norm_encode(value < 0 ? -value : value),
               albert_wheel_speed_report_left_mps_encode(value));
    }
    return 0;
}
"""


def _physical_values() -> list[float]:
    """Values near every rounding decision: decimal half steps, literals, and random ones."""
    half_steps = [k * 0.00005 for k in range(-19999, 20000, 1234)]
    literals = [0.0, -0.0, 0.1234, -0.1234, 0.0007, 0.99995, -0.99995, 1.0, -1.0, 0.015, -0.015]
    generator = random.Random(20240521)
    return half_steps + literals + [generator.uniform(-1.0, 1.0) for _ in range(300)]


def _gcc(*arguments: str | Path, cwd: Path) -> None:
    result = subprocess.run(
        [str(GCC), *CFLAGS, *map(str, arguments)],
        cwd=cwd,
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr


def _answers(program: Path, lines: list[str]) -> list[str]:
    """A compiled test program's output lines for these input lines."""
    done = subprocess.run(
        [str(program)], input="\n".join(lines) + "\n", capture_output=True, text=True, check=True
    )
    return done.stdout.splitlines()


def test_generated_c_compiles_without_warnings(generated: Path) -> None:
    _gcc("-c", "albert.c", "-o", "albert.o", cwd=generated)
    header = (generated / "albert.h").read_text(encoding="utf-8")
    assert "#define ALBERT_MOVEMENT_COMMAND_FRAME_ID (0x101u)" in header
    assert "#define ALBERT_MOVEMENT_COMMAND_LENGTH (8u)" in header
    assert "albert_movement_command_steering_norm_encode(double value)" in header


def test_generated_pack_matches_the_python_encoder(generated: Path) -> None:
    (generated / "pack_test.c").write_text(_test_program(), encoding="utf-8")
    _gcc("pack_test.c", "albert.c", "-o", "pack_test", "-lm", cwd=generated)
    output = subprocess.run(
        [str(generated / "pack_test")], capture_output=True, text=True, check=True
    ).stdout.split()
    expected = [dbc.encode_command(command)[1].hex() for command in (MOVEMENT, CONTROL, LIGHTS)]
    expected += [dbc.encode_report(report)[1].hex() for report in (SPEEDS, STATUS, ERRORS)]
    assert output == expected


def test_generated_encoders_round_like_the_python_codec(generated: Path) -> None:
    (generated / "encode_test.c").write_text(ENCODE_PROGRAM, encoding="utf-8")
    _gcc("encode_test.c", "albert.c", "-o", "encode_test", "-lm", cwd=generated)
    values = _physical_values()
    output = subprocess.run(
        [str(generated / "encode_test")],
        input="\n".join(map(repr, values)),
        capture_output=True,
        text=True,
        check=True,
    ).stdout.splitlines()
    movement = dbc.database().get_message_by_name("MovementCommand")
    steering, throttle = (
        movement.get_signal_by_name(n) for n in ("steering_norm", "throttle_norm")
    )
    left = dbc.database().get_message_by_name("WheelSpeedReport").get_signal_by_name("left_mps")
    expected = [
        f"{to_raw(steering, v)} {to_raw(throttle, abs(v))} {to_raw(left, v)}" for v in values
    ]
    assert output == expected


# --- the CRC-8 and rolling-counter helper written beside the generated code -------------------

PROTECTION_PROGRAM = """
#include <stdio.h>
#include <string.h>
#include "albert_protection.h"

/* stdin: lines "frame_id counter hex-payload" (CRC byte zeroed); stdout: protected payloads. */
int main(void) {
    unsigned int frame_id, counter;
    char hex[17];
    while (scanf("%x %u %16s", &frame_id, &counter, hex) == 3) {
        uint8_t payload[8];
        size_t length = strlen(hex) / 2u;
        for (size_t i = 0; i < length; i++) {
            unsigned int byte;
            sscanf(hex + 2 * i, "%2x", &byte);
            payload[i] = (uint8_t)byte;
        }
        albert_protect_command(frame_id, payload, length, (uint8_t)counter);
        for (size_t i = 0; i < length; i++) printf("%02x", payload[i]);
        printf(" %d %d %d\\n",
               albert_check_command(frame_id, payload, length, ((int)counter + 15) % 16),
               albert_check_command(frame_id, payload, length, (int)counter),
               albert_check_command(frame_id + 1u, payload, length, -1));
    }
    printf("%02x\\n", albert_crc8((const uint8_t *)"123456789", 9u));
    return 0;
}
"""


def _commands() -> list[MovementCommand | ControlCommand | LightsCommand]:
    generator = random.Random(13)
    commands: list[MovementCommand | ControlCommand | LightsCommand] = []
    for counter in range(16):
        norm = round(generator.uniform(-1.0, 1.0), 4)
        commands += [
            MovementCommand(norm, abs(norm), 1.0 - abs(norm), Gear.FORWARD, counter),
            ControlCommand(
                remote_stop=counter % 2 == 0, re_enable=counter % 3 == 0, counter=counter
            ),
            LightsCommand(counter % 2 == 1, False, counter % 5 == 0, True, counter),
        ]
    return commands


def test_the_c_protection_gives_the_python_side_bytes(generated: Path) -> None:
    (generated / "protect_test.c").write_text(PROTECTION_PROGRAM, encoding="utf-8")
    _gcc("protect_test.c", "albert_protection.c", "-o", "protect_test", cwd=generated)
    commands = _commands()
    frames = [dbc.encode_command(command) for command in commands]
    # The C side gets the payload with counter nibble and CRC cleared, and fills both in.
    lines = [
        f"{frame_id:x} {command.counter} {(payload[:-2] + bytes([payload[-2] & 0xF0, 0])).hex()}"
        for command, (frame_id, payload) in zip(commands, frames, strict=True)
    ]
    output = _answers(generated / "protect_test", lines)
    assert output[-1] == "4b"  # CRC-8/SAE-J1850's check value
    # OK after the previous counter, BAD_COUNTER on a repeat, BAD_CRC under another id
    assert output[:-1] == [f"{payload.hex()} 0 -3 -2" for _frame_id, payload in frames]


# --- the SecOC signing helper: AES-128, CMAC, the cryptographic PDU ------------------------------

SECOC_PROGRAM = """
#include <stdio.h>
#include <string.h>
#include "albert_secoc.h"

static void read_hex(const char *hex, uint8_t *out, size_t length) {
    for (size_t i = 0; i < length; i++) {
        unsigned int byte;
        sscanf(hex + 2 * i, "%2x", &byte);
        out[i] = (uint8_t)byte;
    }
}

/* stdin: "cmac KEY MESSAGE|-" -> the 16-byte CMAC; "pdu KEY ID PAYLOAD FRESHNESS" -> 8 bytes. */
int main(void) {
    char kind[8], key_hex[33], text[200];
    while (scanf("%7s %32s", kind, key_hex) == 2) {
        uint8_t key[16], out[16], data[100];
        struct albert_secoc_key_t expanded;
        read_hex(key_hex, key, 16);
        albert_secoc_key_init(&expanded, key);
        if (strcmp(kind, "cmac") == 0) {
            scanf("%199s", text);
            size_t length = strcmp(text, "-") == 0 ? 0 : strlen(text) / 2;
            read_hex(text, data, length);
            albert_cmac(&expanded, data, length, out);
            for (int i = 0; i < 16; i++) printf("%02x", out[i]);
        } else if (strcmp(kind, "trip") == 0) {
            char pdu_hex[17];
            uint8_t pdu[8];
            uint32_t trip = 0xFFFFFFFFu;
            scanf("%199s %16s", text, pdu_hex);
            read_hex(text, data, 7);
            read_hex(pdu_hex, pdu, 8);
            if (albert_secoc_trip_verify(&expanded, data, pdu, &trip)) {
                printf("trip %lu", (unsigned long)trip);
            } else {
                printf("refused %lx", (unsigned long)trip);
            }
        } else if (strcmp(kind, "sign") == 0) {
            unsigned int frame_id;
            unsigned long trip, counter;
            scanf("%x %199s %lx %lx", &frame_id, text, &trip, &counter);
            size_t length = strlen(text) / 2;
            read_hex(text, data, length);
            uint64_t freshness = albert_secoc_freshness((uint32_t)trip, (uint32_t)counter);
            albert_secoc_authenticate(&expanded, frame_id, data, length, freshness, out);
            for (int i = 0; i < 8; i++) printf("%02x", out[i]);
        } else {
            unsigned int frame_id;
            unsigned long long freshness;
            scanf("%x %199s %llx", &frame_id, text, &freshness);
            size_t length = strlen(text) / 2;
            read_hex(text, data, length);
            albert_secoc_authenticate(&expanded, frame_id, data, length, freshness, out);
            printf("%03x ", (unsigned int)albert_secoc_auth_id(frame_id));
            for (int i = 0; i < 8; i++) printf("%02x", out[i]);
        }
        printf("\\n");
    }
    return 0;
}
"""

RFC4493_KEY = "2b7e151628aed2a6abf7158809cf4f3c"
RFC4493_MESSAGE = (
    "6bc1bee22e409f96e93d7e117393172aae2d8a571e03ac9c9eb76fac45af8e51"
    "30c81c46a35ce411e5fbc1191a0a52eff69f2445df4f9b17ad2b417be66c3710"
)
RFC4493_MACS = {
    0: "bb1d6929e95937287fa37d129b756746",
    16: "070a16b46b4d4144f79bdd9dd04a287c",
    40: "dfa66747de9ae63030ca32611497c827",
    64: "51f0bebf7e3b9d92fc49741779363cfe",
}


def test_the_c_secoc_helper_matches_rfc_4493_and_the_python_side(generated: Path) -> None:
    from bywire.protocol import secoc  # noqa: PLC0415

    (generated / "secoc_test.c").write_text(SECOC_PROGRAM, encoding="utf-8")
    _gcc("secoc_test.c", "albert_secoc.c", "-o", "secoc_test", cwd=generated)
    lines = [
        f"cmac {RFC4493_KEY} {RFC4493_MESSAGE[: 2 * length] or '-'}" for length in RFC4493_MACS
    ]
    generator = random.Random(15)
    cases = []
    for command in _commands():
        key = generator.randbytes(16)
        frame_id, payload = dbc.encode_command(command)
        freshness = generator.choice([0, 1, 0xFFFF, 0x1_0000, generator.getrandbits(64)])
        cases.append((key, frame_id, payload, freshness))
        lines.append(f"pdu {key.hex()} {frame_id:x} {payload.hex()} {freshness:x}")
    output = _answers(generated / "secoc_test", lines)
    assert output[: len(RFC4493_MACS)] == list(RFC4493_MACS.values())
    expected = [
        f"{secoc.auth_id(frame_id):03x} "
        + secoc.encode_authenticator(secoc.SecocKey(key), frame_id, payload, freshness).hex()
        for key, frame_id, payload, freshness in cases
    ]
    assert output[len(RFC4493_MACS) :] == expected


def test_the_c_helper_takes_only_a_verified_trip_and_signs_in_it(generated: Path) -> None:
    """The sender's side in C against the controller's Python side: the announcement verifies
    in C (and not when damaged or made with another key), and a command the C helper signs with
    that trip and a message counter is accepted by the controller's receiver."""
    from bywire.protocol import secoc  # noqa: PLC0415
    from bywire.security.session import SecocReceiver  # noqa: PLC0415

    (generated / "secoc_test.c").write_text(SECOC_PROGRAM, encoding="utf-8")
    _gcc("secoc_test.c", "albert_secoc.c", "-o", "secoc_test", cwd=generated)
    key = bytes(range(16))
    trip = 0xFFFF_0001
    receiver = SecocReceiver(secoc.SecocKey(key), trip, dbc.command_ids())
    (_, payload), (_, pdu) = receiver.announcement
    other = SecocReceiver(secoc.SecocKey(bytes(16)), trip, dbc.command_ids()).announcement
    frame_id, command = dbc.encode_command(_commands()[0])
    lines = [
        f"trip {key.hex()} {payload.hex()} {pdu.hex()}",
        f"trip {key.hex()} {payload[:3].hex()}00{payload[4:].hex()} {pdu.hex()}",  # changed
        f"trip {key.hex()} {other[0][1].hex()} {other[1][1].hex()}",  # another key's
        f"sign {key.hex()} {frame_id:x} {command.hex()} {trip:x} 1",
    ]
    output = _answers(generated / "secoc_test", lines)
    assert output[:3] == [f"trip {trip}", "refused ffffffff", "refused ffffffff"]
    receiver.offer(frame_id, command, 0.0)
    outcome = receiver.offer(secoc.auth_id(frame_id), bytes.fromhex(output[3]), 0.001)
    assert outcome.verified == (frame_id, command)
