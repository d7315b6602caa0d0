"""A report as one HTML page: the markdown report rendered, self-contained but for its PNGs.

The page is the markdown of :func:`aeroid.report.report_markdown` (or of a comparison)
rendered by markdown-it-py (CommonMark with tables) inside a page with its own style
sheet: the same content, the figures linked by the same relative names. The HTML of
the text is escaped by the renderer (raw HTML in a message or a note is shown as text).
"""

from __future__ import annotations

import html

from markdown_it import MarkdownIt

from aeroid.errors import UsageError

__all__ = ["FORMATS", "html_page", "report_name"]

#: Report formats: the file suffix of each.
FORMATS = ("md", "html")

_STYLE = """\
body { font-family: system-ui, sans-serif; max-width: 60rem; margin: 2rem auto;
       padding: 0 1rem; line-height: 1.45; color: #222; }
table { border-collapse: collapse; margin: 0.5rem 0 1rem; font-size: 0.9rem; }
th, td { border: 1px solid #ccc; padding: 0.2rem 0.5rem; text-align: right; }
th:first-child, td:first-child { text-align: left; }
th { background: #f2f2f2; }
img { max-width: 100%; display: block; margin: 0.5rem 0; }
code { background: #f4f4f4; padding: 0 0.2rem; }"""


def report_name(stem: str, fmt: str) -> str:
    """Return the file name of a report ``stem`` in format ``fmt`` (``md`` or ``html``)."""
    if fmt not in FORMATS:
        raise UsageError(f"report format must be one of {', '.join(FORMATS)}, got {fmt!r}")
    return f"{stem}.{fmt}"


def html_page(markdown: str, title: str) -> str:
    """Return a whole HTML page of ``markdown`` (CommonMark and tables), titled ``title``.

    Raw HTML in the markdown is escaped, not passed through; links and images keep
    their targets (the report's PNG files, relative to the page).
    """
    body = MarkdownIt("commonmark", {"html": False}).enable("table").render(markdown)
    return ("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            f"<title>{html.escape(title)}</title>\n<style>\n{_STYLE}\n</style>\n</head>\n"
            f"<body>\n{body}</body>\n</html>\n")
