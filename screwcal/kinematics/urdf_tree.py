"""A URDF document read into a checked tree of links and joints, or refused with a sentence
naming the file, the line and the element.

What is refused, and why: XML that declares entities or reaches outside the file (defusedxml:
entity expansion and external entities are how an XML file attacks its reader; a URDF needs
neither); a file over `MAX_BYTES` or `MAX_ELEMENTS` (no robot description comes near); a number
that is not a plain decimal ("-2.7rad", "2kg", "inf", "nan") or lies beyond what a robot can
have (`BOUNDS`: 1e300 m, 1e999 kg); a link with several parents, a cycle, several roots or a
joint naming a link the file does not have (a URDF is one tree: urdfdom refuses these too);
limits with lower not below upper. The document's own encoding declaration and a byte order
mark are honoured (expat reads the bytes).

Units stay the file's (m, rad, kg) except lengths of origins, which are mm as everywhere in the
core; the chain built from the tree (`urdf.model_from_urdf`) converts the rest.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import cached_property
from typing import Any
from xml.etree.ElementTree import Element, ParseError, TreeBuilder

import numpy as np

from screwcal.errors import ModelError
from screwcal.kinematics.pose import rotation_from_euler_zyx_deg
from screwcal.kinematics.se3 import Array

MAX_BYTES = 16 * 2**20
MAX_ELEMENTS = 100_000
# largest magnitude per kind of number (file units): a robot description beyond is a mistake
BOUNDS = {"length_m": 1e3, "angle_rad": 1e4, "mass_kg": 1e6, "inertia": 1e9, "axis": 1e6,
          "effort": 1e12, "velocity": 1e6}
_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")


@dataclass(frozen=True)
class Origin:
    """A URDF <origin>: xyz (m) and rpy (rad) as the file gives them; `T` the transform (mm),
    built when asked (a file's many links off the chain never need theirs)."""

    xyz_m: tuple[float, ...] = (0.0, 0.0, 0.0)
    rpy_rad: tuple[float, ...] = (0.0, 0.0, 0.0)

    @cached_property
    def T(self) -> Array:
        T = np.eye(4)
        T[:3, 3] = np.array(self.xyz_m) * 1000.0
        T[:3, :3] = rotation_from_euler_zyx_deg(np.degrees(self.rpy_rad))
        return T


@dataclass(frozen=True)
class Inertial:
    kg: float
    origin: Origin  # centre of mass in the link frame
    inertia: tuple[float, ...]  # ixx ixy ixz iyy iyz izz, kg m^2 (0s when not given)


@dataclass(frozen=True)
class Link:
    name: str
    line: int
    inertial: Inertial | None


@dataclass(frozen=True)
class Joint:
    name: str
    kind: str
    parent: str
    child: str
    line: int
    origin: Origin  # child frame in the parent frame at joint value 0
    axis: Array  # unit, in the child frame
    limit: tuple[float, float] | None  # lower, upper: rad or m as the file gives them
    effort: float | None
    velocity: float | None
    mimic: tuple[str, float, float] | None  # the joint followed, multiplier, offset


@dataclass(frozen=True)
class UrdfTree:
    source: str
    name: str
    links: dict[str, Link]
    joint_of: dict[str, Joint]  # child link -> the joint that carries it
    root: str

    def where(self, joint: Joint) -> str:
        return f"{self.source}, line {joint.line}: joint '{joint.name}'"

    def upward(self, link: str) -> list[Joint]:
        """The joints from `link` up to the root, `link`'s own first."""
        out = []
        while link in self.joint_of:
            out.append(self.joint_of[link])
            link = out[-1].parent
        return out

    def fixed_transform(self, frm: str, to: str) -> Array | None:
        """Pose of link `to` in link `frm` (mm) when only fixed joints lie between them (the
        transform is then constant), else None."""
        up_to, up_frm = self.upward(to), self.upward(frm)
        above_to = {to} | {j.parent for j in up_to}
        T_frm = np.eye(4)
        link = frm
        for j in up_frm:  # climb from frm to the first link above `to` too
            if link in above_to:
                break
            if j.kind != "fixed":
                return None
            T_frm = j.origin.T @ T_frm
            link = j.parent
        T_to = np.eye(4)
        for j in up_to:
            if j.child == link:
                break
            if j.kind != "fixed":
                return None
            T_to = j.origin.T @ T_to
        return np.asarray(np.linalg.inv(T_frm) @ T_to)


class _LineBuilder(TreeBuilder):
    """The tree, each element's line kept (ElementTree keeps none), elements counted."""

    def __init__(self) -> None:
        super().__init__()
        self.parser: Any = None
        self.lines: dict[int, int] = {}
        self.count = 0

    def start(self, tag: str, attrs: dict[str, str]) -> Element:
        self.count += 1
        if self.count > MAX_ELEMENTS:
            raise _TooBigError(f"more than {MAX_ELEMENTS} elements")
        element = super().start(tag, attrs)
        self.lines[id(element)] = self.parser.parser.CurrentLineNumber
        return element


class _TooBigError(Exception):
    pass


def _parse(data: str | bytes, source: str) -> tuple[Element, dict[int, int]]:
    from defusedxml import DefusedXmlException
    from defusedxml.ElementTree import DefusedXMLParser

    size = len(data)
    if size > MAX_BYTES:
        raise ModelError(f"{source}: {size / 2**20:.0f} MB, more than a robot description "
                         f"holds ({MAX_BYTES // 2**20} MB): not read")
    builder = _LineBuilder()
    parser = DefusedXMLParser(target=builder)
    builder.parser = parser
    try:
        parser.feed(data)
        root = parser.close()
    except ParseError as err:
        line, column = err.position
        raise ModelError(f"{source}, line {line}, column {column + 1}: not a URDF (XML error: "
                         f"{str(err).split(':')[0]})") from None
    except DefusedXmlException as err:
        raise ModelError(f"{source}: refused: the XML declares entities or refers outside the "
                         f"file ({type(err).__name__}: {err}); a URDF needs neither") from None
    except _TooBigError as err:
        raise ModelError(f"{source}: {err}: more than a robot description holds; not read"
                         ) from None
    except (ValueError, LookupError) as err:  # an unknown or impossible declared encoding
        raise ModelError(f"{source}: not readable as XML ({err})") from None
    return root, builder.lines


class _Reader:
    """Numbers and names of one document, each error naming file, line and element."""

    def __init__(self, source: str, lines: dict[int, int]):
        self.source, self.lines = source, lines

    def at(self, e: Element) -> str:
        return f"{self.source}, line {self.lines.get(id(e), 0)}"

    def numbers(self, e: Element, attr: str, n: int, kind: str, owner: str,
                default: str | None = None) -> tuple[float, ...]:
        text = e.get(attr, default)
        if text is None:
            raise ModelError(f"{self.at(e)}: {owner} <{e.tag}> has no '{attr}'")
        parts = text.split()
        bad = [p for p in parts if not _NUMBER.fullmatch(p)]
        if bad or len(parts) != n:
            unit = {"length_m": " (URDF lengths are plain metres)",
                    "angle_rad": " (URDF angles are plain radians)",
                    "mass_kg": " (URDF masses are plain kilograms)"}.get(kind, "")
            what = f"'{bad[0]}' is not a number" if bad else f"{len(parts)} values, not {n}"
            raise ModelError(f"{self.at(e)}: {owner} <{e.tag} {attr}=\"{text}\">: {what}{unit}")
        values = tuple(float(p) for p in parts)
        limit = BOUNDS[kind]
        if not all(abs(v) <= limit for v in values):  # inf (1e999) too
            raise ModelError(f"{self.at(e)}: {owner} <{e.tag} {attr}=\"{text}\">: beyond "
                             f"{limit:g} ({kind.replace('_', ' in ')}): not a robot's figure")
        return values

    def number(self, e: Element, attr: str, kind: str, owner: str,
               default: str | None = None) -> float:
        return self.numbers(e, attr, 1, kind, owner, default)[0]

    def origin(self, e: Element | None, owner: str) -> Origin:
        if e is None:
            return Origin()
        return Origin(self.numbers(e, "xyz", 3, "length_m", owner, "0 0 0"),
                      self.numbers(e, "rpy", 3, "angle_rad", owner, "0 0 0"))

    def name(self, e: Element, what: str) -> str:
        value = e.get("name") or e.get("link")
        if not value:
            raise ModelError(f"{self.at(e)}: {what} <{e.tag}> without a name")
        return value

    def inertial(self, e: Element | None, owner: str) -> Inertial | None:
        if e is None:
            return None
        mass = e.find("mass")
        if mass is None:
            raise ModelError(f"{self.at(e)}: {owner} <inertial> has no <mass>")
        kg = self.number(mass, "value", "mass_kg", owner)
        if kg < 0:
            raise ModelError(f"{self.at(mass)}: {owner} <mass value=\"{mass.get('value')}\">: "
                             "a mass cannot be negative")
        inertia = e.find("inertia")
        moments = (0.0,) * 6 if inertia is None else tuple(
            self.number(inertia, a, "inertia", owner, "0")
            for a in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"))
        return Inertial(kg, self.origin(e.find("origin"), owner), moments)

    def joint(self, e: Element, links: dict[str, Link]) -> Joint:
        name = self.name(e, "a")
        owner = f"joint '{name}'"
        kind = e.get("type", "")
        if kind not in JOINT_TYPES:
            raise ModelError(f"{self.at(e)}: {owner} of type '{kind}': a URDF joint is one of "
                             f"{', '.join(JOINT_TYPES)}")
        ends = []
        for tag in ("parent", "child"):
            end = e.find(tag)
            if end is None or not end.get("link"):
                raise ModelError(f"{self.at(e)}: {owner} has no <{tag} link=...>")
            if end.get("link") not in links:
                raise ModelError(f"{self.at(end)}: {owner}'s {tag} '{end.get('link')}' is not a "
                                 "<link> of the file")
            ends.append(str(end.get("link")))
        axis_e = e.find("axis")
        axis = np.array([1.0, 0.0, 0.0]) if axis_e is None else \
            np.array(self.numbers(axis_e, "xyz", 3, "axis", owner, "1 0 0"))
        norm = float(np.linalg.norm(axis))
        if kind != "fixed" and norm < 1e-9:
            raise ModelError(f"{self.at(e if axis_e is None else axis_e)}: {owner}: a zero axis")
        limit_e = e.find("limit")
        limit = effort = velocity = None
        if limit_e is not None:
            kind_l = "length_m" if kind == "prismatic" else "angle_rad"
            lo = self.number(limit_e, "lower", kind_l, owner, "0")
            hi = self.number(limit_e, "upper", kind_l, owner, "0")
            if kind in ("revolute", "prismatic") and not lo < hi:
                unit = "m" if kind == "prismatic" else "rad"
                raise ModelError(
                    f"{self.at(limit_e)}: {owner} <limit lower=\"{limit_e.get('lower', '')}\" "
                    f"upper=\"{limit_e.get('upper', '')}\">: lower ({lo:g} {unit}) must be below "
                    f"upper ({hi:g} {unit}); a joint that cannot move is a fixed joint")
            limit = (lo, hi)
            if limit_e.get("effort") is not None:
                effort = self.number(limit_e, "effort", "effort", owner)
            if limit_e.get("velocity") is not None:
                velocity = self.number(limit_e, "velocity", "velocity", owner)
        mimic_e = e.find("mimic")
        mimic = None if mimic_e is None else (
            mimic_e.get("joint", ""),
            self.number(mimic_e, "multiplier", "axis", owner, "1"),
            self.number(mimic_e, "offset", "angle_rad", owner, "0"))
        return Joint(name, kind, ends[0], ends[1], self.lines.get(id(e), 0),
                     self.origin(e.find("origin"), owner),
                     axis / norm if norm else axis, limit, effort, velocity, mimic)


def read_tree(data: str | bytes, source: str = "URDF") -> UrdfTree:
    """The checked tree of a URDF document (str, or bytes read with their declared encoding)."""
    root, lines = _parse(data, source)
    r = _Reader(source, lines)
    if root.tag != "robot":
        raise ModelError(f"{source}: not a URDF (root element <{root.tag}>, not <robot>)")
    macro = next((e for e in root.iter() if "xacro" in e.tag), None)
    if macro is not None:
        raise ModelError(f"{r.at(macro)}: <{macro.tag.split('}')[-1]}> is xacro, not URDF: "
                         "expand the file first (ROS's `xacro FILE > robot.urdf`)")
    links: dict[str, Link] = {}
    for e in root.findall("link"):
        name = r.name(e, "a")
        if name in links:
            raise ModelError(f"{r.at(e)}: link '{name}' again (first on line "
                             f"{links[name].line}): link names are unique")
        links[name] = Link(name, lines.get(id(e), 0),
                           r.inertial(e.find("inertial"), f"link '{name}'"))
    if not links:
        raise ModelError(f"{source}: not a URDF robot (no <link>)")
    joints: dict[str, Joint] = {}
    joint_of: dict[str, Joint] = {}
    for e in root.findall("joint"):
        j = r.joint(e, links)
        if j.name in joints:
            raise ModelError(f"{r.at(e)}: joint '{j.name}' again (first on line "
                             f"{joints[j.name].line}): joint names are unique")
        joints[j.name] = j
        if j.child in joint_of:
            first = joint_of[j.child]
            raise ModelError(f"{source}: link '{j.child}' has several parents: joint "
                             f"'{first.name}' (line {first.line}) and joint '{j.name}' (line "
                             f"{j.line}); a URDF is a tree, each link hangs from one joint")
        joint_of[j.child] = j
    _refuse_cycles(joint_of, source)
    roots = [n for n in links if n not in joint_of]
    if len(roots) > 1:
        listed = ", ".join(f"'{n}' (line {links[n].line})" for n in roots[:5])
        raise ModelError(f"{source}: several root links ({listed}{' ...' if len(roots) > 5 else ''}"
                         "): a URDF is one tree; join them with a joint or remove the strays")
    return UrdfTree(source, root.get("name") or "", links, joint_of, roots[0])


def _refuse_cycles(joint_of: dict[str, Joint], source: str) -> None:
    """Each link's parents followed once: a walk that meets itself is a cycle (O(links))."""
    settled: set[str] = set()
    for start in joint_of:
        walk: list[str] = []
        on_walk: set[str] = set()
        link = start
        while link in joint_of and link not in settled:
            if link in on_walk:
                loop = walk[walk.index(link):]
                names = ", ".join(f"'{joint_of[k].name}' (line {joint_of[k].line})"
                                  for k in loop[:6]) + (f" ... ({len(loop)} joints)"
                                                        if len(loop) > 6 else "")
                raise ModelError(f"{source}: the joints {names} form a cycle (link '{link}' "
                                 "hangs from itself): a URDF is a tree")
            walk.append(link)
            on_walk.add(link)
            link = joint_of[link].parent
        settled.update(walk)
