"""Filtering a RAPID program for a calibrated robot (what RoboDK's FilterProgram and ABB's
Absolute Accuracy option do for closed controllers).

Every declared `robtarget` is rewritten so that the nominal controller, given the new target,
drives the joints to where the *calibrated* robot reaches the original one: the target's flange
pose (work object and tool applied) is solved on the nominal model with the target's own
confdata, the calibrated robot's joints are found next to that solution
(`correction.compensate`), and the new target is the nominal pose of those joints, with its
confdata recomputed from them. Only the numbers of `trans`, `rot` and `robconf` change; the rest
of the file is kept byte for byte.

What a static filter cannot compensate is listed with its line, never passed silently: targets
computed at run time (`Offs`, `RelTool`, `CRobT`, ...), targets written inline in an
instruction, targets declared without a value, a target used with two different tools or work
objects, a stationary tool (`robhold` TRUE) and a moving or robot-held work object.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from operator import itemgetter
from typing import TYPE_CHECKING, TypeGuard

import numpy as np

from screwcal.calibration.correction import compensate
from screwcal.calibration.rapid_filter_report import FilterReport, Note
from screwcal.calibration.rapid_source import (
    NUMBER,
    Aggregate,
    Declaration,
    NumberTokens,
    RapidModule,
    Token,
)
from screwcal.errors import DataFileError
from screwcal.kinematics.confdata import confdata, solution_for_confdata
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.pose import (
    rotation_angle_deg,
    rotation_from_quaternion_wxyz,
)
from screwcal.kinematics.se3 import Array, invert_transform, quaternion_wxyz_from_rotation

if TYPE_CHECKING:
    from screwcal.calibration.residual_model import ResidualModel

TRANS_DECIMALS = 4  # mm
QUAT_DECIMALS = 9
Frames = dict[str, "Array | str"]  # by lower-case name: a 4x4 frame, or why it cannot be used
_LITERALS = re.compile(rf"{NUMBER.pattern}(?:,{NUMBER.pattern})*")  # a target's numbers, joined
_text, _start, _end = itemgetter(0), itemgetter(1), itemgetter(2)  # a Token's parts
# a target's row of numbers as written back: x y z (mm), q1..q4, cf1 cf4 cf6 cfx
_ROW = ",".join([f"{{:.{TRANS_DECIMALS}f}}"] * 3 + [f"{{:.{QUAT_DECIMALS}f}}"] * 4 + ["{}"] * 4)


@dataclass
class _Target:
    name: str  # with its index for array elements
    base: str  # the declared name
    line: int
    tokens: list[Token]  # x y z, q1..q4, cf1 cf4 cf6 cfx


def _is_robtarget(node: object) -> TypeGuard[list[list[Token]]]:
    """[[x,y,z],[q1..q4],[cf1,cf4,cf6,cfx],[extax]]: four lists, numbers in the first three."""
    return (isinstance(node, list) and len(node) == 4 and isinstance(node[0], list)
            and len(node[0]) == 3 and isinstance(node[0][0], Token)
            and isinstance(node[1], list) and len(node[1]) == 4
            and isinstance(node[2], list) and len(node[2]) == 4)


def _targets(name: str, value: Aggregate, line_of: Callable[[int], int]) -> list[_Target]:
    """Every robtarget in a declaration's value (one, or the elements of an array)."""
    if _is_robtarget(value):  # one target: most declarations
        tokens = [*value[0], *value[1], *value[2]]
        return [_Target(name, name, line_of(tokens[0].start), tokens)]
    out: list[_Target] = []
    _walk(name, value, [], line_of, out)
    return out


def _walk(name: str, node: object, index: list[int], line_of: Callable[[int], int],
          out: list[_Target]) -> None:
    """The robtargets of an array's value, labelled by their indices (1-based)."""
    if _is_robtarget(node):
        tokens = [*node[0], *node[1], *node[2]]
        label = name + (f"{{{','.join(str(i + 1) for i in index)}}}" if index else "")
        out.append(_Target(label, name, line_of(tokens[0].start), tokens))
    elif isinstance(node, list):
        for k, child in enumerate(node):
            _walk(name, child, [*index, k], line_of, out)


def _record_targets(label: str, node: object, type_: str, records: dict[str, list[tuple[str, str]]],
                    line: int, line_of: Callable[[int], int], found: list[_Target],
                    computed: list[Note]) -> None:
    """The robtargets in a value of `type_` (a robtarget, or a record holding some), labelled
    with their components (`weld{2}.p`): those written as literals in `found`, the others
    (an expression, or a value of another shape) noted in `computed`."""
    if type_ == "robtarget":
        if _is_robtarget(node):
            tokens = [*node[0], *node[1], *node[2]]
            found.append(_Target(label, label.split("{")[0].split(".")[0], line_of(
                tokens[0].start), tokens))
        else:
            computed.append(Note(line_of(node.start) if isinstance(node, Token) else line,
                                 label, "its value is an expression, computed when the "
                                 "program runs"))
        return
    fields = records.get(type_)
    if fields is None:
        return
    if not isinstance(node, list) or len(node) != len(fields):
        computed.append(Note(line, label, f"its {type_} value is not a literal of its "
                             f"{len(fields)} components"))
        return
    for (name, ftype), child in zip(fields, node, strict=True):
        _record_targets(f"{label}.{name}", child, ftype, records, line, line_of, found,
                        computed)


def _array_elements(name: str, value: object, dims: int, index: tuple[int, ...] = ()
                    ) -> list[tuple[str, object]]:
    """(label, value) of each element of an array value of `dims` dimensions."""
    if dims == 0:
        return [(name + (f"{{{','.join(map(str, index))}}}" if index else ""), value)]
    if not isinstance(value, list):
        return [(name, value)]
    return [e for k, child in enumerate(value)
            for e in _array_elements(name, child, dims - 1, (*index, k + 1))]


class _ZeroOrientationError(ValueError):
    """A frame whose quaternion is [0,0,0,0]: a placeholder, no rotation."""


def _frame(trans: list[Token], rot: list[Token]) -> Array:
    T = np.eye(4)
    quat = np.array([t.number for t in rot])
    if not quat.any():
        raise _ZeroOrientationError
    T[:3, :3] = rotation_from_quaternion_wxyz(quat)
    T[:3, 3] = [t.number for t in trans]
    return T


def _frames(module: RapidModule) -> tuple[Frames, Frames]:
    """Tool and work-object frames by lower-case name: a 4x4 array, or the reason they cannot
    be used statically."""
    tools: Frames = {"tool0": np.eye(4)}
    wobjs: Frames = {"wobj0": np.eye(4)}
    for d in module.declarations:
        if d.kind not in ("tooldata", "wobjdata"):
            continue
        key = d.name.lower()
        if d.value is None:
            (tools if d.kind == "tooldata" else wobjs)[key] = "declared without a value"
            continue
        try:
            if not isinstance(d.value, list):  # an expression: not of the standard form
                raise TypeError(d.kind)
            if d.kind == "tooldata":
                robhold, (trans, rot) = d.value[0], d.value[1]
                tools[key] = _frame(trans, rot) if robhold.text.upper() == "TRUE" else \
                    "a stationary tool (robhold FALSE): the robot holds the work object"
            elif d.kind == "wobjdata":
                robhold, ufprog = d.value[0].text.upper(), d.value[1].text.upper()
                (ut, ur), (ot, orot) = d.value[3], d.value[4]
                if robhold == "TRUE":
                    wobjs[key] = "a work object held by the robot (robhold TRUE)"
                elif ufprog == "FALSE":
                    wobjs[key] = "a moving work object (ufprog FALSE: coordinated motion)"
                else:
                    wobjs[key] = _frame(ut, ur) @ _frame(ot, orot)
        except _ZeroOrientationError:
            (tools if d.kind == "tooldata" else wobjs)[key] = "its orientation is [0,0,0,0], " \
                "a placeholder: never defined"
        except (TypeError, ValueError, IndexError, AttributeError):
            (tools if d.kind == "tooldata" else wobjs)[key] = f"its {d.kind} value is not " \
                "of the standard form"
    return tools, wobjs


def filter_rapid(module: RapidModule, calibrated: SerialModel, nominal: SerialModel, *,
                 tool: str = "tool0", wobj: str = "wobj0",
                 residual: ResidualModel | None = None,
                 task: Sequence[RapidModule] = ()) -> tuple[str, FilterReport]:
    """The module's text with every declared robtarget compensated, and what was done.
    `tool` and `wobj` apply to targets no motion instruction of the task names.
    `residual`: the calibrated robot's residual model (`correction.compensate`). `task`: the
    other modules of its task (`rapid_task.read_rapid_task`), whose tools, work objects and
    motions count."""
    report = FilterReport(module.path)
    if module.unreadable:
        report.refused.append(Note(1, "the module", f"{module.unreadable}: left as it is; "
                                   "the robtargets it may hold are not compensated"))
        return module.text, report
    tools, wobjs = _frames(module)
    for other in task:
        if other is not module:
            more_tools, more_wobjs = _frames(other)
            tools = {**more_tools, **tools}
            wobjs = {**more_wobjs, **wobjs}
    for name, known in ((tool, tools), (wobj, wobjs)):
        if name.lower() not in known:
            raise DataFileError(str(module.path), f"'{name}' is not declared in the module "
                                "(nor tool0 / wobj0): declare it, or name a declared one")
    uses = _uses(module, report, [m for m in task if m is not module])
    default = (tool.lower(), wobj.lower())
    targets: list[_Target] = []
    frames: list[tuple[Array, Array]] = []  # (work object, tool) per target
    assigned: dict[str, tuple[int, str]] = {}  # where the program writes a datum: this
    for m in (module, *task):  # module's first, then the task's in order
        for name, where in m.assigned.items():
            assigned.setdefault(name, where)
    for d in module.declarations:
        if d.kind not in ("robtarget", "record"):
            continue
        written = assigned.get(d.name.lower())
        for t in _static_targets(module, d, report):
            if written is not None:
                report.refused.append(Note(t.line, t.name, f"{written[1]} when the program "
                                           f"runs (line {written[0]}): its declared value is "
                                           "not what the robot moves to"))
                continue
            if t.name == d.name:  # a robtarget declared alone: most of every module
                combos = uses.get(t.name.lower(), set())
            else:
                combos = set().union(*(uses.get(k, ()) for k in _use_keys(t.name)))
            if not combos:
                combos = {default}
                report.unmoved.append(Note(t.line, t.name, f"{tool} and {wobj}"))
            if len(combos) > 1:
                pairs = "; ".join(f"{t} with {w}" for t, w in sorted(combos))
                report.refused.append(Note(t.line, t.name, "used with several tools or work "
                                           f"objects ({pairs}): one static value cannot serve "
                                           "them all"))
                continue
            (tname, wname), = combos
            tframe, wframe = tools.get(tname), wobjs.get(wname)
            if not isinstance(tframe, np.ndarray) or not isinstance(wframe, np.ndarray):
                report.refused.append(Note(t.line, t.name,
                                           _frame_problem(tname, tframe, wname, wframe)))
                continue
            targets.append(t)
            frames.append((wframe, tframe))
    if not targets:
        return module.text, report
    return _compensated_text(module.text, targets, frames, calibrated, nominal, report,
                             residual), report


_REFERENCE = re.compile(r"([A-Za-z]\w*)(\{[^{}]*\})?((?:\.[A-Za-z]\w*)*)")
_NAME = re.compile(r"(?<![\w.])([a-z]\w*)(?![\w(])")  # a datum's name in an expression
_LITERAL_INDEX = re.compile(r"\{\d+(?:,\d+)*\}")


def _use_keys(name: str) -> tuple[str, ...]:
    """The keys under which motions to target `name` (`p`, `pArr{2}`, `weld{2}.p`) are
    recorded: the target itself, and its declaration's with any index (`weld{*}.p`, `pArr`)."""
    key = name.lower()
    ref = _REFERENCE.fullmatch(key)
    if ref is None or not ref.group(2):
        return (key,)
    return key, f"{ref.group(1)}{{*}}{ref.group(3)}"


def _uses(module: RapidModule, report: FilterReport, others: Sequence[RapidModule] = ()
          ) -> dict[str, set[tuple[str, str]]]:
    """The (tool, work object) pairs each robtarget the module declares is moved to with (by
    the task's motions), by the keys of `_use_keys` (an index that is not a literal counts for
    every element); the targets only the program knows are noted in the report (the module's
    own motions: the other modules' have their own reports)."""
    kinds = ("robtarget", "record")
    declared = {d.name.lower() for d in module.declarations if d.kind in kinds}
    elsewhere = {d.name.lower() for m in others for d in m.declarations if d.kind in kinds}
    uses: dict[str, set[tuple[str, str]]] = {}
    motions = [(m, True) for m in module.motions] + \
        [(m, False) for o in others for m in o.motions]
    for m, own in motions:
        if m.template:  # to a routine's parameter: each call is a motion of its own
            continue
        for target in m.targets:
            key = target.lower()
            if key in declared:  # a declared name alone: most motions
                uses.setdefault(key, set()).add((m.tool.lower(), m.wobj.lower()))
                continue
            ref = _REFERENCE.fullmatch(re.sub(r"\s+", "", key))
            if ref and ref.group(1) in declared:
                base, index, components = ref.groups()
                if index and not _LITERAL_INDEX.fullmatch(index):
                    index = "{*}"
                uses.setdefault(f"{base}{index or ''}{components}", set()).add(
                    (m.tool.lower(), m.wobj.lower()))
            elif "(" in target:  # Offs(p, ...), RelTool(p, ...): p is moved to in this
                # motion's tool and work object, offset (the offset: the run-time list)
                for name in _NAME.findall(target.lower()):
                    if name in declared:
                        uses.setdefault(name, set()).add((m.tool.lower(), m.wobj.lower()))
            elif own and not (ref and ref.group(1) in elsewhere):
                report.not_static.append(Note(m.line, target[:40], "an inline or undeclared "
                                              "target: declare it in the module to filter it"))
    for line, what in module.runtime:
        report.not_static.append(Note(line, what, "computed at run time from other targets: "
                                      "its offset is applied in the nominal frame"))
    return uses


def _static_targets(module: RapidModule, d: Declaration, report: FilterReport
                    ) -> list[_Target]:
    """The robtargets of declaration `d` whose every number is a literal; the others are
    noted as refused in the report."""
    if d.value is None:
        report.refused.append(Note(d.line, d.name, "declared without a value: assigned at "
                                   "run time"))
        return []
    if isinstance(d.value, Token):
        report.refused.append(Note(d.line, d.name, "its value is an expression, computed "
                                   "when the program runs"))
        return []
    if d.kind == "record":
        found: list[_Target] = []
        notes: list[Note] = []
        for label, element in _array_elements(d.name, d.value, d.dims):
            _record_targets(label, element, d.type, module.records, d.line, module.line_of,
                            found, notes)
        report.refused += notes
    else:
        found = _targets(d.name, d.value, module.line_of)
    if len(found) == 1:  # one target, literal and taught: most declarations
        tokens, value = found[0].tokens, d.value
        # a robtarget's rows read as numbers by the parser are literals (no check again)
        literal = (d.kind == "robtarget" and len(value) == 4 and type(value[0]) is
                   type(value[1]) is type(value[2]) is NumberTokens) or \
            _LITERALS.fullmatch(",".join(map(_text, tokens)))
        if literal and (float(tokens[3].text) or float(tokens[4].text)
                        or float(tokens[5].text) or float(tokens[6].text)):
            return found
    computed = [t for t in found if not _LITERALS.fullmatch(",".join(map(_text, t.tokens)))]
    report.refused += [Note(t.line, t.name, "a number of its value is an expression, "
                            "computed when the program runs") for t in computed]
    unset = [t for t in found if t not in computed and
             not any(float(tok.text) for tok in t.tokens[3:7])]
    report.refused += [Note(t.line, t.name, "its orientation is [0,0,0,0], a placeholder: "
                            "the target was never taught") for t in unset]
    return [t for t in found if t not in computed and t not in unset]


def _frame_problem(tname: str, tframe: Array | str | None, wname: str,
                   wframe: Array | str | None) -> str:
    """Why a target's tool or work object cannot be used statically."""
    if not isinstance(tframe, np.ndarray):
        return f"tool {tname}: " + (tframe if isinstance(tframe, str) else
                                    "not declared in this module")
    return f"work object {wname}: " + (wframe if isinstance(wframe, str) else
                                       "not declared in this module")


def _compensated_text(text: str, targets: list[_Target], frames: list[tuple[Array, Array]],
                      calibrated: SerialModel, nominal: SerialModel, report: FilterReport,
                      residual: ResidualModel | None = None) -> str:
    """The text with each target's numbers replaced by its compensated ones; the targets
    the nominal or the calibrated robot cannot reach are noted as refused in the report."""
    W = np.array([f[0] for f in frames])
    Ttool = np.array([f[1] for f in frames])
    texts = [tok.text for t in targets for tok in t.tokens]  # 11 a target
    numbers = np.fromiter(map(float, texts), float, len(texts)).reshape(len(targets), -1)
    T_target = np.tile(np.eye(4), (len(targets), 1, 1))
    T_target[:, :3, :3] = rotation_from_quaternion_wxyz(numbers[:, 3:7])
    T_target[:, :3, 3] = numbers[:, :3]
    conf = np.rint(numbers[:, 7:11]).astype(int)
    T_flange = W @ T_target @ invert_transform(Ttool)
    q_nominal, keep = solution_for_confdata(nominal, T_flange, conf, strict=False)
    for k in np.flatnonzero(np.logical_not(keep)):
        report.refused.append(Note(targets[k].line, targets[k].name, "the nominal robot has no "
                                   f"solution with confdata {conf[k].tolist()} in its limits"))
    idx = np.flatnonzero(keep)
    if idx.size == 0:
        return text
    comp = compensate(calibrated, nominal, T_flange[idx], q_nominal[idx], frame="base",
                      strict=False, residual=residual)
    for row, why in comp.refused:  # the calibrated robot cannot reach it plausibly
        report.refused.append(Note(targets[idx[row]].line, targets[idx[row]].name, why))
    comp_ok = comp.ok
    if comp.residual is not None:  # what the residual model corrected, and where it could not
        report.residual = comp.residual.summary()
        report.uncorrected += [Note(targets[idx[k]].line, targets[idx[k]].name,
                                    comp.residual.note(k))
                               for k in np.flatnonzero(np.logical_and(
                                   ~comp.residual.within_reach, comp_ok)).tolist()]
    idx = idx[comp_ok]
    if idx.size == 0:
        return text
    comp = replace(comp, q_rad=comp.q_rad[comp_ok], nominal_tool0=comp.nominal_tool0[comp_ok])
    new_target = invert_transform(W[idx]) @ comp.nominal_tool0 @ Ttool[idx]
    values = _target_text(new_target, confdata(nominal, comp.q_rad), numbers[idx, 3:7])
    report.compensated = len(idx)
    report.max_position_change_mm = float(np.linalg.norm(
        new_target[:, :3, 3] - T_target[idx, :3, 3], axis=1).max())
    report.max_rotation_change_deg = float(rotation_angle_deg(
        new_target[:, :3, :3], T_target[idx, :3, :3]).max())
    # the text between the replaced numbers, and the numbers (targets are in file order)
    tokens = [tok for k in idx.tolist() for tok in targets[k].tokens]
    if len(values) != len(tokens):
        raise AssertionError("a target's new numbers do not match its old ones")
    ends = [0, *map(_end, tokens)]
    starts = [*map(_start, tokens), len(text)]
    out = [""] * (2 * len(values) + 1)
    out[::2] = map(text.__getitem__, map(slice, ends, starts))  # the text between them
    out[1::2] = values
    return "".join(out)


def _target_text(T: Array, conf: Array, old_quats: Array) -> list[str]:
    """The numbers of targets T (N, 4, 4) as text, 11 a target one target after the other:
    x y z (mm), q1..q4 (on the side of the old quaternions), cf1 cf4 cf6 cfx."""
    quats = quaternion_wxyz_from_rotation(T[:, :3, :3])
    quats *= np.where(np.sum(quats * old_quats, axis=1) < 0, -1.0, 1.0)[:, None]
    trans = np.round(T[:, :3, 3], TRANS_DECIMALS) + 0.0  # + 0.0: no "-0.0"
    quats = np.round(quats, QUAT_DECIMALS) + 0.0
    numbers = np.concatenate([trans, quats, conf], axis=1, dtype=object).ravel().tolist()
    return ",".join([_ROW] * len(T)).format(*numbers).split(",")  # one format for them all
