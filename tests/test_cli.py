"""The ``nudge`` console script: help, subcommands, one-line errors, exit statuses."""
import pathlib

import pytest

from tests.commandline import nudge

SUBCOMMANDS = ("plan-push", "plan-tumble", "certify", "sweep", "parts")


def test_help_lists_every_command():
    r = nudge("--help")
    assert r.returncode == 0
    for c in SUBCOMMANDS:
        assert c in r.stdout
    assert "metres" in r.stdout and "Exit status" in r.stdout


@pytest.mark.slow
@pytest.mark.parametrize("cmd", SUBCOMMANDS)
def test_each_subcommand_has_help(cmd):
    r = nudge(cmd, "--help")
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith(f"usage: nudge {cmd}")
    if cmd != "parts":
        assert "xit status" in r.stdout and ("metres" in r.stdout or "radians" in r.stdout)


def test_unknown_command_and_no_command_exit_2():
    r = nudge("plan-pushes")
    assert r.returncode == 2 and r.stderr.startswith("error: unknown command 'plan-pushes'")
    assert nudge().returncode == 2


def test_parts_lists_bundled_parts_and_studies():
    r = nudge("parts")
    assert r.returncode == 0
    for name in ("nice_stable", "cube", "margins.yaml", "tolerances.yaml", "certify_triangle.yaml"):
        assert name in r.stdout


@pytest.mark.slow
def test_bundled_part_by_name():
    r = nudge("plan-push", "rectangle", "--start", "0,0,0", "--goal", "0.05,0.02,90deg")
    assert r.returncode == 0, r.stderr
    assert "rectangle" in r.stdout
    r = nudge("plan-push", "no_such_part", "--start", "0,0,0", "--goal", "0.05,0,0")
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "bundled" in r.stderr


def test_every_bundled_example_names_commands_that_exist():
    """The comments of every bundled config and study name commands a user can
    type today (``nudge COMMAND`` or ``python -m sweeps.run``), on files that
    exist, and tables as folders (issue 41: a header said ``python -m
    sweeps.certify`` and ``{samples,summary,certificates}.parquet``)."""
    import re

    from sweeps import catalog
    from sweeps.cli import COMMANDS

    examples = pathlib.Path(__file__).resolve().parents[1] / "examples"
    seen = 0
    for path in sorted(examples.rglob("*.yaml")):
        for n, line in enumerate(path.read_text().splitlines(), 1):
            comment = line.partition("#")[2]
            where = f"{path.relative_to(examples.parent)}:{n}"
            assert ".parquet" not in comment, f"{where}: tables are folders: {line}"
            for module, arg in re.findall(r"python -m ([\w.]+)\s+(\S+)", comment):
                seen += 1
                assert module == "sweeps.run", f"{where}: no such entry point: {line}"
                assert arg in catalog.bundled_studies() or arg.removesuffix(".yaml") in \
                    catalog.bundled_studies() or (examples.parent / arg).exists(), where
            for cmd, arg in re.findall(r"\bnudge ([a-z-]+)\s*(\S*)", comment):
                seen += 1
                assert cmd in COMMANDS, f"{where}: no command nudge {cmd}: {line}"
                if arg.endswith(".yaml") and "/" in arg:
                    assert (examples.parent / arg).exists(), f"{where}: no file {arg}"
    assert seen >= 5
