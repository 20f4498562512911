"""The exception tree of the link.

    ProtocolError
    ├── FramingError        an 80-byte frame is malformed: the connection must be dropped
    ├── PayloadError        a well-framed payload is not a valid message (carries the ERR code)
    ├── ControllerError     the controller answered ERR CODE TEXT
    │   └── ControllerBusyError  ERR 16: another client owns the controller (also a LinkLostError)
    ├── SequenceError       data packets missing, repeated or out of order
    ├── LinkLostError       the connection dropped; every pending wait fails with it
    ├── LinkTimeoutError    a reply did not come in time
    └── ArmLineError        a measuring-arm line is malformed, has a bad checksum or a SEQ gap
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


class LinkLostError(ProtocolError):
    """The connection to the controller dropped."""


class ControllerBusyError(ControllerError, LinkLostError):
    """`0 ERR 16 busy`: another client owns the controller, which closed this connection.
    Try again when that client has left (`ControllerClient.reconnect` does, with back-off)."""

    def __init__(self, text: str = "busy"):
        ProtocolError.__init__(self, f"the controller is busy ({text}): another client owns it")
        self.code, self.text, self.seq = 16, text, 0


class SequenceError(ProtocolError):
    """Data packets of a list arrived missing, repeated or out of order."""


class LinkTimeoutError(ProtocolError):
    """A reply did not arrive within its time limit."""


class ArmLineError(ProtocolError):
    """A measuring-arm line that must not be used as a measurement."""
