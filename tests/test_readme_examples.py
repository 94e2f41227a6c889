"""The README's and the manuals' examples as written: their Python blocks run, their command
lines name commands and options that exist (the cheap ones run on a small simulated fleet), their
TOML reads.

Each fenced block of the documents in :data:`DOCS` is preceded by a marker,
``<!-- tested: tests/...::name -->`` (executed by that test), ``<!-- checked: tests/...::name -->``
(its commands and options are checked, not run) or ``<!-- not run: why -->``. The section
"Monitor your own robot" of docs/monitor.md is run by tests/test_readme_own_robot.py. A new block
without a marker fails :func:`test_every_block_is_accounted_for`.
"""

from __future__ import annotations

import re
import shlex
import shutil
import sqlite3
import subprocess
import sys
import tomllib
from collections.abc import Iterator
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any

import pytest
import typer
from threadpoolctl import threadpool_limits
from typer.testing import CliRunner

import axiswatch as aw
import axiswatch.monitor as awm
from axiswatch.cli import PLUGIN_GROUP, app, monitor_defaults
from tests.conftest import settle
from tests.test_profile_command import _controller_export

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
MANUAL = ROOT / "docs" / "monitor.md"
#: The documents whose blocks and prose are tested: the README, then the manuals it links.
DOCS = (
    README,
    MANUAL,
    ROOT / "docs" / "library.md",
    ROOT / "docs" / "evaluation.md",
    ROOT / "docs" / "contributing.md",
)
TEXTS = {doc: doc.read_text(encoding="utf-8") for doc in DOCS}
#: The documents whose prose names real commands, options and API names (contributing.md's
#: prose names the classes its sketches would add).
PROSE = DOCS[:-1]
FLAT = " ".join(" ".join(text.split()) for text in TEXTS.values())  # line breaks as spaces
THIS = "tests/test_readme_examples.py"
FENCE = re.compile(r"^( *)```(\w*)\n(.*?)^\1```", flags=re.MULTILINE | re.DOTALL)
MARKER = re.compile(r"<!-- (tested|checked|not run): ([^>]*?) -->\n$")
OWN_ROBOT = "## Monitor your own robot"
runner = CliRunner()


def _section(doc: Path, heading: str) -> str:
    """The text of ``doc`` from ``heading`` to the next heading of its level or above."""
    text = TEXTS[doc]
    level = heading.split(" ", 1)[0]
    after = text.split(heading, 1)[1]
    return re.split(rf"\n#{{1,{len(level)}}} ", after, maxsplit=1)[0]


def _marked() -> list[tuple[str, str, str, Path]]:
    """(kind, what, body, document) of every fenced block outside "Monitor your own robot"."""
    found = []
    for doc, text in TEXTS.items():
        own = text.find(OWN_ROBOT)
        end = text.index("\n## ", own + 1) if own >= 0 else -1
        for fence in FENCE.finditer(text):
            if own <= fence.start() < end:
                continue
            before = text[: fence.start()].rsplit("\n", 2)
            marker = MARKER.search("\n".join(before[-2:]))
            kind, what = marker.groups() if marker else ("", "")
            found.append((kind, what, fence.group(3), doc))
    return found


def _found(name: str) -> tuple[str, Path]:
    """The body of the block marked as tested or checked by ``name``, and its document."""
    blocks = [(body, doc) for _, what, body, doc in _marked() if what == f"{THIS}::{name}"]
    assert len(blocks) == 1, f"the documents have {len(blocks)} blocks marked {name}"
    return blocks[0]


def _block(name: str) -> str:
    """The body of the block marked as tested or checked by ``name`` in this module."""
    return _found(name)[0]


def _cli() -> Any:
    """The click command tree of ``axiswatch``, with the entry-point groups (``experiment``)."""
    command = typer.main.get_command(app)
    for entry in entry_points(group=PLUGIN_GROUP):
        command.add_command(typer.main.get_command(entry.load()), entry.name)  # type: ignore[attr-defined]
    return command


CLI = _cli()


def _leaves(command: Any = CLI) -> Iterator[Any]:
    if hasattr(command, "commands"):
        for sub in command.commands.values():
            yield from _leaves(sub)
    else:
        yield command


def _options(command: Any) -> dict[str, Any]:
    return {
        name: param
        for param in command.params
        if param.param_type_name == "option"
        for name in (*param.opts, *param.secondary_opts)
    }


def _resolve(words: list[str]) -> tuple[Any, list[str]]:
    """The command a documented line names and the words after its name (``...`` stops)."""
    command = CLI
    while hasattr(command, "commands") and words and words[0] != "...":
        assert words[0] in command.commands, f"no command {words[0]!r} in {command.name!r}"
        command, words = command.commands[words[0]], words[1:]
    return command, words


def _check_line(line: str) -> None:
    """Every option of a documented command line exists on its command (``--a/--no-a``: both)."""
    words = [w.strip("[]") for w in shlex.split(line, comments=True)]
    command, rest = _resolve(words[1:] if words[0] == "axiswatch" else words)
    known = _options(command)
    for word in rest:
        if word.startswith("--"):
            for option in word.split("=")[0].split("/"):
                assert option in known, f"{line!r}: {command.name} has no option {option}"


def _command_lines(body: str) -> list[str]:
    """``axiswatch`` command lines of a fenced block, a continuation line joined to its own."""
    lines: list[str] = []
    for raw in body.splitlines():
        line = raw.strip().removeprefix(".venv/bin/")
        if line.startswith("axiswatch "):
            lines.append(line)
        elif line.startswith(("[", "--")) and lines:
            lines[-1] += " " + line
    return lines


# -- the inventory ---------------------------------------------------------------------------------


def test_every_block_is_accounted_for() -> None:
    blocks = _marked()
    own_robot = 6  # tests/test_readme_own_robot.py counts them: 5 Python blocks, 1 profile
    for doc, text in TEXTS.items():
        fence_lines = re.findall(r"^ *```", text, flags=re.MULTILINE)
        mine = sum(1 for *_, where in blocks if where == doc)
        assert len(fence_lines) == 2 * (mine + own_robot * (doc == MANUAL)), doc.name
    assert sum(1 for block in blocks if block[0] == "tested") >= 7
    for kind, what, body, doc in blocks:
        assert kind, f"{doc.name}: block without a marker: {body[:60]!r}"
        if kind != "not run":
            module, _, name = what.partition("::")
            assert module == THIS, what
            assert callable(globals().get(name)), what


# -- Python blocks ---------------------------------------------------------------------------------


@pytest.fixture
def demo_fleet(small_fleet_days: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """``demo/fleet`` in a fresh working folder: the README's paths, a small fleet."""
    shutil.copytree(small_fleet_days, tmp_path / "demo" / "fleet")
    settle(tmp_path / "demo" / "fleet")
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.fixture(scope="module")
def small_fleet_days(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The demo's fleet, 8 days of 0.5 s captures (the task changes and faults come later)."""
    root = tmp_path_factory.mktemp("readme") / "fleet"
    result = runner.invoke(
        app, ["simulate", "fleet", str(root), "--days", "8", "--duration", "0.5"]
    )
    assert result.exit_code == 0, result.output
    return root


def test_library_in_one_screen(
    small_fleet: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The block's files: one axis's captures under the names it reads, the fleet's profile.
    axis = tmp_path / "fleet" / "robot1" / "axis4"
    axis.mkdir(parents=True)
    files = sorted((small_fleet / "robot01" / "axis1").glob("*.parquet"))
    for path in files[:6]:
        shutil.copy(path, axis / path.name)
    shutil.copy(files[-1], axis / "2026-04-02.parquet")
    shutil.copy(small_fleet / "axiswatch.toml", tmp_path / "fleet" / "axiswatch.toml")
    monkeypatch.chdir(tmp_path)
    healthy = [Path("fleet/robot1/axis4") / p.name for p in files[1:6]]
    block, doc = _found("test_library_in_one_screen")
    names: dict[str, Any] = {"__name__": "readme", "healthy_paths": healthy}
    with threadpool_limits(1):
        exec(compile(block, str(doc), "exec"), names)

    verdict, model = names["verdict"], names["model"]
    assert verdict.threshold == model.threshold_
    assert verdict.alarm == (verdict.distance > verdict.threshold)
    promised = re.search(r"describe\(\)\s+# '(.*)'", block)
    assert promised is not None
    assert model.alarm_threshold_.describe() == promised.group(1)
    assert isinstance(names["paper"], aw.HealthModel)
    assert names["paper"].detector.__class__.__name__ == "LRADetector"
    default = names["default"]
    assert isinstance(default, aw.IndicatorModel)
    assert default.profile is not None
    assert default.profile.name == "simulated-axis"  # found at fleet/axiswatch.toml
    assert default.assess(aw.read_capture(axis / "2026-04-02.parquet")).threshold > 0


def test_monitoring_a_fleet_from_python(
    demo_fleet: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    block, doc = _found("test_monitoring_a_fleet_from_python")
    assert 'method="indicators"' in block
    assert aw.MonitorConfig().method == "indicators"
    names: dict[str, Any] = {"__name__": "readme"}
    with threadpool_limits(1):
        exec(compile(block, str(doc), "exec"), names)

    summary = names["summary"]
    alarms, rejected, exit_code = summary.alarms, summary.rejected, summary.exit_code
    assert capsys.readouterr().out.startswith(f"{alarms} {rejected} {exit_code}\n")
    assert exit_code == 8 * bool(rejected) + 4 * bool(alarms)
    with aw.Store("demo/fleet.db") as store:
        table = awm.fleet_summary(store)
    assert {"robot", "axis", "method", "state"} <= set(table.columns)
    assert not table.duplicated(["robot", "axis", "method"]).any()  # one row per axis and method
    assert set(table["method"]) == {"indicators"}
    assert len(table) >= 4
    assert (demo_fleet / "demo" / "report" / "index.html").is_file()


def test_use_it_from_python(
    small_fleet: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The README's library example on one axis's captures, under the names it reads."""
    axis = tmp_path / "fleet" / "robot1" / "axis4"
    axis.mkdir(parents=True)
    for path in sorted((small_fleet / "robot01" / "axis1").glob("*.parquet")):
        shutil.copy(path, axis / path.name)
    shutil.copy(small_fleet / "axiswatch.toml", tmp_path / "fleet" / "axiswatch.toml")
    monkeypatch.chdir(tmp_path)
    block, doc = _found("test_use_it_from_python")
    names: dict[str, Any] = {"__name__": "readme"}
    with threadpool_limits(1):
        exec(compile(block, str(doc), "exec"), names)

    model, verdict, files = names["model"], names["verdict"], names["files"]
    assert [path.name for path in files] == sorted(path.name for path in axis.iterdir())
    assert model.profile.name == "simulated-axis"  # found at fleet/axiswatch.toml
    assert verdict.scored
    assert verdict.alarm == (verdict.distance > verdict.threshold)
    assert not verdict.alarm  # a healthy axis on its own task
    assert isinstance(verdict.reason(), str)


def test_watch_a_fleet_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The README's session in order, on the demo's fleet cut to 8 days of 0.5 s captures."""
    monkeypatch.chdir(tmp_path)
    lines = _command_lines(_block("test_watch_a_fleet_folder"))
    assert [shlex.split(line, comments=True)[1] for line in lines] == [
        "simulate", "monitor", "results", "report",
    ]  # fmt: skip
    simulate, monitor, results, report = lines
    done = _invoke(simulate, "--days", "8", "--duration", "0.5")
    assert done.exit_code == 0, done.output
    assert {p.parent.parent.name for p in Path("demo/fleet").glob("*/*/*.parquet")} == {
        "robot01", "robot02", "robot03",
    }  # fmt: skip  # "3 robots with 2 axes each"
    assert len(list(Path("demo/fleet").glob("*/*"))) == 3 * 2
    settle(Path("demo/fleet"))
    with threadpool_limits(1):
        done = _invoke(monitor, "--no-progress")
        assert done.exit_code in (0, 4, 8, 12), done.output
        assert done.output.startswith("indicators: 48 capture files"), done.output
        with aw.Store("demo/fleet.db", read_only=True) as store:
            scored = len(store.score_table())
        # "run monitor again when new files arrive: it scores only what is new"
        again = _invoke(monitor, "--no-progress")
        assert again.exit_code == done.exit_code, again.output
        with aw.Store("demo/fleet.db", read_only=True) as store:
            assert len(store.score_table()) == scored
    done = _invoke(results)
    assert done.exit_code == 0, done.output
    assert "robot02" in done.output
    assert "robot01" not in done.output  # one axis's scores
    done = _invoke(report)
    assert done.exit_code == 0, done.output
    assert Path("demo/report/index.html").is_file()


def test_your_own_robots_files(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The README's own-files session on a controller-style export of two axes per file."""
    monkeypatch.chdir(tmp_path)
    lines = _command_lines(_block("test_your_own_robots_files"))
    assert [shlex.split(line, comments=True)[1] for line in lines] == [
        "profile", "monitor", "report",
    ]  # fmt: skip
    profile, monitor, report = lines
    exports = _controller_export(Path("exports/cell1"), days=7)
    words = shlex.split(profile.removeprefix(".venv/bin/"), comments=True)
    pattern = next(word for word in words if "*" in word)
    assert sorted(Path().glob(pattern)) == sorted(exports)
    profile_line = " ".join(word for word in words if word != pattern)
    done = _invoke(profile_line, *map(str, exports))
    assert done.exit_code == 0, done.output
    assert sorted(p.parent.name for p in Path("fleet").glob("*/*/axis.toml")) == ["A1", "A2"]
    settle(Path("fleet"))
    with threadpool_limits(1):
        done = _invoke(monitor, "--no-progress")
    assert done.exit_code == 0, done.output
    assert "14 capture files, 2 new baseline(s), 12 capture(s) scored" in done.output
    assert "Rejected" not in done.output
    done = _invoke(report)
    assert done.exit_code == 0, done.output
    assert Path("report/index.html").is_file()


# -- command lines ---------------------------------------------------------------------------------


def _fenced_lines() -> list[str]:
    return [
        line
        for kind, _, body, _ in _marked()
        if kind in ("tested", "checked")
        for line in _command_lines(body)
    ]


def test_fenced_command_lines_name_existing_options() -> None:
    lines = _fenced_lines()
    assert len(lines) >= 15
    for line in lines:
        _check_line(line)


def test_fenced_optional_values_are_the_defaults() -> None:
    """``[--seed 0]``: an optional option shown with a value shows its default."""
    shown = 0
    for line in _fenced_lines():
        command, _ = _resolve(shlex.split(line, comments=True)[1:])
        for name, value in re.findall(r"\[(--[\w-]+) ([^]\s|]+)\]", line):
            param = _options(command)[name]
            if name == "--data":  # None: the command reads ../shared/data, as its help says
                assert param.default is None, line
                assert value in param.help, line
            else:
                assert _same(param.default, value), f"{line!r}: {name} defaults to {param.default}"
            shown += 1
    assert shown >= 6


def _prose(text: str) -> str:
    """A document with its fenced blocks blanked (their ``#`` lines are no headings)."""
    return FENCE.sub(lambda m: "\n" * m.group(0).count("\n"), text)


def _spans() -> Iterator[tuple[str, str]]:
    """(section heading, code span) of every inline code span of the prose (a span may wrap)."""
    for doc in PROSE:
        prose = _prose(TEXTS[doc])
        headings = [
            (-1, ""),
            *((m.start(), m.group(1)) for m in re.finditer(r"^#{2,3} (.*)$", prose, re.M)),
        ]
        for span in re.finditer(r"`([^`]+)`", prose):
            section = [title for start, title in headings if start < span.start()][-1]
            yield section, " ".join(span.group(1).split())


COMMANDS = {
    "monitor", "results", "report", "rebaseline", "rejections", "ack", "backup", "compact", "demo"
}  # fmt: skip


def test_inline_command_lines_name_existing_options() -> None:
    spans = [
        span
        for _, span in _spans()
        if span.startswith("axiswatch ") or (span.split(" ", 1)[0] in COMMANDS and " --" in span)
    ]
    assert len(spans) >= 12
    for span in spans:
        _check_line(span)


#: The commands whose options a section's prose names alone (`--settle 10`).
SECTION_COMMANDS = {
    "Watch a fleet folder": {"monitor"},
    "Monitoring a fleet": {leaf.name for leaf in _leaves()},  # `--help`: every command
    "Delivering capture files": {"monitor"},
    "Monitor your own robot": {"monitor", "profile"},
    "What `monitor` does (defaults)": {"monitor"},
    "Rejected captures and exit status": {"monitor"},
    "The store (SQLite)": {"monitor", "results"},
    "What the demo shows (honestly)": {"monitor"},
    "Real data": {"monitor"},
    "Options that are off by default": {"monitor"},
    "An opt-in operating point: `--whole-moves`": {"monitor", "transfer"},
    "Modes: `--modes`": {"monitor"},
    "The paper's methods on recorded data": {"gearbox", "cwru"},
}
#: Sections that give an option's default as `--name value`.
DEFAULT_SECTIONS = {
    "Delivering capture files",
    "What `monitor` does (defaults)",
    "Rejected captures and exit status",
}
#: Options shown with a value that is not their default: the manual says "off by default".
EXAMPLE_VALUES = {"--task-envelope": None}


def _same(default: Any, value: str) -> bool:
    try:
        return float(default) == float(value)
    except (TypeError, ValueError):
        return str(default) == value


def test_options_in_the_prose_exist_with_the_defaults_it_gives() -> None:
    leaves = {leaf.name: leaf for leaf in _leaves()}
    checked = 0
    for section, span in _spans():
        if not span.startswith("--"):
            continue
        assert section in SECTION_COMMANDS, f"{span!r} in section {section!r}: which command?"
        name, _, value = span.partition(" ")
        options = [_options(leaves[c]) for c in SECTION_COMMANDS[section]]
        if name == "--help":  # "Every command has `--help`."
            assert all(leaves[c].add_help_option for c in SECTION_COMMANDS[section])
            continue
        owners = [o[name] for o in options if name in o]
        assert owners, f"{span!r} ({section}): no such option of {SECTION_COMMANDS[section]}"
        checked += 1
        if section not in DEFAULT_SECTIONS or not value or value.isupper():
            continue
        (param,) = owners
        # monitor's options default to None: the monitor's own default, shown in its help
        default = monitor_defaults().get(param.name) if param.default is None else param.default
        if name in EXAMPLE_VALUES:
            assert param.default == EXAMPLE_VALUES[name], span
        elif "|" in value:  # the choices, the default first
            choices = value.split("|")
            assert set(choices) <= set(awm.methods()), span
            assert default == choices[0], span
        else:
            assert _same(default, value), f"{span!r}: the default is {default!r}"
    assert checked >= 25


def test_benchmark_command_lines_name_existing_options() -> None:
    shown = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "run.py"), "--help"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    body = _block("test_benchmark_command_lines_name_existing_options")
    lines = [line for line in body.splitlines() if "benchmarks/run.py" in line]
    assert len(lines) == 5
    for line in lines:
        for word in shlex.split(line, comments=True):
            if word.startswith("--") and word != "--case":  # --case is hidden from --help
                assert re.search(rf"(?<![\w-]){re.escape(word)}(?![\w-])", shown), line
    assert "--case" in (ROOT / "benchmarks" / "run.py").read_text(encoding="utf-8")


def _invoke(line: str, *more: str) -> Any:
    words = shlex.split(line.removeprefix(".venv/bin/"), comments=True)
    assert words[0] == "axiswatch"
    return runner.invoke(app, [*words[1:], *more])


def test_monitoring_a_fleet_commands(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The block's commands in order, on the demo's fleet cut to 8 days of 0.5 s captures."""
    monkeypatch.chdir(tmp_path)
    lines = _command_lines(_block("test_monitoring_a_fleet_commands"))
    assert [shlex.split(line)[1] for line in lines] == [
        "simulate", "monitor", "monitor", "monitor", "results", "report", "ack", "backup",
    ]  # fmt: skip
    simulate, *monitors, results, report, ack, backup = lines
    done = _invoke(simulate, "--days", "8", "--duration", "0.5")
    assert done.exit_code == 0, done.output
    # "captures, labels.csv, axiswatch.toml"
    assert len(list(Path("demo/fleet").glob("*/*/*.parquet"))) == 3 * 2 * 8
    assert Path("demo/fleet/labels.csv").is_file()
    assert Path("demo/fleet/axiswatch.toml").is_file()
    settle(Path("demo/fleet"))  # delivered long ago, as `--settle` expects
    with threadpool_limits(1):
        for line, method in zip(monitors, ("indicators", "lra", "pca"), strict=True):
            done = _invoke(line, "--no-progress")
            assert done.exit_code in (0, 4, 8, 12), done.output
            assert done.output.startswith(f"{method}: 48 capture files"), done.output
    # "the summary printed by `monitor`, whose columns are robot, axis, ... and rejected"
    promised = re.search(r"whose columns are ([\w, ]+) and (\w+),", FLAT)
    assert promised is not None
    columns = [*promised.group(1).split(", "), promised.group(2)]
    assert done.output.splitlines()[1].split() == columns

    done = _invoke(results)
    assert done.exit_code == 0, done.output
    header, *rows = done.output.splitlines()
    # "one row per scored capture with `robot, ..., alarm` (then `captured_at, ...`)"
    promised = re.search(r"scored capture with `([\w, ]+)` \(then `([\w, ]+)`\)", FLAT)
    assert promised is not None
    assert header.split(",") == f"{promised.group(1)}, {promised.group(2)}".split(", ")
    assert rows
    assert all(row.startswith("robot02,axis1,") for row in rows)
    assert {row.split(",")[3] for row in rows} == {"indicators", "lra", "pca"}

    done = _invoke(report)
    assert done.exit_code == 0, done.output
    assert Path("demo/report/index.html").is_file()  # the comment's promise

    # No alarm on robot02/axis1 in 8 days (its bearing defect starts on day 20): `ack` refuses
    # an axis that is not in alarm, with one line, as the manual says.
    done = _invoke(ack)
    assert done.exit_code == 1
    assert "not in alarm" in done.output
    assert done.output.count("\n") == 1
    done = runner.invoke(app, ["ack", "--store", "demo/fleet.db", "--list"])
    assert done.exit_code == 0
    assert "No acknowledgements." in done.output

    done = _invoke(backup)
    assert done.exit_code == 0, done.output
    with aw.Store("demo/fleet-backup.db", read_only=True) as copy:
        assert len(copy.score_table()) > 0
    assert _invoke(backup).exit_code == 1  # it never overwrites a file

    # `axiswatch rejections --store S`, then the block's --ack and --retry with S the store.
    listed = runner.invoke(app, ["rejections", "--store", "demo/fleet.db"])
    promised = re.search(r"changed file \(([\w, ]+)\)", FLAT)
    assert promised is not None
    assert listed.exit_code == 0
    assert listed.output.splitlines()[0].split() == promised.group(1).split(", ")
    for line in _command_lines(_block("test_rejections_commands")):
        done = _invoke(line.replace("--store S", "--store demo/fleet.db").replace("[PATH ...]", ""))
        assert done.exit_code == 0, done.output
    # The store's tables are the manual's table of them.
    with sqlite3.connect("demo/fleet.db") as connection:
        tables = {
            row[0]
            for row in connection.execute("SELECT name FROM sqlite_master WHERE type='table'")
        }
        (version,) = connection.execute("SELECT version FROM schema_version").fetchone()
    store = _section(MANUAL, "## The store (SQLite)")
    assert tables == set(re.findall(r"^\| `(\w+)` \|", store, flags=re.MULTILINE))
    assert f"the schema version ({version};" in store
    # `axiswatch rebaseline --store S --robot R --axis A`
    done = runner.invoke(
        app, ["rebaseline", "--store", "demo/fleet.db", "--robot", "robot01", "--axis", "axis1"]
    )
    assert done.exit_code == 0, done.output
    assert "baseline retired" in done.output


def test_rejections_commands() -> None:
    """The block's two lines: run by :func:`test_monitoring_a_fleet_commands` on its store."""
    lines = _command_lines(_block("test_rejections_commands"))
    assert [shlex.split(line, comments=True)[2:] for line in lines] == [
        ["--store", "S", "--retry", "[PATH", "...]"],
        ["--store", "S", "--ack", "[PATH", "...]"],
    ]


# -- TOML and the other blocks ---------------------------------------------------------------------


def test_the_own_robot_profile_reads_as_described(tmp_path: Path) -> None:
    """The TOML of "Monitor your own robot", step 2, through tomllib and AxisProfile."""
    section = _section(MANUAL, OWN_ROBOT)
    (toml,) = re.findall(r'write_text\(\n    """(.*?)"""', section, flags=re.DOTALL)
    data = tomllib.loads(toml)
    assert data["units"] == {"time": "ms", "position": "deg"}
    path = tmp_path / "axiswatch.toml"
    path.write_text(toml, encoding="utf-8")
    profile = aw.AxisProfile.from_toml(path)
    assert profile.name == "demo-wrist"
    assert dict(profile.columns) == {
        "Timestamp": "time", "J2_ActPos": "position", "J2_Current": "torque",
    }  # fmt: skip
    assert (profile.time_unit, profile.position_unit) == ("ms", "deg")
    assert profile.gear_ratio is None  # every field optional: no kinematics given


def test_the_simulated_fleet_profile_has_the_kinematics_named(small_fleet: Path) -> None:
    """ "the simulated axis's kinematics as the fleet's profile ROOT/axiswatch.toml" and "gear
    ratio, the tooth stage, the bearing's defect order"."""
    tomllib.loads((small_fleet / "axiswatch.toml").read_text(encoding="utf-8"))
    profile = aw.AxisProfile.find(small_fleet, "robot01", "axis1")
    assert profile is not None
    assert profile.gear_ratio is not None
    assert profile.gear_ratio > 1
    assert len(profile.gear_stages) == 1
    assert len(profile.bearing_orders) == 1


def test_fleet_layout_example() -> None:
    from axiswatch.monitor._fleet import parse_capture_time

    line = _block("test_fleet_layout_example").strip()
    example = Path(line.split("e.g. ", 1)[1])
    assert example.parts[1:3] == ("robot01", "axis4")
    assert parse_capture_time(example.name).isoformat() == "2026-03-01T06:00:00"
    assert example.suffix in line.split()[0]


def test_layout_names_existing_modules() -> None:
    body = _block("test_layout_names_existing_modules")
    parts = ("", "indicators", "paper", "monitor", "datasets", "cli")
    product = [ROOT / "src" / "axiswatch" / part for part in parts]
    modules = {p.stem for folder in product for p in folder.glob("_*.py")} - {
        "__init__",
        "__main__",
    }
    named = set(re.findall(r"(?<![\w.])(_[a-z]+(?:_[a-z]+)*)\b", body))
    assert named == modules, f"not in the layout: {modules - named}; gone: {named - modules}"
    for folder in re.findall(r"^\s*(src/\S+/)", body, flags=re.MULTILINE):
        assert (ROOT / folder).is_dir(), folder
    assert "cli/" in body
    assert (ROOT / "src" / "axiswatch" / "cli" / "__init__.py").is_file()
    for module in (ROOT / "src" / "axiswatch" / "monitor" / "report").glob("[a-z]*.py"):
        assert re.search(rf"\b{module.stem}\b", body), f"not in the layout: report/{module.name}"


def test_delivering_capture_files(
    small_fleet: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The block's ``cp`` then ``mv``: the monitor sees nothing, then the whole file."""
    from axiswatch.monitor._fleet import discover_fleet

    monkeypatch.chdir(tmp_path)
    shutil.copy(next((small_fleet / "robot01" / "axis1").glob("*.parquet")), "capture.parquet")
    Path("fleet/robot01/axis4").mkdir(parents=True)
    (cp, source, partial), (mv, moved, final) = (
        shlex.split(line, comments=True)
        for line in _block("test_delivering_capture_files").splitlines()
    )
    assert (cp, source, mv, moved) == ("cp", "capture.parquet", "mv", partial)
    shutil.copy(source, partial)
    assert discover_fleet(Path("fleet"))[0] == []  # hidden: ignored
    Path(moved).rename(final)
    (found,), problems = discover_fleet(Path("fleet"))
    assert found.path == Path("fleet") / Path(final).relative_to("fleet")
    assert problems == []
    assert aw.read_capture(final).rates_hz == aw.read_capture(source).rates_hz


#: Dotted names of the prose that are no Python attributes: a file name, an entry-point group.
NOT_ATTRIBUTES = {"axiswatch.toml", "axiswatch.methods"}


def _lookup(name: str) -> Any:
    """A name the prose uses bare or dotted: from ``aw``, ``axiswatch.monitor`` or datasets."""
    import axiswatch.datasets as awd

    dotted = name.removeprefix("aw.").removeprefix("axiswatch.").split(".")
    for space in (aw, awm, awd):
        found: Any = space
        for part in dotted:
            found = getattr(found, part, None)
        if found is not None:
            return found
    return None


def test_api_names_and_keywords_in_the_prose_exist() -> None:
    """`aw.X`, `axiswatch.monitor.X`, `IndicatorModel(order_lines=True)`: each name exists and
    each keyword is a parameter of the call it is given to."""
    import inspect

    checked = 0
    for _, span in _spans():
        dotted = re.fullmatch(r"((?:aw|axiswatch)(?:\.\w+)+)(\(.*\))?", span)
        if dotted and dotted.group(1) not in NOT_ATTRIBUTES:
            assert _lookup(dotted.group(1)) is not None, span
            checked += 1
        text, call = span, re.compile(r"([\w.]+)\(([^()]*)\)")  # innermost calls first
        while call.search(text):
            for name, arguments in call.findall(text):
                target = _lookup(name)
                if target is None:
                    assert not name[0].isupper(), f"{span!r}: no {name} in axiswatch"
                    continue  # max(...), prctl(...), a method such as reason()
                parameters = inspect.signature(target).parameters
                for keyword in re.findall(r"(?<![\w.])(\w+)=", arguments):
                    assert keyword in parameters, f"{span!r}: {name} has no parameter {keyword}"
                    checked += 1
            text = call.sub("_", text)
    assert checked >= 20
    for detector in (aw.PCADetector, aw.LRADetector):  # fit(X_baseline), distance, transform
        assert all(callable(getattr(detector, m, None)) for m in ("fit", "distance", "transform"))
    assert "solver" in inspect.signature(aw.lra_embedding).parameters  # `solver="dense"`
