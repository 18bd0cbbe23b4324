"""The ErrorReport's part of albert.dbc, derived from ``ErrorFlag``: one 1-bit signal per flag.

Each flag is a signal named as the flag, at the bit of its value, with its ``DESCRIPTIONS``
sentence as comment, so cantools, SavvyCAN or CANoe show ``RC_TIMEOUT: 1`` rather than a 64-bit
number. albert.dbc holds the rendered text and a test holds the file to ``message_block`` and
``comment_lines``; after appending a flag, ``python -m bywire.protocol.flag_signals`` prints both
to paste into the file. Pure.
"""

from __future__ import annotations

from bywire.error_flags import DESCRIPTIONS, ErrorFlag

ERROR_REPORT_ID = 0x201
ERROR_REPORT_LENGTH = 8  # bytes: room for 64 flags, so appending one never changes the length


def flag_bit(flag: ErrorFlag) -> int:
    """The bit a flag's signal sits at: the position of its value's one set bit."""
    return int(flag).bit_length() - 1


def flags_in_order() -> tuple[ErrorFlag, ...]:
    """Every flag, lowest bit first."""
    return tuple(sorted(ErrorFlag, key=flag_bit))


def message_comment() -> str:
    """The ErrorReport's own comment: what its signals are and which bits are reserved."""
    first_reserved = flag_bit(flags_in_order()[-1]) + 1
    last = 8 * ERROR_REPORT_LENGTH - 1
    return (
        "Error flags: one 1-bit signal per flag, named as the flag and set while it is up "
        f"(bywire.error_flags); bits {first_reserved}-{last} are reserved and sent as 0. "
        "All 0 means no error."
    )


def message_block(frame_id: int = ERROR_REPORT_ID) -> str:
    """The ``BO_`` line and one ``SG_`` line per flag, as they stand in albert.dbc."""
    lines = [f"BO_ {frame_id} ErrorReport: {ERROR_REPORT_LENGTH} BYWIRE"]
    lines += [
        f' SG_ {flag.name} : {flag_bit(flag)}|1@1+ (1,0) [0|1] "" HLC' for flag in flags_in_order()
    ]
    return "\n".join(lines) + "\n"


def comment_lines(frame_id: int = ERROR_REPORT_ID) -> str:
    """The message's ``CM_ BO_`` line and one ``CM_ SG_`` line per flag, as in albert.dbc."""
    lines = [f'CM_ BO_ {frame_id} "{message_comment()}";']
    lines += [
        f'CM_ SG_ {frame_id} {flag.name} "{DESCRIPTIONS[flag]}";' for flag in flags_in_order()
    ]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(message_block() + "\n" + comment_lines(), end="")
