"""What filtering a RAPID program did and left alone: the count and size of the changes, and
every target left as it was (or compensated without part of the correction), with its line and
why (`rapid_filter.filter_rapid` fills it; `screwcal compensate --rapid` prints its summary)."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Note:
    """Something left as it was: where, what, and why."""

    line: int
    name: str
    reason: str


@dataclass
class FilterReport:
    path: str
    compensated: int = 0
    max_position_change_mm: float = 0.0
    max_rotation_change_deg: float = 0.0
    refused: list[Note] = field(default_factory=list)  # declared targets left unchanged
    not_static: list[Note] = field(default_factory=list)  # targets only the program knows
    residual: str = ""  # the residual model's corrections, when one was given
    uncorrected: list[Note] = field(default_factory=list)  # beyond the residual model's reach
    # targets no instruction of the task moves to: compensated in --tool and --wobj
    unmoved: list[Note] = field(default_factory=list)

    def summary(self) -> str:
        lines = [f"{self.path}: {self.compensated} robtargets compensated; largest change "
                 f"{self.max_position_change_mm:.3f} mm, {self.max_rotation_change_deg:.4f} deg"]
        if self.residual:
            lines.append(f"  {self.residual}")
        for title, notes in (("compensated without the residual's correction",
                              self.uncorrected),
                             ("moved to by no instruction (compensated in the --tool and "
                              "--wobj given)", self.unmoved),
                             ("refused (left unchanged)", self.refused),
                             ("not compensated statically", self.not_static)):
            if notes:
                lines.append(f"  {len(notes)} {title}:")
                lines += [f"    {self.path}:{n.line}: {n.name}: {n.reason}" for n in notes]
        return "\n".join(lines)
