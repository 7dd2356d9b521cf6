"""One error type for bad input and one exit-status table at the edge."""
import pytest

from sweeps.config import ConfigError
from sweeps.errors import Exit, UserError
from sweeps.partfile import PartFileError
from sweeps.store import RunError
from sweeps.tasks import PlanInputError
from sweeps.terminal import InputError, run_main
from sweeps.yamlio import YamlError


def test_every_bad_input_is_a_user_error():
    for cls in (ConfigError, PartFileError, RunError, PlanInputError, InputError, YamlError):
        assert issubclass(cls, UserError) and issubclass(cls, ValueError), cls


def test_exit_table():
    assert [int(e) for e in Exit] == [0, 1, 2, 3, 130]


def _run(fn, capsys):
    with pytest.raises(SystemExit) as info:
        run_main(fn)
    return info.value.code, capsys.readouterr().err


def test_a_user_error_that_reaches_the_guard_is_exit_2_in_one_line(capsys, monkeypatch):
    monkeypatch.delenv("NUDGE_DEBUG", raising=False)

    def bad():
        raise ConfigError("samples: must be >= 1,\n   got 0")

    code, err = _run(bad, capsys)
    assert code == 2 and err == "error: samples: must be >= 1, got 0\n"


def test_a_bug_is_exit_3_and_ctrl_c_130(capsys, monkeypatch):
    monkeypatch.delenv("NUDGE_DEBUG", raising=False)

    def bug():
        raise ValueError("not bad input: a bug")

    code, err = _run(bug, capsys)
    assert code == 3 and err.startswith("error: internal error (ValueError: not bad input")

    def interrupted():
        raise KeyboardInterrupt

    assert _run(interrupted, capsys)[0] == 130
    assert _run(lambda: Exit.NEGATIVE, capsys)[0] == 1
