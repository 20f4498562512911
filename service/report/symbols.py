"""The parameter names of an identification in words (screwcal.calibration.error_parameters
names them; the thesis's virtual joints: calibration.virtual_joints), and what a parameter the
data could not separate means for the robot."""

from __future__ import annotations

import re

from service.document import RemovedParameter

AXES = {"x": "x", "y": "y", "z": "z"}
SHORT = {"base": "the measuring frame's", "tool": "the measured point's",
         "home": "the home flange's"}
FRAMES = {"base": "the robot base in the measuring system's frame",
          "tool": "the measured point in the flange frame",
          "home": "the flange frame at home (every joint at 0) in the robot base frame"}
# (pattern, the symbol as the legend writes it, its meaning); the first that matches names it.
_FAMILIES: tuple[tuple[re.Pattern[str], str, str], ...] = (
    (re.compile(r"^(base|tool|home)\.r([xyz])$"), "{0}.rx, .ry, .rz",
     "{frame}: rotation about x, y, z (deg)"),
    (re.compile(r"^(base|tool|home)\.([xyz])$"), "{0}.x, .y, .z",
     "{frame}: shift along x, y, z (mm)"),
    (re.compile(r"^J(\d)\.dir\.([uv])$"), "Ji.dir.u, Ji.dir.v",
     "tilt of joint i's axis towards u or v (deg); u and v are two directions perpendicular to "
     "the joint's nominal axis w: u = w x X (w x Y when w lies along X), v = w x u"),
    (re.compile(r"^J(\d)\.pos\.([uv])$"), "Ji.pos.u, Ji.pos.v",
     "shift of joint i's axis along u or v (mm), the same u and v"),
    (re.compile(r"^J(\d)c\.m(\d)$"), "Jic.mk",
     "compliance of joint i under the torque of arm mass k (deg per kN m)"),
    (re.compile(r"^J(\d)c$"), "Jic",
     "compliance of joint i under gravity: the joint bends by Jic x its gravity torque "
     "(deg per kN m)"),
    (re.compile(r"^J(\d)r([xyz])$"), "Jirx, Jiry, Jirz",
     "joint i's zero offset, as the thesis names it (Table 11) (deg)"),
    (re.compile(r"^J(\d)p([xyz])$"), "Jipx, Jipy, Jipz",
     "link offset after joint i along the home frame's axis (thesis's virtual prismatic joint) "
     "(mm)"),
    (re.compile(r"^J(\d)$"), "Ji",
     "joint i's zero offset: how far the joint is from where the controller reads its zero "
     "(deg)"),
)


def family(name: str) -> tuple[str, str] | None:
    """(symbol, meaning) of a parameter name's family, None for a name of no known family."""
    for pattern, symbol, meaning in _FAMILIES:
        m = pattern.match(name)
        if m:
            frame = FRAMES.get(m.group(1), "")
            return symbol.format(m.group(1)), meaning.format(frame=frame)
    return None


def legend(names: list[str]) -> list[tuple[str, str]]:
    """The symbols the names use, each once, in the order met."""
    out: dict[str, str] = {}
    for name in names:
        found = family(name)
        if found is not None:
            out.setdefault(*found)
    return list(out.items())


def in_words(name: str) -> str:
    """One parameter in words: 'J2.pos.u' -> "the shift of joint 2's axis along u"."""
    m = re.match(r"^(base|tool|home)\.(r?)([xyz])$", name)
    if m:
        what = "rotation about" if m.group(2) else "shift along"
        return f"{SHORT[m.group(1)]} {what} {m.group(3)}"
    m = re.match(r"^J(\d)(?:\.(dir|pos)\.([uv])|(c)|)$", name)
    if m:
        joint = m.group(1)
        if m.group(2) == "dir":
            return f"the tilt of joint {joint}'s axis towards {m.group(3)}"
        if m.group(2) == "pos":
            return f"the shift of joint {joint}'s axis along {m.group(3)}"
        if m.group(4):
            return f"joint {joint}'s compliance"
        return f"joint {joint}'s zero offset"
    m = re.match(r"^J(\d)(?:r[xyz]|p([xyz])|c\.m(\d))$", name)
    if m:
        if m.group(2):
            return f"the link offset after joint {m.group(1)} along {m.group(2)}"
        if m.group(3):
            return f"joint {m.group(1)}'s compliance under arm mass {m.group(3)}"
        return f"joint {m.group(1)}'s zero offset"
    return name


def partners(removed: RemovedParameter) -> list[str]:
    """The parameters a removed one is not separable from, strongest first: the names in its
    reason (identifiability.explain_removed writes "not separable from +1.02 base.rz -0.03
    base.rx ..."); none when it has no effect at all."""
    return re.findall(r"[+-][\d.]+(?:e[+-]?\d+)? (\S+)", removed.reason)


# What a parameter held at nominal means for the robot, by what took up its effect.
CONSEQUENCES = {
    "none": "they have no effect on these measurements: nothing the robot does here depends on "
            "them",
    "frame": "the measuring frame (base.*) takes up their effect: positions in this cell are "
             "predicted correctly, but the values are not the robot's own: taken to another "
             "cell, or entered in the controller, they do not correct it",
    "robot": "the robot's other parameters take up their effect: the calibrated model predicts "
             "the flange correctly near the calibration poses, but those values are not the "
             "robot's physical ones, and far from those poses the prediction may err",
}


def taken_up_by(removed: RemovedParameter) -> str:
    """What took up a removed parameter's effect: "none", "frame" or "robot"
    (`CONSEQUENCES`)."""
    others = partners(removed)
    if not others:
        return "none"
    if removed.name.startswith(("base.", "tool.")) or any(
            p.startswith(("base.", "tool.")) for p in others):
        return "frame"
    return "robot"
