"""linkwright.warmup: kernels compiled (or loaded) in worker processes, and its command."""
import os

import pytest

from linkwright.cli import main
from linkwright.warmup import GROUPS, NEEDS, compile_kernels


def test_one_group_runs_in_another_process_and_reports_its_times():
    table = compile_kernels(["approx"], processes=1)
    assert list(table.group) == ["approx"]
    row = table.iloc[0]
    assert row.pid != os.getpid()
    assert 0.0 <= row.compile_seconds <= row.seconds


def test_groups_and_needs_name_existing_groups():
    assert set(NEEDS) <= set(GROUPS)
    assert all(set(v) <= set(GROUPS) for v in NEEDS.values())


@pytest.mark.parametrize("kw, name", [(dict(groups=["nope"]), "groups"),
                                      (dict(processes=0), "processes"),
                                      (dict(processes=True), "processes"),
                                      (dict(processes=1.5), "processes")])
def test_bad_arguments_are_refused_by_name(kw, name):
    with pytest.raises(ValueError, match=name):
        compile_kernels(**kw)


def test_command_refuses_a_bad_process_count(capsys):
    assert main(["compile", "--processes", "0"]) == 2
    assert "processes" in capsys.readouterr().err
