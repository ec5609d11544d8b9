"""HTML tables for a notebook's rich display (`_repr_html_` of a recording, parameters, a fit):
every cell escaped, numbers right-aligned, a caption above."""

from collections.abc import Sequence
from html import escape


def html_table(caption: str, headers: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    """A `<table>` with `caption`, one header row and `rows` (a cell that reads as a number
    right-aligned, text left-aligned)."""

    def cell(tag: str, v: object) -> str:
        return f'<{tag} style="text-align:{"right" if tag == "td" and _number(v) else "left"}">{escape(str(v))}</{tag}>'

    head = "".join(cell("th", h) for h in headers)
    body = "".join("<tr>" + "".join(cell("td", v) for v in row) + "</tr>" for row in rows)
    return f"<table><caption>{escape(caption)}</caption><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _number(v: object) -> bool:
    try:
        float(str(v))
    except ValueError:
        return False
    return True


__all__ = ["html_table"]
