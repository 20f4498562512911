"""Robot programs of other makers, read once: KUKA KRL (`krl`), FANUC LS (`fanuc_ls`) and
URScript (`urscript`). Each reader returns a `Program` (`program`): the Cartesian targets
written as literals, where each number sits in the text, the tool and frame each target is
used with, its configuration flags as written, and what cannot be compensated statically
(computed targets, registers, partial aggregates), with its line. The program filter
(`screwcal.calibration.program_filter`) compensates them; the RAPID parser is `screwcal.rapid`.

May import: nothing of ours (a core layer below every other: the standard library only).
"""

from screwcal.programs.program import Flag, Frame, Note, Program, ProgramSyntaxError, Target
from screwcal.programs.read import language_of, read_program

__all__ = ["Flag", "Frame", "Note", "Program", "ProgramSyntaxError", "Target", "language_of",
           "read_program"]
