"""The monitor's list of rejected captures says a reason shared by several files once."""

from __future__ import annotations

from axiswatch.monitor.report.summary import fold_same_reason


def test_a_shared_reason_is_said_once_at_its_first_file_with_the_count_of_the_others() -> None:
    lines = [
        "r1/a1/d1.csv: r1/robot.toml: bad key",
        "r2/a1/d1.csv: empty file",
        "r1/a1/d2.csv: r1/robot.toml: bad key",
        "r1/a2/d1.csv: r1/robot.toml: bad key",
        "r2/a1/d2.csv: ends inside a row",
    ]
    assert fold_same_reason(lines) == [
        "r1/a1/d1.csv (and 2 more capture files with this reason): r1/robot.toml: bad key",
        "r2/a1/d1.csv: empty file",
        "r2/a1/d2.csv: ends inside a row",
    ]


def test_lines_of_one_file_each_are_unchanged() -> None:
    lines = ["r/a/x.csv: empty file", "r/a/y.csv: not a capture", "r/a/z.csv: empty file."]
    assert fold_same_reason(lines) == lines


def test_a_line_without_a_path_is_never_folded() -> None:
    # No "PATH: " to fold on (a misnamed folder's line is one for its folder): kept as it is,
    # even twice.
    lines = ["folder robot 2 is not a robot folder", "folder robot 2 is not a robot folder"]
    assert fold_same_reason(lines) == lines


def test_slow_twin_every_file_is_counted_once() -> None:
    # The obvious count: a folded line's files (1 + N) add up to the lines given, per reason.
    lines = [f"r/a{i % 3}/d{i}.csv: reason {i % 4}" for i in range(40)]
    folded = fold_same_reason(lines)
    counted = {}
    for line in folded:
        head, _, reason = line.partition(": ")
        more = head.split("(and ")[1].split(" more")[0] if "(and " in head else "0"
        counted[reason] = 1 + int(more)
    expected = {}
    for line in lines:
        reason = line.partition(": ")[2]
        expected[reason] = expected.get(reason, 0) + 1
    assert counted == expected
    assert [line.partition(": ")[2] for line in folded] == list(expected)  # first-seen order


def test_reasons_that_differ_only_in_numbers_are_one_reason() -> None:
    # Unix milliseconds read as seconds: each file's line names its own first stamp, so a first
    # run of a year of captures printed about a hundred lines for one cause.
    lines = [
        "r/a/d1.csv: column 'time' starts at 1.767e+12 s; are the stamps in ms?",
        "r/a/d2.csv: column 'time' starts at 1.768e+12 s; are the stamps in ms?",
        "r/a/d3.csv: empty file",
    ]
    assert fold_same_reason(lines) == [
        "r/a/d1.csv (and 1 more capture files with this reason, numbers aside): column 'time' "
        "starts at 1.767e+12 s; are the stamps in ms?",
        "r/a/d3.csv: empty file",
    ]
