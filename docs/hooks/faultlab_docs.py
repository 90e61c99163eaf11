"""MkDocs hooks of faultlab's docs site.

* The navigation lists every page found under ``docs/`` (pages added later appear without editing
  ``mkdocs.yml``), with the top-level sections in reading order: tutorial, how-to guides,
  reference, explanation; a section is labelled by :data:`SECTION_TITLES` where its directory name
  capitalised would read wrong ("Api"); the home page's label is its ``title`` (front matter: the
  header names the site already).
* ``<!-- cli-help -->`` in a page is replaced by the ``--help`` text of every command and
  subcommand, taken from the command line's own argparse parsers.
"""

from __future__ import annotations

import argparse
import os

SECTION_ORDER = ("tutorial", "how-to", "reference", "explanation")
#: Navigation labels of sections (by directory) whose capitalised directory name would read wrong.
SECTION_TITLES = {"how-to": "How-to guides", "api": "API"}
CLI_MARKER = "<!-- cli-help -->"
#: Width of the generated ``--help`` texts (argparse wraps to it): fits the page's code blocks.
CLI_COLUMNS = "88"


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


def _directory(item) -> str:
    """The directory a section's pages live in (its last path component)."""
    first = next(iter(_pages(item)), None)
    parts = first.file.src_uri.split("/")[:-1] if first is not None else []
    depth = 0
    parent = getattr(item, "parent", None)
    while parent is not None:
        depth, parent = depth + 1, getattr(parent, "parent", None)
    return parts[depth] if depth < len(parts) else ""


def _relabel(items) -> None:
    for item in items:
        if item.is_section:
            item.title = SECTION_TITLES.get(_directory(item), item.title)
            _relabel(item.children)


def on_nav(nav, config, files):
    nav.items.sort(key=_section_rank)
    _relabel(nav.items)
    return nav


def _subcommands(parser: argparse.ArgumentParser, prefix: str):
    """(command line, parser) of every subcommand below ``parser``, depth first."""
    for action in parser._actions:  # argparse offers no public accessor for subparsers
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                line = f"{prefix} {name}"
                yield line, sub
                yield from _subcommands(sub, line)
                verbs = sub.get_default("verb_parsers")  # verbs parsed by the command itself (effects)
                for verb, verb_parser in (verbs(sub.prog) if verbs else {}).items():
                    yield f"{line} {verb}", verb_parser


def cli_markdown() -> str:
    """Markdown with the ``--help`` of the program and every (sub)command."""
    from faultlab.cli import build_parser

    os.environ["COLUMNS"] = CLI_COLUMNS  # argparse wraps help to the terminal width
    parser = build_parser()
    parts = ["## " + parser.prog, "", "```text", parser.format_help().rstrip(), "```", ""]
    for line, sub in _subcommands(parser, parser.prog):
        parts += ["## " + line.removeprefix(parser.prog + " "), "", "```text", sub.format_help().rstrip(), "```", ""]
    return "\n".join(parts)


def on_page_markdown(markdown, page, config, files):
    if CLI_MARKER in markdown:
        markdown = markdown.replace(CLI_MARKER, cli_markdown())
    return markdown
