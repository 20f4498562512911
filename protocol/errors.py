"""The exception tree of the link.

    ProtocolError
    ├── FramingError        an 80-byte frame is malformed: the connection must be dropped
    ├── PayloadError        a well-framed payload is not a valid message (carries the ERR code)
    ├── ControllerError     the controller answered ERR CODE TEXT
    │   └── ControllerBusyError  ERR 16: another client owns the controller (also a LinkLostError)
    ├── SequenceError       data packets missing, repeated or out of order
    └── LinkError           a device link failed: reconnect and go on (a job pauses; caught as one)
        ├── LinkLostError       the connection dropped; every pending wait fails with it
        │   └── ControllerBusyError (above)
        ├── LinkTimeoutError    a reply did not come in time
        ├── ArmLineError        a measuring-arm line is malformed, a hole not measured, or the
        │                       arm's port failed (pyserial's and the OS's errors, translated)
        └── TrackerError        the laser tracker (emScon) could not measure now: status, command
            ├── BeamBrokenError         no reflector locked: the beam is broken (after one
            │                           FindReflector and a second try)
            ├── TrackerNotInitialisedError  the tracker must be initialised first
            └── TrackerWarmingUpError   the laser / distance meter is still warming up
    TrackerRefusedError     the tracker refused a command for good (a wrong parameter, a
                            command it does not implement): not cured by reconnecting

Errors of the libraries underneath (pyserial's SerialException, OSError) are translated at the
boundary (`ControllerClient`, `ArmReader`): callers catch `LinkError`, never those.
"""


class ProtocolError(Exception):
    """Base of every error the link raises on purpose."""


class FramingError(ProtocolError):
    """A frame that cannot be trusted: the receiver drops the connection, never resynchronises."""


class PayloadError(ProtocolError):
    """A valid frame whose payload is not a valid message. `code` is the ERR code to answer
    (10 bad frame, 11 unknown verb, 12 bad arguments), `seq` the request's SEQ if it was read."""

    def __init__(self, message: str, code: int = 12, seq: int | None = None):
        super().__init__(message)
        self.code = code
        self.seq = seq


class ControllerError(ProtocolError):
    """The controller refused a request: `SEQ ERR CODE TEXT`."""

    def __init__(self, code: int, text: str, seq: int):
        super().__init__(f"controller error {code} ({text}) for request {seq}")
        self.code = code
        self.text = text
        self.seq = seq


class LinkError(ProtocolError):
    """A link to a device (controller or measuring arm) failed in a way a reconnect can cure."""


class LinkLostError(LinkError):
    """The connection to the controller dropped."""


class ControllerBusyError(ControllerError, LinkLostError):
    """`0 ERR 16 busy`: another client owns the controller, which closed this connection.
    Try again when that client has left (`ControllerClient.reconnect` does, with back-off)."""

    def __init__(self, text: str = "busy"):
        super().__init__(16, text, 0)
        self.args = (f"the controller is busy ({text}): another client owns it",)

    def __str__(self) -> str:
        return str(self.args[0])


class SequenceError(ProtocolError):
    """Data packets of a list arrived missing, repeated or out of order."""


class LinkTimeoutError(LinkError):
    """A reply did not arrive within its time limit."""


class ArmLineError(LinkError):
    """A measuring-arm line that must not be used as a measurement."""


class TrackerError(LinkError):
    """The laser tracker could not measure now (emScon ES_ResultStatus `status` for the command
    `command`): the job pauses and goes on once the cause is cleared."""

    def __init__(self, message: str, status: int = 0, command: int = 0):
        super().__init__(message)
        self.status = status
        self.command = command


class BeamBrokenError(TrackerError):
    """No reflector is locked: something broke the beam or the reflector faces away. The driver
    already searched (FindReflector) and tried again once."""


class TrackerNotInitialisedError(TrackerError):
    """The tracker was not initialised (or lost its initialisation): Initialize first."""


class TrackerWarmingUpError(TrackerError):
    """The tracker's laser or distance meter is still warming up: wait and try again."""


class TrackerRefusedError(ProtocolError):
    """The tracker refused a command for good (ES_ResultStatus `status`)."""

    def __init__(self, message: str, status: int, command: int):
        super().__init__(message)
        self.status = status
        self.command = command
