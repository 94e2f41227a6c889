"""What a rise of an indicator most likely means, in one line for a reason or a report.

Plain Python: the monitor words a score's reason without importing the paper's models.
"""

from __future__ import annotations

__all__ = ["LIKELY_FAULTS", "describe_top_indicator"]


#: What a rise of an indicator most likely means, by the name a score's ``indicators`` details
#: give it: the fault it watches, for the monitor's reasons and report.
LIKELY_FAULTS: dict[str, str] = {
    "viscous_friction": "friction (lubrication, seals, wear)",
    "viscous_friction_deficit": "lost motion (backlash) breaking the energy balance",
    "impulsiveness": "impacts (backlash, or damage in the gearbox or ball screw)",
    "reversal_bursts": "backlash in the drive train",
    "tooth_lines": "a damaged gear tooth",
    "bearing_lines": "a bearing defect",
}


def describe_top_indicator(explanation: dict[str, dict[str, float]]) -> str | None:
    """One line on the indicator with the largest share of the distance, and what it means.

    Parameters
    ----------
    explanation : dict
        A score's ``indicators`` details: per indicator its ``spreads`` and ``share``.

    Returns
    -------
    str or None
        None when no indicator moved up (distance 0).

    Examples
    --------
    >>> describe_top_indicator({"bearing_lines": {"value": 9.0, "baseline": 1.1,
    ...                                           "spreads": 5.04, "share": 0.82}})
    'bearing_lines +5.0 healthy spreads (82 % of the distance): likely a bearing defect'
    """
    moved = [(entry["share"], name) for name, entry in explanation.items() if entry["share"] > 0]
    if not moved:
        return None
    share, name = max(moved)
    spreads = explanation[name]["spreads"]
    meaning = LIKELY_FAULTS.get(name)
    text = f"{name} {spreads:+.1f} healthy spreads ({100 * share:.0f} % of the distance)"
    return text + (f": likely {meaning}" if meaning else "")
