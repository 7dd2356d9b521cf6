"""The ``nudge`` console script: help, subcommands, one-line errors, exit statuses."""
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
