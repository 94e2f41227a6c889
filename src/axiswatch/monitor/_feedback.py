"""The engineer's feedback on an alarm: the verdicts ``axiswatch ack`` records.

A verdict is optional; an acknowledgement without one says only that someone saw the alarm.
The store keeps the verdict's name; the report and the terminal say it in words.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["ACK_VERDICTS", "alarm_feedback", "check_verdict", "feedback_words"]

#: Verdict name -> what it says, in the words the report uses. The names are the ``ack`` options
#: without their dashes.
ACK_VERDICTS: dict[str, str] = {
    "fault-confirmed": "fault confirmed",
    "false-alarm": "marked a false alarm",
    "task-changed": "reported a task change",
}


def check_verdict(verdict: str | None) -> None:
    """Refuse a verdict that is not one of :data:`ACK_VERDICTS`.

    Examples
    --------
    >>> check_verdict("false-alarm")
    >>> check_verdict("maybe")
    Traceback (most recent call last):
    ...
    ValueError: The 'verdict' parameter must be one of fault-confirmed, false-alarm, \
task-changed or None. Got 'maybe' instead.
    """
    if verdict is not None and verdict not in ACK_VERDICTS:
        raise ValueError(
            f"The 'verdict' parameter must be one of {', '.join(ACK_VERDICTS)} or None. "
            f"Got {verdict!r} instead."
        )


def feedback_words(verdict: str | None, by: str, when: str, note: str) -> str:
    """One sentence on an acknowledgement: who, what they concluded, when, and their note.

    Examples
    --------
    >>> feedback_words("false-alarm", "ana", "2026-04-01T08:00:00+00:00", "new gripper")
    'ana marked a false alarm on 2026-04-01: new gripper.'
    >>> feedback_words(None, "ana", "2026-04-01T08:00:00+00:00", "seen")
    'ana saw it on 2026-04-01: seen.'
    """
    what = ACK_VERDICTS.get(verdict or "", "saw it")
    return f"{by} {what} on {str(when)[:10]}: {note.rstrip('.')}."


def alarm_feedback(results: pd.DataFrame, acks: pd.DataFrame) -> list[str | None]:
    """The feedback on each score's alarm: the latest acknowledgement of the alarm it is part of.

    Parameters
    ----------
    results : DataFrame
        Scores ordered by robot, axis, method and capture time (``StoreBackend.score_table``).
    acks : DataFrame
        ``StoreBackend.acknowledgements()``: each names the capture that raised the alarm seen.

    Returns
    -------
    list of str or None
        Per score: the verdict (``false-alarm``, ...), ``seen`` for an acknowledgement without
        one, ``re-baselined`` for a re-baseline without one; None outside acknowledged alarms.

    Examples
    --------
    >>> import pandas as pd
    >>> scores = pd.DataFrame({"robot": "r", "axis": "a", "method": "m", "epoch": 1,
    ...                        "capture": ["c1", "c2", "c3", "c4"],
    ...                        "alarm": [False, True, True, False]})
    >>> acks = pd.DataFrame({"robot": ["r"], "axis": ["a"], "method": ["m"], "capture": ["c2"],
    ...                      "rebaseline": [False], "verdict": ["false-alarm"]})
    >>> alarm_feedback(scores, acks)
    [None, 'false-alarm', 'false-alarm', None]
    """
    said: dict[tuple[object, ...], str] = {}
    for ack in acks.itertuples(index=False):
        if isinstance(ack.capture, str):  # a re-baseline of an axis not in alarm names none
            verdict = getattr(ack, "verdict", None)
            fallback = "re-baselined" if ack.rebaseline else "seen"
            said[(ack.robot, ack.axis, ack.method, ack.capture)] = (
                verdict if isinstance(verdict, str) else fallback
            )
    out: list[str | None] = []
    current: str | None = None
    previous: tuple[object, ...] | None = None
    for row in results.itertuples(index=False):
        group = (row.robot, row.axis, row.method, row.epoch)
        if group != previous or not row.alarm:
            current = None
        if row.alarm and current is None:
            current = said.get((row.robot, row.axis, row.method, row.capture), "")
        out.append(current or None)
        previous = group
    return out
