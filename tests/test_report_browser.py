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

ARTIFACTS = Path(__file__).resolve().parents[1] / "test-artifacts"

#: Ground truth of the demo (docs/monitor.md, "What the demo shows"): the simulator's faulty axes, and
#: the parts an indicator of the default method may name for their fault (a friction rise raises
#: the friction and the drive-load readings; the bearing is the one named in the demo's profile).
FAULTY = {
    "robot02/axis1": ("bearing motor_inner_race",),
    "robot03/axis2": ("friction", "drive load"),
}
#: A healthy axis the default calls over its threshold at the demo's last capture (docs/monitor.md,
#: "What the demo shows": robot02/axis2, Coulomb friction 1.25 x its task-change allowance on
#: 03-30). The fleet prior reads every pair of axes both ways, so the order of the robot folders
#: does not change this.
FALSE_ALARMS = {"robot02/axis2": ("friction",)}


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
    """The items of the attention list, and every chart ``<div>`` and whether Plotly drew it."""

    def __init__(self) -> None:
        super().__init__()
        self.items: dict[str, str] = {}
        self.kinds: dict[str, str] = {}
        self.charts: dict[str, bool] = {}
        self._item: str | None = None
        self._depth = 0

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        found = dict(attrs)
        if tag == "li" and found.get("data-axis"):
            self._item = str(found["data-axis"])
            self.items[self._item] = ""
            self.kinds[self._item] = str(found.get("data-kind"))
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

    loaded = _browse("--virtual-time-budget=10000", "--dump-dom", demo_report.as_uri())
    assert loaded.returncode == 0, loaded.stderr[-2000:]
    assert _console(loaded) == []

    screen = _FirstScreen()
    screen.feed(loaded.stdout)
    assert set(screen.items) == set(FAULTY) | set(FALSE_ALARMS), screen.items
    for axis, components in {**FAULTY, **FALSE_ALARMS}.items():
        line = screen.items[axis]
        assert screen.kinds[axis] == "alarm", (axis, screen.kinds[axis])
        # The indicator that moved, the part it watches, and by how much.
        assert any(f"({component}) " in line for component in components), line
        assert "spreads from its baseline" in line, line
        assert "since 2026-03-" in line, line
    # Every axis has its lead chart and the paper's methods chart, each drawn by Plotly.
    assert len(screen.charts) == 12, sorted(screen.charts)
    assert all(screen.charts.values()), screen.charts

    ARTIFACTS.mkdir(exist_ok=True)
    shot = ARTIFACTS / "report_first_screen.png"
    shot.unlink(missing_ok=True)
    taken = _browse(
        "--virtual-time-budget=10000", "--window-size=1280,1400", f"--screenshot={shot}",
        demo_report.as_uri(),
    )  # fmt: skip
    assert taken.returncode == 0, taken.stderr[-2000:]
    assert shot.stat().st_size > 10_000  # a rendered page, not a blank image
    print(f"screenshot of the report's first screen: {shot}")


@pytest.mark.slow
def test_readme_quotes_the_demo(demo_report: Path) -> None:
    """The monitor manual quotes the demo's stored reasons ("The store") and the alarm line
    `monitor` prints ("Rejected captures and exit status"): they are what the demo gives."""
    from typer.testing import CliRunner

    from axiswatch.cli import app
    from axiswatch.monitor._results import fleet_results
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
    (line,) = re.findall(r"`(robot02/axis1: ALARM since [^`]*)`", readme)
    shown = CliRunner().invoke(
        app,
        ["monitor", str(out / "fleet"), "--store", str(out / "fleet.db"), "--settle", "0"],
    )
    assert shown.exit_code == 4, shown.output
    assert f"  {line}\n" in shown.output


def test_an_acknowledged_rejection_leaves_the_first_screen(
    small_fleet: Path, tmp_path: Path
) -> None:
    # Before: the page read no acknowledgement of a rejection and listed both acknowledged
    # axes (robot01/axis1, the misnamed folder robot 2/) as bad data.
    from axiswatch.monitor._report import write_report
    from axiswatch.monitor.store import Store
    from tests.test_report import acknowledged_rejections

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
