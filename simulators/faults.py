"""Faults the IRC5 emulator can inject, for the client's tests. Each fires once: the pose faults
in the frames the RAPID program sends (the socket layer), the collision in its moves."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class FaultPlan:
    split_frames: bool = False  # every frame written in two pieces
    merge_frames: bool = False  # a pose's j and p frames written in one piece
    drop_at_pose: int | None = None  # close the connection instead of sending pose k's packets
    stall_at_pose: int | None = None  # go silent for stall_s before pose k
    stall_s: float = 30.0
    garble_at_pose: int | None = None  # pose k's j frame loses its '#'
    collision_at_move: int | None = None  # the controller's move k (0-based) stops halfway

    def take(self, name: str, idx: int) -> bool:
        """True once when the fault `name` is due at pose `idx`."""
        if getattr(self, name) == idx:
            setattr(self, name, None)
            return True
        return False
