"""What each indicator's move means for a service engineer: fault, part, action and colour.

The one table (:data:`ADVICE`) from an indicator's code name to words, read by the verdicts and
the charts. Each row follows what the indicator measures (``axiswatch.indicators._readings``,
``axiswatch.indicators._ringing``, ``axiswatch.indicators._order_lines``). The code names stay
in the report's details. The report does not know whether an axis turns a gearbox or a ball
screw, so a row names the drive train and both, unless the profile declared a gear stage.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["ADVICE", "TASK_CHANGE_HINT", "Advice", "advice_for", "indicator_colour", "part_words"]


@dataclass(frozen=True)
class Advice:
    """What one indicator's move means.

    Attributes
    ----------
    measures : str
        What the indicator reads off the capture, in words.
    rising, falling : str
        The suspected fault when the reading rose, or fell. A one-sided indicator (only a rise
        is abnormal) has the same text in both.
    component : str
        The part to look at (empty when the method names none). ``{part}`` is replaced by the
        part the reading names (a gear stage or a bearing of the axis's profile).
    action, action_falling : str
        What to do when it rose, or fell.
    colour : str
        The indicator's colour in every chart and on the first screen. None is red, orange or
        green: the charts draw alarms, excursions and the baseline in those.
    """

    measures: str
    rising: str
    falling: str
    component: str
    action: str
    action_falling: str
    colour: str


#: The hint of a drive load's advice that a payload change moves it too.
TASK_CHANGE_HINT = "If the tool or payload changed, record it: axiswatch ack --task-changed."
_PLAY = "Check the drive train for play; a new lubricant also lowers friction."
#: The parts that carry the load on a rotary axis and on a linear one.
_DRIVE = "gearbox or ball screw"


def _drive_load(direction: str, colour: str) -> Advice:
    # Mean of torque x sign(speed) over steady motion one way: the torque that keeps the axis
    # moving at constant speed, so friction plus the payload's weight along that stroke. Its
    # code name says "load"; in a service engineer's words it is the friction of those moves.
    return Advice(
        measures=f"the torque that keeps the axis moving {direction} at steady speed",
        rising=f"friction rising in {direction} moves",
        falling=f"friction falling in {direction} moves",
        component="drive train lubrication",
        action=f"Check the lubrication of the {_DRIVE}: grease level, leaks, seals. "
        + TASK_CHANGE_HINT,
        action_falling=f"{_PLAY} {TASK_CHANGE_HINT}",
        colour=colour,
    )


#: Indicator code name (or the family before ``:``) -> what its move means, for the product
#: default (method ``indicators``); ``""`` is a method whose distance names no indicator (the
#: paper's PCA and LRA). Another method's indicators get :func:`advice_for`'s plain words.
ADVICE: dict[str, Advice] = {
    "coulomb_friction": Advice(
        measures="the friction torque that does not depend on speed",
        rising="friction rising",
        falling="friction falling",
        component="drive train lubrication",
        # A heavier payload raises the Coulomb friction of a gear train too (development
        # robots: a 5 kg payload alarmed a lone axis for as long as it was carried).
        action=f"Check the lubrication of the {_DRIVE}: grease level, leaks, seals. "
        + TASK_CHANGE_HINT,
        action_falling=_PLAY,
        colour="#1f77b4",
    ),
    "viscous_friction": Advice(
        measures="the friction torque that grows with speed",
        rising="friction rising with speed",
        falling="friction falling with speed",
        component="lubricant",
        action="Check the lubricant: grade, level and contamination.",
        action_falling=_PLAY,
        colour="#17becf",
    ),
    "load_forward": _drive_load("forward", "#393b79"),
    "load_backward": _drive_load("backward", "#8c6d31"),
    "impulsiveness": Advice(
        measures="short torque impacts while the axis moves",
        rising="impacts in the drive",
        falling="impacts in the drive",
        component="damage or play in the drive train",
        action=f"Inspect the {_DRIVE} for damage (a tooth, a ball track) or play.",
        action_falling=f"Inspect the {_DRIVE} for damage (a tooth, a ball track) or play.",
        colour="#9467bd",
    ),
    "gap_ringing": Advice(
        measures="ringing of the drive when its load changes side",
        rising="impacts at reversals",
        falling="impacts at reversals",
        component="backlash in the drive train",
        action=f"Measure the play at the axis output; service the {_DRIVE} if it grew.",
        action_falling=f"Measure the play at the axis output; service the {_DRIVE} if it grew.",
        colour="#637939",
    ),
    "tooth_lines": Advice(
        measures="vibration at the turn of a gear whose teeth are watched",
        rising="gear tooth damage",
        falling="gear tooth damage",
        component="{part}",
        action="Inspect the teeth of the {part} for wear, pitting or a broken tooth.",
        action_falling="Inspect the teeth of the {part} for wear, pitting or a broken tooth.",
        colour="#8c564b",
    ),
    "bearing_lines": Advice(
        measures="vibration at a bearing's defect frequencies",
        rising="bearing damage",
        falling="bearing damage",
        component="{part}",
        action="Plan the replacement of the {part}; meanwhile listen for noise and feel for heat.",
        action_falling="Plan the replacement of the {part}.",
        colour="#e377c2",
    ),
    "order_lines": Advice(
        measures="new or grown vibration lines locked to the axis's rotation",
        rising="new vibration in the drive",
        falling="new vibration in the drive",
        component="{part}",
        action="Inspect the {part}. The profile's kinematics name the part.",
        action_falling="Inspect the {part}.",
        colour="#bcbd22",
    ),
    "": Advice(
        measures="how far the whole capture's signals moved from the baseline's",
        rising="signals unlike the baseline's",
        falling="signals unlike the baseline's",
        component="",
        action="Look at the axis. This method also alarms on a task change; the default names "
        "the part.",
        action_falling="Look at the axis. This method also alarms on a task change; the default "
        "names the part.",
        colour="#555555",
    ),
}

#: Colours of indicators outside the table (another gear stage or bearing of a profile): chosen
#: by the name, so an indicator keeps its colour on every axis.
_SPARE_COLOURS = ("#7f7f7f", "#c49c94", "#f7b6d2", "#dbdb8d", "#aec7e8", "#ce6dbd")

#: The default part of each family whose reading names no part.
_DEFAULT_PART = {
    "tooth_lines": "gear stages",
    "bearing_lines": "bearings",
    "order_lines": "rotating parts of the drive",
}


def _family(name: str) -> str:
    return name.split(":", 1)[0]


def part_words(name: str, where: str | None = None) -> str:
    """The part an indicator names, in words: the profile's gear stage or bearing.

    Parameters
    ----------
    name : str
        The indicator's code name (``bearing_lines:motor_inner_race``).
    where : str, optional
        The component the score's details name (``order_lines``: where its lines grew).

    Examples
    --------
    >>> part_words("bearing_lines:motor_inner_race")
    'bearing motor inner race'
    >>> part_words("tooth_lines:intermediate")
    'gear stage intermediate'
    >>> part_words("order_lines", "new or grown order lines, most at order 12: bearing motor")
    'bearing motor'
    >>> part_words("order_lines", "new or grown order lines, most at order 12")
    'rotating parts of the drive'
    """
    family, _, own = name.partition(":")
    if own:
        kind = "gear stage" if family == "tooth_lines" else "bearing"
        return f"{kind} {own.replace('_', ' ')}"
    if where and ": " in where:
        return where.rsplit(": ", 1)[1].replace("_", " ")
    return _DEFAULT_PART.get(family, "")


def advice_for(name: str | None) -> Advice:
    """The row of :data:`ADVICE` for an indicator (its family's for a named part).

    Examples
    --------
    >>> advice_for("load_backward").rising
    'friction rising in backward moves'
    >>> advice_for("bearing_lines:motor_inner_race").rising
    'bearing damage'
    >>> advice_for(None).rising
    "signals unlike the baseline's"
    """
    if name is None:
        return ADVICE[""]
    family = _family(name)
    if family in ADVICE:
        return ADVICE[family]
    return Advice(
        measures=f"the reading {name}",
        rising="an unusual reading",
        falling="an unusual reading",
        component="not named",
        action="Look at the axis.",
        action_falling="Look at the axis.",
        colour=indicator_colour(name),
    )


def indicator_colour(name: str) -> str:
    """The indicator's colour: the table's, or one fixed by its name (the same on every axis).

    A named part (``bearing_lines:motor_inner_race``) gets one by its name: an axis with two
    bearings shows two colours.

    Examples
    --------
    >>> indicator_colour("gap_ringing")
    '#637939'
    >>> indicator_colour("bearing_lines:motor_inner_race")
    '#f7b6d2'
    """
    if name in ADVICE and name:
        return ADVICE[name].colour
    # A stable choice by the name's characters: hash() is salted per process.
    return _SPARE_COLOURS[sum(map(ord, name)) % len(_SPARE_COLOURS)]
