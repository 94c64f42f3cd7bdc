"""The command line: every command and option documented, every --help with examples, schemas exported, users
created, demo seeded."""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys

import msgspec
import pytest

from burnedge.cli import build_parser
from harness.processes import REPO
from schemas.export import public_messages


def _commands(parser, prefix=()) -> list[tuple[str, ...]]:
    found = []
    for action in parser._actions:
        if action.__class__.__name__ == "_SubParsersAction":
            for name, sub in action.choices.items():
                found.append((*prefix, name))
                found += _commands(sub, (*prefix, name))
    return found


def _parsers(parser, prefix=()) -> list[tuple[tuple[str, ...], argparse.ArgumentParser]]:
    """Every parser in the tree, the top one (prefix ()) included, with its command path."""
    found = [(prefix, parser)]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found += _parsers(sub, (*prefix, name))
    return found


PARSERS = _parsers(build_parser())
GLOBAL_OPTIONS = {"--config", "--db", "--verbose"}
"""Accepted after every command too; documented once, as the global options."""


def _readme_blocks() -> list[str]:
    """README.md in paragraphs and table rows: where a command is documented with its options."""
    return re.split(r"\n\s*\n|\n(?=\|)", (REPO / "README.md").read_text())


def _mentions(block: str, words: str) -> bool:
    return re.search(rf"(?<![\w-]){re.escape(words)}(?![\w-])", block) is not None


@pytest.mark.parametrize("command", _commands(build_parser()), ids=" ".join)
def test_every_cli_command_is_documented_in_the_readme(command):
    readme = (REPO / "README.md").read_text()
    assert f"burnedge {' '.join(command)}" in readme, f"document `burnedge {' '.join(command)}` in README.md"


@pytest.mark.parametrize(("command", "parser"), PARSERS, ids=[" ".join(("burnedge", *c)) for c, _ in PARSERS])
def test_every_option_of_every_command_is_documented_with_it_in_the_readme(command, parser):
    """Each long flag is named in a README paragraph or table row that names the command (the global options in
    the paragraph about them)."""
    name = " ".join(("burnedge", *command))
    flags = {f for a in parser._actions for f in a.option_strings if f.startswith("--") and f != "--help"}
    if command:
        flags -= GLOBAL_OPTIONS
    blocks = [b for b in _readme_blocks() if _mentions(b, name if command else "Global options")]
    assert blocks, f"README.md has no paragraph or table row naming `{name}`"
    missing = sorted(f for f in flags if not any(_mentions(b, f) for b in blocks))
    assert not missing, f"README.md does not document {', '.join(missing)} where it documents `{name}`"


@pytest.mark.parametrize(("command", "parser"), PARSERS, ids=[" ".join(("burnedge", *c)) for c, _ in PARSERS])
def test_every_command_help_shows_an_example(command, parser):
    name = " ".join(("burnedge", *command))
    text = parser.format_help()
    assert "examples:" in text, (
        f"`{name} --help` shows no example: give its parser examples(...) (burnedge/cli_help.py)"
    )
    shown = text[text.index("examples:") :].splitlines()[1:]
    assert any(name in line for line in shown), f"`{name} --help`: no example runs `{name}`"


def test_schemas_export_writes_a_json_schema_per_message(tmp_path):
    r = subprocess.run(
        [sys.executable, "-m", "burnedge.cli", "schemas", "export", str(tmp_path)],
        capture_output=True,
        text=True,
        cwd=REPO,
    )
    assert r.returncode == 0, r.stderr
    names = {p.stem for p in tmp_path.glob("*.json")} - {"index"}
    for required in (
        "Patient",
        "Encounter",
        "Intake",
        "PrimarySurvey",
        "SecondarySurvey",
        "Mechanism",
        "BurnChart",
        "TbsaResult",
        "FluidPlan",
        "ReferralAssessment",
        "Mutation",
        "ChangesPage",
        "Problem",
    ):
        assert required in names
    patient = json.loads((tmp_path / "Patient.json").read_text())
    props = patient["$defs"]["Patient"]["properties"]
    assert props["weight_kg"]["anyOf"][0]["exclusiveMinimum"] == 0
    assert patient["$defs"]["Patient"]["additionalProperties"] is False
    # JSON Schema patterns are ECMA-262, where \A is an error in unicode mode and ^...$ anchors the whole string.
    assert props["id"]["pattern"].startswith("^") and props["id"]["pattern"].endswith("}$")
    assert len(names) == len(public_messages())


def test_every_input_message_refuses_unknown_fields():
    """Messages clients send are Message subclasses: their schema must say additionalProperties false."""
    from schemas.base import Message

    inputs = [s for s in public_messages() if issubclass(s, Message) and not s.__struct_config__.frozen]
    assert len(inputs) >= 20
    for struct in inputs:
        schema = msgspec.json.schema(struct)
        assert schema["$defs"][struct.__name__]["additionalProperties"] is False, struct.__name__
        with pytest.raises(msgspec.ValidationError, match="unknown field"):
            msgspec.json.decode(b'{"surely_not_a_field": 1}', type=struct)


def test_users_add_rejects_a_short_password(tmp_path):
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "burnedge.cli",
            "--db",
            str(tmp_path / "u.sqlite3"),
            "users",
            "add",
            "--username",
            "dr.a",
            "--role",
            "clinician",
            "--password-stdin",
        ],
        input="short\n",
        capture_output=True,
        text=True,
        cwd=REPO,
    )
    assert r.returncode == 2 and "10+ characters" in r.stderr


def test_demo_seeds_a_patient_with_calculated_results_and_is_idempotent(tmp_path):
    db = tmp_path / "demo.sqlite3"
    args = [sys.executable, "-m", "burnedge.cli", "--db", str(db), "demo", "--no-series", "--exit"]
    env = {
        "BURNEDGE_SECURITY_ARGON2_MEMORY_KIB": "8",
        "BURNEDGE_SECURITY_ARGON2_TIME_COST": "1",
        "BURNEDGE_SECURITY_ARGON2_PARALLELISM": "1",
        "PATH": "",
    }
    first = subprocess.run(args, capture_output=True, text=True, cwd=REPO, env=env)
    assert first.returncode == 0, first.stderr
    assert "%TBSA" in first.stdout and "Decision support" in first.stdout
    second = subprocess.run(args, capture_output=True, text=True, cwd=REPO, env=env)
    assert second.returncode == 0, second.stderr
    assert first.stdout.splitlines()[1] == second.stdout.splitlines()[1]
    assert db.with_suffix(".credentials").stat().st_mode & 0o077 == 0


def test_version_and_every_exit_code_are_in_the_readme():
    from base import __version__
    from burnedge.cli import EXIT_CODES

    r = subprocess.run([sys.executable, "-m", "burnedge.cli", "--version"], capture_output=True, text=True, cwd=REPO)
    assert r.returncode == 0 and r.stdout.strip() == f"burnedge {__version__}"
    readme = (REPO / "README.md").read_text()
    codes = readme[readme.index("Exit codes:") :].split("\n\n")[0]
    for code in {0, 6, 7, *(c for _, c in EXIT_CODES)}:
        assert f"{code} " in codes, f"exit code {code} is not in the README's list"
    assert "`--version`" in readme


def test_global_options_work_before_and_after_the_command(tmp_path):
    missing = str(tmp_path / "nope.sqlite3")
    for args in (["--db", missing, "audit", "verify"], ["audit", "verify", "--db", missing]):
        r = subprocess.run([sys.executable, "-m", "burnedge.cli", *args], capture_output=True, text=True, cwd=REPO)
        assert r.returncode == 3 and f"no database at {missing}" in r.stderr, (args, r.stderr)
    config = tmp_path / "burnedge.toml"
    config.write_text(f'[gateway]\ndatabase = "{tmp_path / "from-config.sqlite3"}"\n')
    parsed = build_parser().parse_args(
        ["--config", str(config), "users", "add", "--username", "amani", "--role", "nurse", "-v"]
    )
    assert (parsed.config, parsed.db, parsed.verbose) == (str(config), None, True)


def test_ci_runs_the_readmes_test_command_with_the_linter_and_the_formatter_check():
    ci = (REPO / ".ci" / "run").read_text().strip().splitlines()[-1]
    assert f"```sh\n{ci}\n```" in (REPO / "README.md").read_text(), "the README's test command is what CI runs"
    assert "ruff check ." in ci and "ruff format --check ." in ci and "pytest" in ci
