"""The frames the controller owes a RUN and a motion request (MOVJ, HOME, ZERO) after its ACK, as
state machines with no I/O (h11's shape): `feed(frame)` either accepts the frame, says what the
client must do next, or raises. The client (`protocol.client`) reads the frames and acts.

- RUN of a list of `count` poses: for each pose in order, in STEP mode first a WAIT (answered by
  the operator's GO), then its `j` packet and its `p` packet with the FLAG of its place (0 first,
  1 between, 2 last); then DONE RUN.
- MOVJ / HOME: one `j 2 0` and one `p 2 0`, then DONE. ZERO: at most one WAIT 0, then DONE.

Anything else is a `SequenceError`; an ERR is the controller's `ControllerError`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from protocol import codec
from protocol.codec import Done, Err, Joints, Message, Pose, Six, Wait
from protocol.errors import ControllerError, SequenceError

MotionVerb = Literal["MOVJ", "HOME", "ZERO"]


@dataclass(frozen=True)
class MeasuredPose:
    """What the controller reported after reaching pose `idx` of a list."""

    idx: int
    flag: int
    joints_deg: Six
    tool0: Six  # x, y, z (mm), rx, ry, rz (deg), nominal, base frame


# What `feed` tells the caller: a WAIT to answer with the operator's go-ahead, a pose to hand
# on, the request's DONE, or nothing (the frame was the first half of a pose).
Event = Wait | MeasuredPose | Done | None


class RunReplies:
    """The frames of one RUN of a loaded list of `count` poses. `operator`: the caller answers
    WAITs (STEP mode, or an AUTO run given an operator); `step`: a pose may only be reported
    after its GO."""

    def __init__(self, count: int, *, operator: bool, step: bool):
        self.count, self.operator, self.step = count, operator, step
        self.expected = 0  # the pose reported next
        self.pending: Joints | None = None  # its `j` packet, waiting for its `p` packet
        self.released = -1  # the last pose the operator's GO was sent for

    def feed(self, msg: Message) -> Event:
        if isinstance(msg, Wait):
            return self._wait(msg)
        if isinstance(msg, Joints):
            if self.pending is not None:
                raise SequenceError(f"j packet {msg.idx} repeated before its p packet")
            check_packet(msg, self.expected, self.count)
            if self.step and self.released != self.expected:
                raise SequenceError(f"pose {msg.idx} reported before its GO: the controller "
                                    "moved without the go-ahead")
            self.pending = msg
            return None
        if isinstance(msg, Pose):
            pending = self.pending
            if pending is None or pending.idx != msg.idx or pending.flag != msg.flag:
                raise SequenceError(f"p packet {msg.idx} without its j packet")
            self.expected, self.pending = self.expected + 1, None
            return MeasuredPose(msg.idx, msg.flag, pending.values, msg.values)
        if isinstance(msg, Done) and msg.verb == "RUN":
            if self.pending is not None or self.expected != self.count:
                raise SequenceError(f"run ended after {self.expected} of {self.count} poses")
            return msg
        if isinstance(msg, Err):
            raise ControllerError(msg.code, msg.text, msg.seq)
        raise SequenceError(f"unexpected {msg} during the run")

    def _wait(self, msg: Wait) -> Wait:
        """A WAIT for the next pose, once: the caller sends GO after the operator's go-ahead."""
        if not self.operator:
            raise SequenceError(f"WAIT {msg.idx} during an AUTO run")
        if msg.idx != self.expected or self.pending is not None:
            raise SequenceError(f"WAIT {msg.idx} while pose {self.expected} is next")
        if self.released == self.expected:
            raise SequenceError(f"WAIT {msg.idx} repeated: GO {msg.idx} was sent")
        self.released = self.expected
        return msg


class MotionReplies:
    """The frames of one MOVJ, HOME or ZERO; `result` holds the reported pose (not for ZERO).
    `operator`: the caller can answer ZERO's WAIT."""

    def __init__(self, verb: MotionVerb, *, operator: bool):
        self.verb, self.operator = verb, operator
        self.reports = verb != "ZERO"
        self.joints: Joints | None = None
        self.result: MeasuredPose | None = None
        self.released = False

    def feed(self, reply: Message) -> Event:
        verb = self.verb
        if isinstance(reply, Joints | Pose):
            if not self.reports or (reply.flag, reply.idx) != (2, 0):
                raise SequenceError(f"{verb} reply: unexpected {reply}")
            if isinstance(reply, Joints):
                if self.joints is not None:
                    raise SequenceError(f"{verb} reply: j packet repeated")
                self.joints = reply
            elif self.joints is None or self.result is not None:
                raise SequenceError(f"{verb} reply: p packet without its j packet")
            else:
                self.result = MeasuredPose(0, 2, self.joints.values, reply.values)
            return None
        if isinstance(reply, Wait):
            if verb != "ZERO" or reply.idx != 0 or self.released:
                raise SequenceError(f"{verb} reply: unexpected WAIT {reply.idx}")
            if not self.operator:
                raise SequenceError(f"{verb} waits for the operator; give on_wait")
            self.released = True
            return reply
        if isinstance(reply, Done) and reply.verb == verb:
            if self.reports and self.result is None:
                raise SequenceError(f"{verb} finished without reporting the pose")
            return reply
        if isinstance(reply, Err):
            raise ControllerError(reply.code, reply.text, reply.seq)
        raise SequenceError(f"unexpected {reply} during {verb}")


def check_packet(msg: Joints, expected: int, count: int) -> None:
    """A run's `j` packet is the expected pose, inside the list, with its place's FLAG."""
    if msg.idx < expected:
        raise SequenceError(f"pose {msg.idx} repeated (expected {expected})")
    if msg.idx >= count:
        raise SequenceError(f"pose {msg.idx} after the last of {count}")
    if msg.idx > expected:
        raise SequenceError(f"pose {expected} missing (got {msg.idx})")
    if msg.flag != codec.flag_of(msg.idx, count):
        raise SequenceError(f"pose {msg.idx} has FLAG {msg.flag}, expected "
                            f"{codec.flag_of(msg.idx, count)} in a list of {count}")
