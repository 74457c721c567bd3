"""A self-contained HTML page that opens offline: inline CSS, PNG pictures inline as base64
``data:`` URIs, no script, no font, no link out, and a Content-Security-Policy that lets the
browser load nothing else (:data:`CSP`). What goes on it (tables, pictures, text) is given as
:class:`Section` objects; :func:`write_page` writes it.
"""

from __future__ import annotations

import base64
import html
from dataclasses import dataclass
from pathlib import Path

#: the page's Content-Security-Policy: nothing from anywhere but its own inline style and
#: ``data:`` images
CSP = "default-src 'none'; img-src data:; style-src 'unsafe-inline'"

_CSS = """
body { font-family: sans-serif; max-width: 1100px; margin: 2em auto; padding: 0 1em;
       color: #222; line-height: 1.4; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; }
h2 { font-size: 1.25em; border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 1.6em; }
p.subtitle { color: #555; margin-top: 0; }
p.warning { background: #fff3cd; border: 1px solid #e0c060; padding: 0.5em 0.8em; }
table { border-collapse: collapse; margin: 0.6em 0; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.7em; text-align: left; vertical-align: top; }
th { background: #f2f2f2; }
td.value { font-variant-numeric: tabular-nums; }
figure { margin: 1em 0; }
figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { color: #555; font-size: 0.9em; }
pre { background: #f7f7f7; border: 1px solid #ddd; padding: 0.6em; overflow-x: auto;
      font-size: 0.85em; }
"""


@dataclass(frozen=True)
class Section:
    """One part of the page, drawn in this order: its title, ``warning`` (highlighted), ``text``
    (a paragraph), the table (``header`` and ``rows``: tuples of cell texts), the ``images``
    (``(caption, PNG path)``), then ``pre`` (preformatted text). Every text is plain text: it is
    escaped, never read as HTML."""

    title: str
    text: str = ""
    warning: str = ""
    header: tuple = ()
    rows: tuple = ()
    images: tuple = ()
    pre: str = ""


def _e(text) -> str:
    return html.escape(str(text), quote=True)


def _table(header, rows) -> str:
    out = ["<table>"]
    if header:
        out.append("<tr>" + "".join(f"<th>{_e(h)}</th>" for h in header) + "</tr>")
    for row in rows:
        first, *rest = row
        out.append(f"<tr><th>{_e(first)}</th>"
                   + "".join(f'<td class="value">{_e(v)}</td>' for v in rest) + "</tr>")
    out.append("</table>")
    return "\n".join(out)


def _figure(caption: str, path: Path) -> str:
    data = base64.b64encode(Path(path).read_bytes()).decode("ascii")
    return (f'<figure><img alt="{_e(caption)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{_e(caption)}</figcaption></figure>")


def render(title: str, subtitle: str, sections) -> str:
    """The page's HTML text."""
    body = [f"<h1>{_e(title)}</h1>", f'<p class="subtitle">{_e(subtitle)}</p>']
    for s in sections:
        body.append(f"<h2>{_e(s.title)}</h2>")
        if s.warning:
            body.append(f'<p class="warning">{_e(s.warning)}</p>')
        if s.text:
            body.append(f"<p>{_e(s.text)}</p>")
        if s.rows:
            body.append(_table(s.header, s.rows))
        body.extend(_figure(caption, path) for caption, path in s.images)
        if s.pre:
            body.append(f"<pre>{_e(s.pre)}</pre>")
    return ("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            f'<meta http-equiv="Content-Security-Policy" content="{CSP}">\n'
            f"<title>{_e(title)}</title>\n<style>{_CSS}</style>\n</head>\n<body>\n"
            + "\n".join(body) + "\n</body>\n</html>\n")


def write_page(path, title: str, subtitle: str, sections) -> Path:
    """Write the page to ``path`` (through a temporary file, so a reader never sees half of
    it); returns ``path``."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(render(title, subtitle, sections), encoding="utf-8")
    tmp.replace(path)
    return path
