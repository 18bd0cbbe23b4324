"""Digital outputs through libgpiod v2: lines by name or offset, requested low from the start.

Every line of one chip is requested in one request whose settings already say "output, inactive",
so the kernel switches the pin to an output at the low (safe) level: no glitch at start-up
(R-SAFE-START). The inputs (the E-stop's line) are requested in the same request as inputs with
the pull-down on, so an open circuit (a press, a broken wire, nothing connected) reads low.
A chip is given as a label (`pinctrl-bcm2711`), a name (`gpiochip0`) or a path.
"""

from __future__ import annotations

import contextlib
import errno
import logging
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

import gpiod

from bywire.errors import HardwareError
from bywire.hal.linux.device_errors import device_error, reason

CONSUMER = "bywire"
NO_INTERRUPT = frozenset({errno.ENODEV, errno.ENXIO})
"""What gpiolib-cdev answers an edge-detection request on a line without an interrupt."""
log = logging.getLogger(__name__)
MISSING_HINT = "check gpio_chip (`gpiodetect` lists the chips and their labels)"


@dataclass(frozen=True, slots=True)
class LineSpec:
    """One output: the configuration key (for messages), its chip and its line name or offset."""

    key: str
    chip: str
    line: str | int


def find_gpio_chip(dev_root: Path, spec: str) -> Path:
    """The character device of chip `spec` (path, name or label); HardwareError otherwise."""
    given = Path(spec)
    if given.is_absolute():
        return given
    if (dev_root / spec).exists():
        return dev_root / spec
    found: list[str] = []
    for path in sorted(dev_root.glob("gpiochip*")):
        label = _label(path)
        if label == spec:
            return path
        found.append(f"{path.name} = {label}")
    shown = ", ".join(found) or "none"
    raise HardwareError(f"GPIO: no chip {spec!r} under {dev_root} (found: {shown}): {MISSING_HINT}")


def _label(path: Path) -> str:
    if not gpiod.is_gpiochip_device(str(path)):
        return "?"
    try:
        with gpiod.Chip(str(path)) as chip:
            return chip.get_info().label
    except OSError:
        return "?"


class GpiodLine:
    """A `DigitalOut` on one line of a request."""

    def __init__(self, request: gpiod.LineRequest, offset: int, key: str) -> None:
        self._request, self._offset, self.key = request, offset, key

    def set(self, level: bool) -> None:
        value = gpiod.line.Value.ACTIVE if level else gpiod.line.Value.INACTIVE
        try:
            self._request.set_value(self._offset, value)
        except (OSError, gpiod.RequestReleasedError) as error:
            raise HardwareError(f"GPIO {self.key}: cannot set ({reason(error)})") from error


class GpiodInput:
    """A `DigitalIn` on one line of a request (pulled down: an open circuit reads low), with
    edge events on: a falling edge since the last read reads low, however short the low was,
    so a press between two reads is not missed. On a chip whose lines have no interrupt
    (`edges` False) the level alone is read."""

    def __init__(
        self, request: gpiod.LineRequest, offset: int, key: str, *, edges: bool = True
    ) -> None:
        self._request, self._offset, self.key = request, offset, key
        self.edges = edges

    def get(self) -> bool:
        try:
            fell = False
            if self.edges and self._request.wait_edge_events(
                0
            ):  # one buffer a read: the rest, the next
                for event in self._request.read_edge_events():
                    fell |= event.event_type is gpiod.EdgeEvent.Type.FALLING_EDGE
            return not fell and self._request.get_value(self._offset) == gpiod.line.Value.ACTIVE
        except (OSError, gpiod.RequestReleasedError) as error:
            raise HardwareError(f"GPIO {self.key}: cannot read ({reason(error)})") from error


class GpiodOutputs:
    """Every output line, keyed like `lines`, requested low; `close()` drives them low. The
    `inputs` (keyed alike) are requested beside them, pulled down, as `GpiodInput`s."""

    def __init__(
        self,
        lines: Mapping[str, LineSpec],
        dev_root: Path = Path("/dev"),
        inputs: Mapping[str, LineSpec] | None = None,
    ) -> None:
        self._requests: list[tuple[gpiod.LineRequest, tuple[int, ...]]] = []  # with its outputs
        self.lines: dict[str, GpiodLine] = {}
        self.inputs: dict[str, GpiodInput] = {}
        self._input_names = frozenset(inputs or {})
        by_chip: dict[Path, dict[str, LineSpec]] = {}
        for name, spec in {**lines, **(inputs or {})}.items():
            by_chip.setdefault(find_gpio_chip(dev_root, spec.chip), {})[name] = spec
        try:
            for path, specs in by_chip.items():
                self._request_chip(path, specs)
        except BaseException:
            self.close()
            raise

    def close(self) -> None:
        """Every line low, then released; safe to call again."""
        requests, self._requests = self._requests, []
        for request, outputs in requests:
            # A chip that is gone leaves its pins to their pull-downs. Only the outputs: the
            # kernel refuses a set that names an input, and would then set none of them.
            with contextlib.suppress(OSError, gpiod.RequestReleasedError):
                if outputs:
                    request.set_values(dict.fromkeys(outputs, gpiod.line.Value.INACTIVE))
            request.release()

    def _settings(
        self, offsets: Mapping[str, int], *, edges: bool = True
    ) -> dict[Iterable[int | str] | int | str, gpiod.LineSettings | None]:
        """Outputs low; inputs pulled down, with edge events unless `edges` is False."""
        outs = tuple(offset for name, offset in offsets.items() if name not in self._input_names)
        ins = tuple(offset for name, offset in offsets.items() if name in self._input_names)
        settings: dict[Iterable[int | str] | int | str, gpiod.LineSettings | None] = {}
        if outs:
            settings[outs] = gpiod.LineSettings(
                direction=gpiod.line.Direction.OUTPUT, output_value=gpiod.line.Value.INACTIVE
            )
        if ins:
            settings[ins] = gpiod.LineSettings(
                direction=gpiod.line.Direction.INPUT,
                bias=gpiod.line.Bias.PULL_DOWN,
                edge_detection=gpiod.line.Edge.BOTH if edges else gpiod.line.Edge.NONE,
            )
        return settings

    def _request_chip(self, path: Path, specs: Mapping[str, LineSpec]) -> None:
        try:
            chip = gpiod.Chip(str(path))
        except OSError as error:
            raise device_error(
                "GPIO", str(path), error, group="gpio", missing=MISSING_HINT
            ) from error
        with chip:
            offsets = {name: _offset(chip, path, spec) for name, spec in specs.items()}
            _check_distinct(offsets, specs, path)
            request, edges = self._request(chip, path, offsets, specs)
        outputs = tuple(offset for name, offset in offsets.items() if name not in self._input_names)
        self._requests.append((request, outputs))
        for name, offset in offsets.items():
            if name in self._input_names:
                self.inputs[name] = GpiodInput(request, offset, specs[name].key, edges=edges)
            else:
                self.lines[name] = GpiodLine(request, offset, specs[name].key)

    def _request(
        self,
        chip: gpiod.Chip,
        path: Path,
        offsets: Mapping[str, int],
        specs: Mapping[str, LineSpec],
    ) -> tuple[gpiod.LineRequest, bool]:
        """The chip's request, and whether its inputs have edge events: a chip whose lines have
        no interrupt (the kernel answers ENODEV or ENXIO) has its inputs read by level alone,
        with a warning naming them: a low shorter than a control period may then pass unseen
        (an E-stop button latches: a press is held until it is reset)."""
        inputs = [specs[name].key for name in offsets if name in self._input_names]
        try:
            return chip.request_lines(config=self._settings(offsets), consumer=CONSUMER), True
        except OSError as error:
            if not inputs or error.errno not in NO_INTERRUPT:
                raise device_error(
                    "GPIO", str(path), error, group="gpio", missing=MISSING_HINT
                ) from error
        log.warning(
            "GPIO %s: %s gives no edge events (its lines have no interrupt): read by level once"
            " a pass, a press shorter than a control period may pass unseen",
            ", ".join(inputs),
            path,
        )
        try:
            settings = self._settings(offsets, edges=False)
            return chip.request_lines(config=settings, consumer=CONSUMER), False
        except OSError as error:
            raise device_error(
                "GPIO", str(path), error, group="gpio", missing=MISSING_HINT
            ) from error


def _offset(chip: gpiod.Chip, path: Path, spec: LineSpec) -> int:
    try:
        return chip.line_offset_from_id(spec.line)
    except (OSError, ValueError) as error:
        raise HardwareError(
            f"GPIO {spec.key}: no line {spec.line!r} on {path} ({reason(error)}):"
            " check the name with `gpioinfo` or give an offset"
        ) from error


def _check_distinct(offsets: Mapping[str, int], specs: Mapping[str, LineSpec], path: Path) -> None:
    seen: dict[int, str] = {}
    for name, offset in offsets.items():
        if offset in seen:
            raise HardwareError(
                f"GPIO {seen[offset]} and {specs[name].key} are both line {offset} of {path}:"
                " give each its own line"
            )
        seen[offset] = specs[name].key
