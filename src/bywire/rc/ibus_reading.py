"""One IBUS stream read as the controller reads it, and what it showed: the view's state.

Bytes go through the controller's own parser (`protocol.ibus.IbusParser`: a frame with a bad
header or checksum is counted and dropped) and each intact frame through the controller's own
decoding with the robot file's calibration (`control.rc_mapping.rc_step`: bands, hysteresis, the
gear's debounce), and is added to the observations (`rc.observations`).
"""

from __future__ import annotations

from bywire.config import RobotConfig
from bywire.control.rc_mapping import RcRequest, RcStage, in_failsafe, rc_step
from bywire.protocol.ibus import IbusParser
from bywire.rc.observations import NOTHING_SEEN, Observations, observe
from bywire.rc.suggestion import Suggestion, suggest


class RcSession:
    """The parser, the decoding stage and the observations of one stream."""

    def __init__(self, config: RobotConfig) -> None:
        self.config = config
        self.mapping = config.rc.mapping
        self.parser = IbusParser()
        self.seen: Observations = NOTHING_SEEN
        self.stage = RcStage()
        self.channels: tuple[int, ...] | None = None
        """The latest intact frame's channels; None before any."""
        self.request: RcRequest | None = None
        """What the controller reads in the latest frame; None when it refuses it whole."""
        self.last_frame_s: float | None = None

    def feed(self, data: bytes, now_s: float) -> int:
        """Take the bytes that arrived by `now_s`; returns how many intact frames they ended."""
        frames = self.parser.feed(data, now_s)
        debounce_frames = self.config.supervisor.debounce_frames
        for channels in frames:
            self.seen = observe(self.seen, channels, self.mapping)
            self.stage, self.request = rc_step(self.stage, channels, self.mapping, debounce_frames)
            self.channels = channels
        if frames:
            self.last_frame_s = now_s
        return len(frames)

    @property
    def in_failsafe(self) -> bool:
        """True when the latest frame is the receiver's failsafe output."""
        return self.channels is not None and in_failsafe(self.channels, self.mapping)

    def reset(self) -> None:
        """Forget what was seen (ranges, rests); the counters and the decoding go on."""
        self.seen = NOTHING_SEEN

    def suggestion(self) -> Suggestion:
        return suggest(self.seen, self.mapping)
