"""The mode library's verdict as the monitor's decision, kept per baseline in the store.

With ``MonitorConfig.modes``, each baseline of the ``indicators`` method keeps a
:class:`~axiswatch.indicators._mode_library.ModeLibrary`. Every capture of a moving axis gets a
verdict: scored in its mode's normal, or by the guard while its mode is learned. The library
learns only from captures it scored healthy, and an engineer teaches it a mode change
(``axiswatch ack --task-changed``).
"""

from __future__ import annotations

import dataclasses
import math
import pickle
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from axiswatch.monitor._decision import AxisHistory, Decision, DecisionRule, alarm_step

if TYPE_CHECKING:
    from axiswatch.indicators._mode_library import ModeAssessment, ModeLibrary
    from axiswatch.indicators._modes import CaptureDescription
    from axiswatch.monitor.store.protocols import _ModeLibraries

__all__ = ["AxisModes", "ModeBook", "load_axis_modes", "mode_decision", "teach_mode"]

#: Healthy captures under the threshold, per capture: a false alarm in 1,000 captures, split
#: between the readings and the torque spectrum (the library's default, chosen on development
#: robots).
MODE_PERCENTILE = 99.9
#: Alarmed captures whose description is kept, so that ``ack --task-changed`` can teach them.
KEPT_ALARMS = 8


@dataclass
class AxisModes:
    """What one baseline keeps: its library, its recent verdicts and its recent alarms."""

    library: ModeLibrary
    recent: list[tuple[bool, bool]] = field(default_factory=list)
    alarmed: dict[str, CaptureDescription] = field(default_factory=dict)


#: What an unreadable stored library raises when loaded: a damaged row, or a class since renamed.
_UNREADABLE = (pickle.UnpicklingError, EOFError, AttributeError, ImportError, IndexError,
               TypeError, ValueError)  # fmt: skip


def load_axis_modes(blob: bytes) -> AxisModes | str:
    """A stored library, or why it cannot be read (one line)."""
    try:
        modes = pickle.loads(blob)
    except _UNREADABLE as exc:
        return f"{type(exc).__name__}: {exc}".splitlines()[0]
    if not isinstance(modes, AxisModes):
        return f"a {type(modes).__name__}, not a mode library"
    return modes


def new_axis_modes(n_fit: int) -> AxisModes:
    """An empty library: ``n_fit`` captures of a mode before it is known."""
    from axiswatch.indicators._mode_library import ModeLibrary

    return AxisModes(ModeLibrary(n_fit=n_fit, percentile=MODE_PERCENTILE))


def guarded(verdict: ModeAssessment, baseline: float, top: str | None) -> ModeAssessment:
    """A learning capture's verdict, also guarded by the baseline model's score (its task's
    spreads, or its fleet's allowance for a task change) when that is higher."""
    guard = verdict.score if math.isfinite(verdict.score) else -math.inf
    if verdict.state != "learning" or not baseline > guard:
        return verdict
    where = f"{top or 'baseline'}, against the baseline"
    return dataclasses.replace(verdict, score=baseline, alarm=baseline > 1.0, where=where)


def _state_words(verdict: ModeAssessment) -> str:
    if verdict.state == "learning":
        return f"mode {verdict.mode}: learning new mode ({verdict.n_seen} of {verdict.n_fit})"
    if verdict.state == "drift":
        return f"mode {verdict.mode}: drifted from its first fit"
    return f"mode {verdict.mode}"


def mode_decision(
    verdict: ModeAssessment, recent: list[tuple[bool, bool]], rule: DecisionRule
) -> Decision:
    """The monitor's decision from a library's verdict: over when the score passes 1 (the
    threshold) or the mode drifted; the alarm by the rule's k of n and m clean captures."""
    over = bool(verdict.alarm)
    previous = bool(recent[-1][1]) if recent else False
    overs = [o for o, _ in recent[-rule.window :]] + [over]
    alarm = alarm_step(previous, overs, k=rule.alarm_k, n=rule.alarm_n, m=rule.clear_m)
    words = _state_words(verdict)
    if math.isfinite(verdict.score):
        words += f"; score {verdict.score:.3g} {'>' if verdict.score > 1 else '<='} threshold 1"
        if verdict.where and over:
            words += f" ({verdict.where})"
    elif verdict.state == "learning":
        words += "; no guard yet (a second known mode sets it)"
    if alarm and not previous:
        words += "; ALARM raised"
    elif alarm:
        words += "; alarm persists"
    elif previous:
        words += "; alarm cleared"
    else:
        words += "; healthy"
    details: dict[str, Any] = {
        "mode": verdict.mode,
        "mode_state": verdict.state,
        "mode_seen": verdict.n_seen,
        "mode_fit": verdict.n_fit,
        "false_alarm_rate": verdict.false_alarm_rate,
    }
    if verdict.where:
        details["mode_where"] = verdict.where
        if over:
            details["top_indicator"] = verdict.where
    return Decision("monitor", 1.0, over, alarm, words, details=details)


class ModeBook:
    """The mode libraries of the baselines a run scores: read once, saved with the scores."""

    def __init__(self, store: _ModeLibraries, rule: DecisionRule, n_fit: int) -> None:
        self.store, self.rule, self.n_fit = store, rule, n_fit
        self._axes: dict[int, AxisModes] = {}
        #: Baselines whose stored library could not be read: why, said once in a reason.
        self._unreadable: dict[int, str] = {}

    def axis(self, baseline_id: int) -> AxisModes:
        """The baseline's library, from the store, or new (none stored, or none readable)."""
        if baseline_id not in self._axes:
            blob = self.store.mode_library(baseline_id)
            loaded = new_axis_modes(self.n_fit) if blob is None else load_axis_modes(blob)
            if isinstance(loaded, str):
                self._unreadable[baseline_id] = loaded
                loaded = new_axis_modes(self.n_fit)
            self._axes[baseline_id] = loaded
        return self._axes[baseline_id]

    def decide(
        self,
        baseline_id: int,
        description: CaptureDescription,
        capture: str,
        baseline: tuple[float, str | None] = (math.nan, None),
    ) -> tuple[float, Callable[[AxisHistory], Decision], Callable[[], None]]:
        """The capture's score, its decision, and what to do once it is stored: learn from it
        (or keep it while in alarm) and save the library, right after the score is written
        (a run killed between the two leaves the library without that capture).

        ``baseline``: the axis's baseline model's score of the capture, in thresholds, and its
        top indicator. It guards a new mode too: where the fleet's task-change allowance
        applies, or the capture is of the baseline's own task."""
        modes = self.axis(baseline_id)
        verdict = guarded(modes.library.score(description), *baseline)
        decision = mode_decision(verdict, modes.recent, self.rule)
        if baseline_id in self._unreadable:
            why = self._unreadable.pop(baseline_id)
            decision = dataclasses.replace(
                decision,
                reason=f"the stored mode library could not be read ({why}): the axis learns "
                f"its modes again; {decision.reason}",
            )

        def stored() -> None:
            modes.recent = [*modes.recent, (decision.over, decision.alarm)][-self.rule.window :]
            if not modes.library.learn(description, verdict) and verdict.alarm:
                modes.alarmed[capture] = description
                while len(modes.alarmed) > KEPT_ALARMS:
                    del modes.alarmed[next(iter(modes.alarmed))]
            self.store.save_mode_library(baseline_id, pickle.dumps(modes))

        score = verdict.score if math.isfinite(verdict.score) else 0.0
        return score, lambda history: decision, stored


def teach_mode(
    store: _ModeLibraries, baseline_id: int, since: str, *, new_mode: bool = True
) -> dict[str, str]:
    """Teach the baseline's library the alarmed captures from ``since`` on as healthy.

    ``new_mode``: the alarm was a mode change (``ack --task-changed``), and the captures start
    or join a new mode; else a false alarm (``ack --false-alarm``), and they join the mode
    they were scored in, which starts again if it had drifted. Returns capture -> the mode it
    joined (empty when the baseline keeps no mode library or none of those captures)."""
    blob = store.mode_library(baseline_id)
    modes = None if blob is None else load_axis_modes(blob)
    if not isinstance(modes, AxisModes):
        return {}  # none kept, or none readable: the next run learns the modes again
    captures = list(modes.alarmed)
    taught = {}
    learn = modes.library.teach if new_mode else modes.library.accept
    for capture in captures[captures.index(since) :] if since in captures else []:
        taught[capture] = learn(modes.alarmed.pop(capture))
    if taught:
        modes.recent = [(False, False)]  # the alarm was not a fault: cleared
        store.save_mode_library(baseline_id, pickle.dumps(modes))
    return taught
