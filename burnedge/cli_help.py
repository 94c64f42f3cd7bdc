"""How every `burnedge` command's --help reads: its options (their defaults written in their help), then examples.

Each parser is made with `examples(...)`: the lines are shown as written under "examples:" (tests/test_cli.py
checks that every command has some, and that every command and option is in README.md).
"""

from __future__ import annotations

import argparse


def examples(*lines: str) -> dict:
    """Keyword arguments for ArgumentParser / add_parser: an epilog of example command lines, kept as written."""
    return {
        "epilog": "examples:\n" + "\n".join(f"  {line}" for line in lines),
        "formatter_class": argparse.RawDescriptionHelpFormatter,
    }
