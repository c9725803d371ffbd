"""A run's report: one self-contained HTML page (``report.html``) in a run folder, made
from what the run wrote there (``manifest.json``, its plots, stills, animations and data
files), so that it can be made again from a finished run without running it again
(``pipeline report RUN_FOLDER``).

What it shows, top to bottom: the run's status and where it came from; the model (its
coordinates and their units, mobility and redundant constraints, each flexible link's
kept modes and their frequencies, the model's warnings and notes); every analysis case's
trust verdict with its message and warnings; every figure, embedded (PNG stills and plots,
GIF animations); the peak absolute value of every column of every result table, with its
unit and when it occurred; links to the data files. Nothing is fetched from elsewhere: the
page opens offline, mailed or archived, in any browser.

A small script on the page records what a browser met while loading it: the errors
(a script that failed, an image that did not decode: each fires an error event) and the
figures that decoded, as the ``data-errors`` and ``data-figures`` attributes of
``<body>`` (the tests read them from headless Chromium).
"""

from __future__ import annotations

import base64
import csv
import html
import json
import math
from pathlib import Path

from pipeline.core.atomic import atomic_open

__all__ = ["REPORT", "column_peaks", "report_html", "write_report"]

#: the report's file name in a run folder
REPORT = "report.html"

#: figures larger than this are linked, not embedded (a long animation)
EMBED_LIMIT = 25_000_000

_IMAGES = {".png": "image/png", ".gif": "image/gif", ".jpg": "image/jpeg",
           ".jpeg": "image/jpeg", ".svg": "image/svg+xml"}
#: unit suffixes of result-table columns (``lower.tip.y_m``, ``energy:kinetic_J``)
_UNITS = ("m", "m/s", "m/s2", "rad", "rad/s", "J", "W", "N", "Nm", "N m", "Pa", "s",
          "m3/s", "Hz", "kg")

_CSS = """
body{font-family:"DejaVu Sans",Arial,sans-serif;margin:24px auto;max-width:1180px;
color:#1d2730;background:#fff;line-height:1.4}
h1{font-size:24px;margin:0 0 4px}h2{font-size:19px;border-bottom:2px solid #d6dde3;
padding-bottom:3px;margin-top:30px}h3{font-size:15px;margin:18px 0 6px}
table{border-collapse:collapse;margin:6px 0 12px;font-size:13px}
th,td{border:1px solid #d6dde3;padding:3px 8px;text-align:left;vertical-align:top}
th{background:#eef2f5}td.num{text-align:right;font-variant-numeric:tabular-nums}
.badge{display:inline-block;padding:2px 10px;border-radius:10px;color:#fff;font-weight:bold}
.ok{background:#2e7d32}.suspect{background:#c77c00}.partial,.failed,.lost,.error{background:#b3261e}
.meta{color:#52606d;font-size:13px}.warn{color:#8a4b00}
.figs{display:flex;flex-wrap:wrap;gap:14px}
figure{margin:0;border:1px solid #d6dde3;padding:6px;max-width:560px}
figure img{max-width:100%;height:auto;display:block}figcaption{font-size:12px;color:#52606d}
ul.files{columns:3;font-size:13px}
"""

_SCRIPT = """
(function(){var errors=0;
window.addEventListener('error',function(){errors+=1;document.body.dataset.errors=errors;},true);
window.addEventListener('load',function(){var ok=0;
document.querySelectorAll('figure img').forEach(function(i){
if(i.complete&&i.naturalWidth>0){ok+=1;}});
document.body.dataset.errors=errors;document.body.dataset.figures=ok;});})();
"""


def write_report(folder: str | Path) -> Path:
    """Write ``report.html`` into the run folder ``folder`` (from its ``manifest.json``
    and files); returns its path."""
    folder = Path(folder)
    path = folder / REPORT
    with atomic_open(path, "w") as fh:
        fh.write(report_html(folder))
    return path


def report_html(folder: str | Path) -> str:
    """The report page of the run folder ``folder`` (module docstring), as text."""
    folder = Path(folder)
    try:
        man = json.loads((folder / "manifest.json").read_text())
    except (OSError, ValueError) as exc:
        raise FileNotFoundError(f"{folder}: not a finished run (no readable manifest.json: "
                                f"{exc})") from None
    files = [f for f in man.get("files", []) if f != REPORT]
    parts = [_header(man), _model(man), _verdicts(man), _figures(folder, files),
             _peaks(folder, files, man), _files(folder, files, man)]
    title = html.escape(f"{man.get('name', folder.name)}: run report")
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{title}</title><style>{_CSS}</style><script>{_SCRIPT}</script>"
            "</head>\n<body data-errors=\"0\" data-figures=\"0\">\n"
            + "\n".join(p for p in parts if p) + "\n</body></html>\n")


def _e(x) -> str:
    return html.escape(str(x))


def _badge(state: str) -> str:
    return f'<span class="badge {_e(state)}">{_e(state)}</span>'


def _table(head, rows, num=()) -> str:
    out = ["<table><tr>" + "".join(f"<th>{_e(h)}</th>" for h in head) + "</tr>"]
    for r in rows:
        out.append("<tr>" + "".join(
            f'<td class="num">{c}</td>' if k in num else f"<td>{c}</td>"
            for k, c in enumerate(r)) + "</tr>")
    return "".join(out) + "</table>"


def _header(man: dict) -> str:
    over = ", ".join(f"{p}={v}" for p, v in man.get("overrides", [])) or "none"
    t = man.get("timings_s", {})
    return (f"<h1>{_e(man.get('name', ''))} {_badge(man.get('status', '?'))}</h1>"
            f"<p class=\"meta\">workflow {_e(man.get('workflow', ''))}"
            f"{' (quick)' if man.get('quick') else ''}; overrides: {_e(over)}; "
            f"created {_e(man.get('created', ''))}; input hash "
            f"{_e(str(man.get('input_hash', ''))[:16])}; run time "
            f"{_e(_fmt(t.get('total', float('nan'))))} s</p>"
            + _skipped(man))


def _skipped(man: dict) -> str:
    notes = man.get("skipped_outputs") or []
    if not notes:
        return ""
    return ("<p class=\"warn\"><b>Outputs not drawn:</b></p><ul>"
            + "".join(f"<li class=\"warn\">{_e(n)}</li>" for n in notes) + "</ul>")


def _model(man: dict) -> str:
    coords = man.get("coordinates", [])
    units = man.get("coordinate_units") or ["" for _ in coords]
    model = man.get("model", {})
    out = ["<h2>Model</h2>"]
    facts = [_count(len(coords), "coordinate")]
    if "loops" in model:
        facts.append(_count(model["loops"], "closed loop"))
    if model.get("dof") is not None:
        facts.append(f"{_count(model['dof'], 'degree')} of freedom (every coordinate, joint "
                     "and modal, less the independent closure constraints)")
    red = model.get("redundant") or []
    if red:
        facts.append(f"{_count(len(red), 'redundant closure constraint')} (kept; their "
                     f"reactions are not unique): {', '.join(red)}")
    out.append("<p>" + _e("; ".join(facts)) + ".</p>")
    out.append("<p class=\"meta\">coordinates (unit): " + _e(", ".join(
        f"{c} ({u})" if u else c for c, u in zip(coords, units, strict=False))) + "</p>")
    links = man.get("links", {})
    if links:
        rows = [[_e(n), _e(", ".join(str(m + 1) for m in p.get("modes", []))) or "none",
                 _e(", ".join(_fmt(f) for f in p.get("frequencies_hz", []))),
                 _e(p.get("artifact", "")), _e(p.get("cache", ""))]
                for n, p in links.items()]
        out.append("<h3>Flexible links</h3>"
                   + _table(["link", "kept modes (1: the lowest)",
                             "their frequencies (the link's own basis), Hz",
                             "artifact", "cache"], rows))
    for key, title in (("warnings", "Model warnings"), ("notes", "Model notes")):
        if model.get(key):
            out.append(f"<h3>{title}</h3><ul>"
                       + "".join(f"<li class=\"{'warn' if key == 'warnings' else ''}\">"
                                 f"{_e(w)}</li>" for w in model[key]) + "</ul>")
    return "".join(out)


def _verdicts(man: dict) -> str:
    rows = []
    for name, cases in man.get("analyses", {}).items():
        for c in cases:
            notes = "; ".join([c.get("message", "")] + list(c.get("warnings", [])))
            expected = c.get("expected", "ok")
            rows.append([_e(name), _e(c.get("case", "")), _e(c.get("type", "")),
                         _badge(c.get("verdict", "?"))
                         + ("" if expected == "ok" else f" (expected {_e(expected)})"),
                         _e(c.get("outputs", "")), _e(_fmt(c.get("seconds", float("nan")))),
                         _e(notes.strip("; "))])
    return ("<h2>Analyses and their trust verdicts</h2>"
            + _table(["analysis", "case", "type", "verdict", "outputs", "seconds",
                      "message and warnings"], rows, num=(4, 5)))


def _figures(folder: Path, files: list[str]) -> str:
    figs = []
    for f in files:
        kind = _IMAGES.get(Path(f).suffix.lower())
        p = folder / f
        if kind is None or not p.is_file():
            continue
        if p.stat().st_size > EMBED_LIMIT:
            figs.append(f"<figure><figcaption><a href=\"{_e(f)}\">{_e(f)}</a> (too large to "
                        "embed)</figcaption></figure>")
            continue
        data = base64.b64encode(p.read_bytes()).decode("ascii")
        figs.append(f"<figure><img alt=\"{_e(f)}\" src=\"data:{kind};base64,{data}\">"
                    f"<figcaption>{_e(f)}</figcaption></figure>")
    if not figs:
        return ""
    return "<h2>Figures</h2><div class=\"figs\">" + "".join(figs) + "</div>"


def column_peaks(path: str | Path) -> list[tuple[str, float, float]]:
    """(column, peak |value|, time of the peak (s) or NaN) of every column but the first
    (the time) of a result table (CSV with a header line)."""
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    if len(rows) < 2:
        return []
    head, body = rows[0], rows[1:]
    timed = head[0].startswith("time")
    out = []
    for k in range(1 if timed else 0, len(head)):
        best, when = -1.0, float("nan")
        for r in body:
            try:
                x = abs(float(r[k]))
            except (ValueError, IndexError):
                continue
            if math.isfinite(x) and x > best:
                best, when = x, float(r[0]) if timed else float("nan")
        if best >= 0:
            out.append((head[k], best, when))
    return out


def _unit(column: str, units: dict) -> tuple[str, str]:
    """(quantity, unit) of a result-table column."""
    if column in units:
        return column, units[column]
    for u in sorted(_UNITS, key=len, reverse=True):
        if column.endswith("_" + u):
            return column[: -len(u) - 1], u
    return column, ""


def _peaks(folder: Path, files: list[str], man: dict) -> str:
    units = dict(zip(man.get("coordinates", []), man.get("coordinate_units", []),
                     strict=False))
    blocks = []
    for f in files:
        p = folder / f
        if p.suffix != ".csv" or not p.is_file():
            continue
        try:
            peaks = column_peaks(p)
        except (OSError, csv.Error):
            continue
        if not peaks:
            continue
        rows = []
        for col, x, t in peaks:
            name, unit = _unit(col, units)
            rows.append([_e(name), _e(_fmt(x)), _e(unit),
                         "" if math.isnan(t) else _e(_fmt(t))])
        blocks.append(f"<h3><a href=\"{_e(f)}\">{_e(f)}</a></h3>"
                      + _table(["quantity", "peak |value|", "unit", "at t, s"], rows,
                               num=(1, 3)))
    return ("<h2>Peak values</h2>" + "".join(blocks)) if blocks else ""


def _files(folder: Path, files: list[str], man: dict) -> str:
    items = []
    for f in files + ["manifest.json"]:
        p = folder / f
        size = f" ({_size(p.stat().st_size)})" if p.is_file() else ""
        items.append(f"<li><a href=\"{_e(f)}\">{_e(f)}</a>{_e(size)}</li>")
    versions = man.get("versions", {})
    v = "; ".join(f"{k} {x}" for k, x in versions.items()) if isinstance(versions, dict) \
        else str(versions)
    return ("<h2>Data files</h2><ul class=\"files\">" + "".join(items) + "</ul>"
            + (f"<p class=\"meta\">versions: {_e(v)}</p>" if v else ""))


def _count(k: int, what: str) -> str:
    return f"{k} {what}" + ("" if k == 1 else "s")


def _fmt(x) -> str:
    try:
        x = float(x)
    except (TypeError, ValueError):
        return str(x)
    if not math.isfinite(x):
        return "-"
    return f"{x:.4g}"


def _size(n: int) -> str:
    for unit in ("B", "kB", "MB", "GB"):
        if n < 1000 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000
    return f"{n} B"
