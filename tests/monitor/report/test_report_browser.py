"""The demo's report in a real browser (headless Chromium): first screen, charts, console.

Runs ``axiswatch demo`` as a user does, opens its ``index.html`` from the file system in
Chromium with no network, and reads the page after its scripts ran (``--dump-dom``). Needs the
Debian ``chromium`` package: ``.ci/run`` installs it; elsewhere the test is skipped with the
reason when it is missing (in CI, ``CI=true``, a missing browser is a failure instead).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from html.parser import HTMLParser
from pathlib import Path

import pytest

from tests import _cli

ARTIFACTS = Path(__file__).resolve().parents[3] / "test-artifacts"

#: Ground truth of the demo (docs/monitor.md, "What the demo shows"): the simulator's faulty
#: axes, and words their verdict's fault must hold (the bearing is the demo profile's).
FAULTY = {"robot02/axis1": "bearing", "robot03/axis2": "friction"}
#: What the first screen must not show: indicator code names and statistics terms.
CODE_OR_STATISTICS = re.compile(
    r"coulomb_friction|viscous_friction|load_forward|load_backward|impulsiveness|gap_ringing|"
    r"bearing_lines|tooth_lines|order_lines|reversal_bursts|spread|half-Laplace|percentile|"
    r"\bpct\b|allowance",
    re.IGNORECASE,
)


def _chromium() -> str:
    for name in ("chromium", "chromium-browser"):
        found = shutil.which(name)
        if found:
            return found
    message = "no 'chromium' on PATH (Debian: apt-get install -y chromium; .ci/run installs it)"
    if os.environ.get("CI"):
        pytest.fail(f"CI must run the browser test: {message}")
    pytest.skip(message)


def _browse(*args: str) -> subprocess.CompletedProcess[str]:
    with tempfile.TemporaryDirectory(prefix="axiswatch-chromium-") as profile:
        return subprocess.run(
            [
                _chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                "--no-first-run", "--disable-background-networking", "--disable-component-update",
                "--disable-sync", f"--user-data-dir={profile}", "--enable-logging=stderr", "--v=0",
                *args,
            ],
            capture_output=True, text=True, timeout=180,
        )  # fmt: skip


def _console(run: subprocess.CompletedProcess[str]) -> list[str]:
    """Console messages and uncaught errors of the page (Chromium logs them as ``CONSOLE``)."""
    return [line for line in run.stderr.splitlines() if re.search(r":CONSOLE[:(]", line)]


def test_console_errors_are_seen(tmp_path: Path) -> None:
    # The control of the check below: a page that throws must show up.
    page = tmp_path / "broken.html"
    page.write_text("<html><body><script>undefinedFunction();</script></body></html>")
    messages = _console(_browse("--virtual-time-budget=2000", "--dump-dom", page.as_uri()))
    assert len(messages) == 1, messages
    assert "Uncaught ReferenceError: undefinedFunction is not defined" in messages[0]


class _FirstScreen(HTMLParser):
    """The items of the attention list in order, their kinds and states, every chart ``<div>``
    and whether Plotly drew it, and the page's visible text (set by :func:`_probe`)."""

    def __init__(self) -> None:
        super().__init__()
        self.items: dict[str, str] = {}
        self.kinds: dict[str, str] = {}
        self.states: dict[str, str] = {}
        self.charts: dict[str, bool] = {}
        self.visible = ""
        self._item: str | None = None
        self._depth = 0

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        found = dict(attrs)
        if tag == "html":
            self.visible = str(found.get("data-visible-text") or "")
        if tag == "li" and found.get("data-axis"):
            self._item = str(found["data-axis"])
            self.items[self._item] = ""
            self.kinds[self._item] = str(found.get("data-kind"))
            self.states[self._item] = str(found.get("data-state"))
            self._depth = 0
        elif self._item is not None and tag == "li":
            self._depth += 1
        identifier = found.get("id") or ""
        if tag == "div" and re.fullmatch(r"(chart|paper)-.+", identifier):
            self.charts[identifier] = "js-plotly-plot" in (found.get("class") or "")

    def handle_endtag(self, tag: str) -> None:
        if tag == "li" and self._item is not None:
            if self._depth == 0:
                self._item = None
            else:
                self._depth -= 1

    def handle_data(self, data: str) -> None:
        if self._item is not None:
            self.items[self._item] += data


def _probe(page: Path, folder: Path) -> Path:
    """A copy of ``page`` that keeps, once loaded, the text a reader sees (``innerText``:
    nothing folded, no script) on its ``<html>`` element, where ``--dump-dom`` shows it."""
    probe = folder / "probe.html"
    script = (
        "<script>window.addEventListener('load', function () { document.documentElement"
        ".setAttribute('data-visible-text', document.body.innerText); });</script>"
    )
    probe.write_text(page.read_text(encoding="utf-8").replace("</body>", script + "</body>"))
    return probe


@pytest.fixture(scope="module")
def demo_report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    _chromium()  # skip before the half-minute demo when there is no browser
    out = tmp_path_factory.mktemp("demo")
    done = _cli.run("demo", "--out", out)  # in this process: the report is the claim
    assert done.returncode == 0, done.stdout + done.stderr
    return out / "report" / "index.html"


@pytest.mark.slow
def test_demo_first_screen_names_the_faulty_axes_and_charts_render(demo_report: Path) -> None:
    page = demo_report.read_text(encoding="utf-8")
    # Nothing is fetched: no script, style or image from elsewhere.
    assert not re.search(r"""<(script|link|img)[^>]+(src|href)\s*=""", page)

    probe = _probe(demo_report, demo_report.parent.parent)
    loaded = _browse(
        "--virtual-time-budget=10000", "--window-size=1366,900", "--dump-dom", probe.as_uri()
    )
    assert loaded.returncode == 0, loaded.stderr[-2000:]
    assert _console(loaded) == []

    screen = _FirstScreen()
    screen.feed(loaded.stdout)
    # The two faulty axes first, each to act on now: the fault and the part in words, an action.
    order = list(screen.items)
    assert set(order[:2]) == set(FAULTY), screen.states
    for axis, fault in FAULTY.items():
        text = " ".join(screen.items[axis].split())
        assert screen.states[axis] == "act now", (axis, screen.states[axis])
        headline = text.split(" What to do: ")[0]
        assert fault in headline.lower(), text
        assert "Suspected: " in headline, text
        for said in ("What to do: ", "Over the alarm level since 2026-03-", "How sure: "):
            assert said in text, (said, text)
        assert "confirmed by" in text, text
    # Below them, any excursion of a healthy axis is marked unconfirmed, never "act now".
    for axis in order[2:]:
        assert screen.states[axis] != "act now", (axis, screen.states[axis])
        if screen.kinds[axis] == "alarm":
            assert screen.states[axis] == "watch, unconfirmed", (axis, screen.states[axis])
            assert "unconfirmed until the next capture" in screen.items[axis]
    # The demo's healthy robot02/axis2 is over its alarm level on its last capture only.
    assert screen.states.get("robot02/axis2") == "watch, unconfirmed", screen.states
    # What a reader sees first holds no code name and no statistics term.
    first = screen.visible[:1500]
    assert "Needs attention now (3)" in first, first
    assert "robot02/axis2" in first, first
    assert not CODE_OR_STATISTICS.search(first), CODE_OR_STATISTICS.search(first)
    # Every axis has its lead chart and the paper's methods chart, each drawn by Plotly.
    assert len(screen.charts) == 12, sorted(screen.charts)
    assert all(screen.charts.values()), screen.charts

    ARTIFACTS.mkdir(exist_ok=True)
    shot = ARTIFACTS / "report_first_screen.png"
    shot.unlink(missing_ok=True)
    taken = _browse(
        "--virtual-time-budget=10000", "--window-size=1366,900", f"--screenshot={shot}",
        demo_report.as_uri(),
    )  # fmt: skip
    assert taken.returncode == 0, taken.stderr[-2000:]
    assert shot.stat().st_size > 10_000  # a rendered page, not a blank image
    print(f"screenshot of the report's first screen: {shot}")


@pytest.mark.slow
def test_readme_quotes_the_demo(demo_report: Path) -> None:
    """The monitor manual quotes the demo's stored reasons ("The store") and the verdict
    `monitor` prints ("Rejected captures and exit status"): they are what the demo gives."""
    from typer.testing import CliRunner

    from axiswatch.cli import app
    from axiswatch.monitor.report.results import fleet_results
    from axiswatch.monitor.store import Store

    manual = ARTIFACTS.parent / "docs" / "monitor.md"
    readme = " ".join(manual.read_text(encoding="utf-8").split())
    out = demo_report.parent.parent
    with Store(out / "fleet.db", read_only=True) as store:
        reasons = fleet_results(store)["reason"].dropna().tolist()
    quoted = re.findall(r"`(distance [\d.]+ [^`]*)`", readme)
    assert len(quoted) == 2
    for reason in quoted:
        assert any(r.startswith(reason.removesuffix(" ...")) for r in reasons), reason
    (verdict,) = re.findall(r"`(ACT NOW robot02/axis1 [^`]*)`", readme)
    shown = CliRunner().invoke(
        app,
        ["monitor", str(out / "fleet"), "--store", str(out / "fleet.db"), "--settle", "0"],
    )
    assert shown.exit_code == 4, shown.output
    assert verdict in " ".join(shown.output.split())


def test_an_acknowledged_rejection_leaves_the_first_screen(
    small_fleet: Path, tmp_path: Path
) -> None:
    # Before: the page read no acknowledgement of a rejection and listed both acknowledged
    # axes (robot01/axis1, the misnamed folder robot 2/) as bad data.
    from axiswatch.monitor.report.html import write_report
    from axiswatch.monitor.store import Store
    from tests.monitor.report.test_report import acknowledged_rejections

    _chromium()
    fleet = Path(shutil.copytree(small_fleet, tmp_path / "fleet"))
    with Store(acknowledged_rejections(fleet, tmp_path)) as store:
        page = write_report(store, tmp_path / "report")
    loaded = _browse("--virtual-time-budget=5000", "--dump-dom", page.as_uri())
    assert loaded.returncode == 0, loaded.stderr[-2000:]
    assert _console(loaded) == []
    screen = _FirstScreen()
    screen.feed(loaded.stdout)
    assert screen.kinds == {"robot01/axis2": "bad data"}, screen.items
    assert "Needs attention now (1)" in loaded.stdout
    assert "1 capture file(s) rejected, seen on " in loaded.stdout.split('id="healthy"')[1]


def test_the_filter_box_hides_the_rows_without_its_words(small_fleet: Path, tmp_path: Path) -> None:
    # Before: the folded table of calm axes had no filter: on a fleet of 1,000 axes a reader
    # scrolled. The page's own script runs; the probe types "axis2" and reads the shown rows.
    from axiswatch.monitor._config import MonitorConfig
    from axiswatch.monitor._monitor import monitor_fleet
    from axiswatch.monitor.report.html import write_report
    from axiswatch.monitor.store import Store

    _chromium()
    fleet = Path(shutil.copytree(small_fleet, tmp_path / "fleet"))
    with Store(tmp_path / "s.db") as store:
        monitor_fleet(fleet, store, MonitorConfig(method="pca"), settle_s=0)
        page = write_report(store, tmp_path / "report")
    probe = tmp_path / "report" / "probe.html"
    script = (
        "<script>window.addEventListener('load', function () {"
        " var box = document.querySelector('#healthy input.filter');"
        " box.value = 'AXIS2'; box.dispatchEvent(new Event('input'));"
        " var shown = Array.from(box.nextElementSibling.querySelectorAll('tr.row'))"
        ".filter(function (r) { return r.style.display !== 'none'; })"
        ".map(function (r) { return r.cells[0].textContent; });"
        " document.documentElement.setAttribute('data-shown', shown.join(','));"
        " });</script>"
    )
    probe.write_text(page.read_text(encoding="utf-8").replace("</body>", script + "</body>"))
    loaded = _browse("--virtual-time-budget=5000", "--dump-dom", probe.as_uri())
    assert loaded.returncode == 0, loaded.stderr[-2000:]
    assert _console(loaded) == []
    shown = re.search(r"<html[^>]* data-shown=\"([^\"]*)\"", loaded.stdout)
    assert shown is not None, loaded.stdout[:500]
    assert shown.group(1) == "robot01/axis2"
