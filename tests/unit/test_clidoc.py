"""docs/cli.md's command-line reference is generated from the argparse parser and is current."""

import argparse
from pathlib import Path

from swarmactors import clidoc
from swarmactors.cli import build_parser

DOC = Path(__file__).resolve().parents[2] / "docs" / "cli.md"  # the checkout's (CI installs a wheel)


def test_the_reference_is_generated_from_the_parser():
    assert clidoc.main(["--check", "--doc", str(DOC)]) == 0, "run: python -m swarmactors.clidoc"


def test_every_command_and_option_is_in_it():
    text = clidoc.reference()
    for name, _, sub in clidoc._subcommands(build_parser()):
        assert f"`swarmactors {name}`" in text, name
        for action in sub._actions:
            for option in action.option_strings:
                if option not in ("-h", "--help") and action.help != argparse.SUPPRESS:
                    assert option in text, (name, option)


def test_a_stale_page_is_refused_and_rewritten(tmp_path):
    page = tmp_path / "cli.md"
    page.write_text("# CLI\n\n<!-- cli -->\nold\n<!-- end cli -->\nafter\n")
    assert clidoc.main(["--check", "--doc", str(page)]) == 1
    assert clidoc.main(["--doc", str(page)]) == 0
    text = page.read_text()
    assert "old" not in text and "### `swarmactors run`" in text and text.endswith("<!-- end cli -->\nafter\n")
    assert clidoc.main(["--check", "--doc", str(page)]) == 0


def test_a_page_without_markers_or_missing_is_bad_input(tmp_path, capsys):
    page = tmp_path / "cli.md"
    page.write_text("# CLI\n")
    assert clidoc.main(["--check", "--doc", str(page)]) == 2
    assert clidoc.main(["--doc", str(tmp_path / "none.md")]) == 2
    assert "cli.md" in capsys.readouterr().err
