"""MkDocs hooks of faultlab's docs site.

* The navigation lists every page found under ``docs/`` (pages added later appear without editing
  ``mkdocs.yml``), with the top-level sections in reading order: tutorial, how-to guides,
  reference, explanation.
* ``<!-- cli-help -->`` in a page is replaced by the ``--help`` text of every command and
  subcommand, taken from the command line's own argparse parsers.
"""

from __future__ import annotations

import argparse
import os

SECTION_ORDER = ("tutorial", "how-to", "reference", "explanation")
CLI_MARKER = "<!-- cli-help -->"


def _section_rank(item) -> tuple[int, str]:
    if item.is_page:
        return (-1, "")  # the home page first
    first = next(iter(_pages(item)), None)
    top = first.file.src_uri.split("/", 1)[0] if first is not None else ""
    rank = SECTION_ORDER.index(top) if top in SECTION_ORDER else len(SECTION_ORDER)
    return (rank, item.title)


def _pages(item):
    if item.is_page:
        yield item
    for child in getattr(item, "children", None) or ():
        yield from _pages(child)


def on_nav(nav, config, files):
    nav.items.sort(key=_section_rank)
    return nav


def _subcommands(parser: argparse.ArgumentParser, prefix: str):
    """(command line, parser) of every subcommand below ``parser``, depth first."""
    for action in parser._actions:  # argparse offers no public accessor for subparsers
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                line = f"{prefix} {name}"
                yield line, sub
                yield from _subcommands(sub, line)


def cli_markdown() -> str:
    """Markdown with the ``--help`` of the program and every (sub)command."""
    from faultlab.cli import build_parser

    os.environ["COLUMNS"] = "100"  # argparse wraps help to the terminal width
    parser = build_parser()
    parts = ["## " + parser.prog, "", "```text", parser.format_help().rstrip(), "```", ""]
    for line, sub in _subcommands(parser, parser.prog):
        parts += ["## " + line.removeprefix(parser.prog + " "), "", "```text", sub.format_help().rstrip(), "```", ""]
    return "\n".join(parts)


def on_page_markdown(markdown, page, config, files):
    if CLI_MARKER in markdown:
        markdown = markdown.replace(CLI_MARKER, cli_markdown())
    return markdown
