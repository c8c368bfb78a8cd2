"""CI runs the README's commands verbatim, then the built wheel from an empty folder; the
README's command lines parse and name shipped studies."""
import re
import shlex

import pytest

from linkwright.cli import _parser
from linkwright.examples import studies

from .util import ROOT

README, CI = ROOT / "README.md", ROOT / ".ci" / "run"
pytestmark = pytest.mark.skipif(not (README.exists() and CI.exists()),
                                reason="needs the source tree")


def code_lines(section: str) -> list[str]:
    """The lines of the ```sh blocks of a README section."""
    text = README.read_text()
    body = text.split(f"## {section}\n", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```sh\n(.*?)```", body, re.S)
    return [re.sub(r"\s+#.*$", "", ln).strip() for block in blocks
            for ln in block.splitlines() if ln.strip()]


def ci_commands() -> list[str]:
    return [ln.strip() for ln in CI.read_text().splitlines()
            if ln.strip() and not ln.strip().startswith("#")]


def test_ci_runs_the_readme_quickstart_verbatim():
    quick = code_lines("Quickstart")
    assert quick == ['pip install . && linkwright demo -o demo-output',
                     'pip install ".[test]" && python -m pytest']
    for cmd in quick:
        assert any(ln == cmd or ln.startswith(cmd + " ||") for ln in ci_commands()), cmd


def test_ci_tests_the_built_wheel_from_an_empty_folder():
    text = "\n".join(ci_commands())
    assert "pip wheel" in text and text.count("-m venv") >= 2
    for cmd in ("linkwright demo", "linkwright bench --quick", "linkwright examples -o",
                "linkwright synth", "linkwright stiffness", "linkwright approx",
                "linkwright analyze"):
        assert cmd in text.split("pip wheel", 1)[1], cmd


def test_readme_command_lines_parse_and_name_shipped_studies():
    shipped = {p.name for p in studies()}
    lines = [ln for ln in code_lines("The command") if ln.startswith("linkwright ")]
    assert {"synth", "stiffness", "approx", "analyze", "examples", "bench"} <= \
        {ln.split()[1] for ln in lines}
    for ln in lines:
        args = _parser().parse_args(shlex.split(ln)[1:])
        if getattr(args, "study", None):
            assert args.study.split("/")[-1] in shipped, ln
