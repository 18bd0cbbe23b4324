"""Compare two output histories instant by instant and name the first output that differs."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from bywire.hal.tape.run_record import Output, OutputValue
from bywire.protocol import dac6574
from bywire.protocol.dac6574 import DEFAULT_VREF_VOLTS

Instant = tuple[float, list[Output]]


@dataclass(frozen=True, slots=True)
class Divergence:
    """At `time_s` output `name` was `recorded` in the record but `replayed` on replay (each the
    value after that instant's writes; None: not written yet). The same value after different
    writes (a frame sent twice, once on replay) or the same writes in another order among the
    instant's outputs differ too: `*_writes` are that output's writes at the instant, `*_order`
    the names of every write at the instant, in order."""

    time_s: float
    name: str
    recorded: OutputValue | None
    replayed: OutputValue | None
    recorded_writes: tuple[OutputValue, ...] = ()
    replayed_writes: tuple[OutputValue, ...] = ()
    recorded_order: tuple[str, ...] = ()
    replayed_order: tuple[str, ...] = ()

    def describe(self, start_s: float = 0.0, vref_volts: float = DEFAULT_VREF_VOLTS) -> str:
        recorded = show(self.recorded, self.name, vref_volts)
        replayed = show(self.replayed, self.name, vref_volts)
        head = f"first divergence at {self.time_s - start_s:.6f} s: {self.name}"
        if recorded != replayed:
            return f"{head} recorded {recorded}, replayed {replayed}"
        if self.recorded_writes != self.replayed_writes:
            return (
                f"{head} written {_writes(self.recorded_writes, self.name, vref_volts)} at"
                " that instant in the record,"
                f" {_writes(self.replayed_writes, self.name, vref_volts)} on replay"
            )
        return (
            f"{head}: the same writes, in another order among that instant's outputs"
            f" (recorded {', '.join(self.recorded_order)};"
            f" replayed {', '.join(self.replayed_order)})"
        )


def _writes(values: tuple[OutputValue, ...], name: str, vref_volts: float) -> str:
    """'2 times (1104, 1104)', '1 time (1104)', 'never'."""
    if not values:
        return "never"
    times = "1 time" if len(values) == 1 else f"{len(values)} times"
    return f"{times} ({', '.join(show(value, name, vref_volts) for value in values)})"


def show(value: OutputValue | None, name: str = "", vref_volts: float = DEFAULT_VREF_VOLTS) -> str:
    """A value as the divergence message shows it: a DAC write (`dac.<channel>`, recorded as its
    I2C frame) in volts, with the frame beside it."""
    if value is None:
        return "(not written)"
    if isinstance(value, float):
        return f"{value:.9g}"
    volts = dac_volts(value, vref_volts) if name.startswith("dac.") else None
    return str(value) if volts is None else f"{volts:.3f} V (I2C {value})"


def dac_volts(value: OutputValue, vref_volts: float = DEFAULT_VREF_VOLTS) -> float | None:
    """The volts a recorded DAC6574 write frame (hex) sets; None if it is not one."""
    try:
        _channel, code = dac6574.decode_write(bytes.fromhex(str(value)))
    except ValueError:  # FrameError is one; so is a value that is not hex
        return None
    return dac6574.volts_from_code(code, vref_volts)


def _instants(outputs: Sequence[Output]) -> list[Instant]:
    instants: list[Instant] = []
    for output in outputs:
        if instants and instants[-1][0] == output.time_s:
            instants[-1][1].append(output)
        else:
            instants.append((output.time_s, [output]))
    return instants


def _first_name(recorded: list[Output], replayed: list[Output]) -> str:
    """The output whose writes differ at one instant; if only their order differs, the first."""
    names = dict.fromkeys(o.name for o in (*recorded, *replayed))
    for name in names:
        if [o.value for o in recorded if o.name == name] != [
            o.value for o in replayed if o.name == name
        ]:
            return name
    pairs = zip(recorded, replayed, strict=False)
    return next((a.name for a, b in pairs if (a.name, a.value) != (b.name, b.value)), "")


def first_divergence(recorded: Sequence[Output], replayed: Sequence[Output]) -> Divergence | None:
    """None when both histories are identical (same instants, names, values, order)."""
    ours, theirs = _instants(recorded), _instants(replayed)
    state_recorded: dict[str, OutputValue] = {}
    state_replayed: dict[str, OutputValue] = {}
    i = j = 0
    while i < len(ours) or j < len(theirs):
        time_s = min(x[0] for x in (ours[i : i + 1] + theirs[j : j + 1]))
        a = ours[i][1] if i < len(ours) and ours[i][0] == time_s else []
        b = theirs[j][1] if j < len(theirs) and theirs[j][0] == time_s else []
        i, j = i + bool(a), j + bool(b)
        state_recorded.update((o.name, o.value) for o in a)
        state_replayed.update((o.name, o.value) for o in b)
        if [(o.name, o.value) for o in a] != [(o.name, o.value) for o in b]:
            name = _first_name(a, b)
            return Divergence(
                time_s,
                name,
                state_recorded.get(name),
                state_replayed.get(name),
                tuple(o.value for o in a if o.name == name),
                tuple(o.value for o in b if o.name == name),
                tuple(o.name for o in a),
                tuple(o.name for o in b),
            )
    return None
