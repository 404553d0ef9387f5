"""``curves.html``: one row per force curve with a thumbnail of its figure, beside ``curves.csv``.

Links are relative (the folder can be moved); rejected curves are highlighted with their reason.
The table sorts by a click on a column heading and filters by status (a few lines of inline
JavaScript; without it the page is the full table in manifest order).
"""

import html
from collections import Counter
from pathlib import PurePosixPath
from urllib.parse import quote

import numpy as np

from turgorbayes import __version__
from turgorbayes.formatting import format_pm
from turgorbayes.plots.curves import FIGURE_DIR, reading_text, shown_result
from turgorbayes.report.html import CSS

__all__ = ["HEADER", "render_curves_html", "write_curves_html"]

#: Columns of the page's table.
HEADER = ("file", "curve", "cell", "target", "status", "k [mN/m]", "depth [nm]", "contact height [nm]",
          "figure")
_PAGE_CSS = CSS + """
tr.rejected td{background:#fde2e2}td .reason{color:#c00;font-size:90%}
img.thumb{width:260px;border:0}td{vertical-align:top}
#curves th{cursor:pointer}#curves th[aria-sort=ascending]::after{content:" \\25B2"}
#curves th[aria-sort=descending]::after{content:" \\25BC"}"""


def _e(x):
    return html.escape(str(x))


def _pm(value, sd, scale):
    if not np.isfinite(value):
        return ""
    return f"{value * scale:.1f}" if not sd > 0 else format_pm(value * scale, sd * scale)


def _status(result):
    if result.ok:
        no_k = "" if np.isfinite(result.k) else reading_text(result)  # a glass reference curve
        return "ok" + (f"<br>{_e(no_k)}" if no_k else "")
    if result.accepted:  # imprecise: kept, with its reason
        return f"{_e(result.status)}<br><span class='reason'>{_e(result.detail)}</span>"
    return f"<b>{_e(result.status)}</b><br><span class='reason'>{_e(result.detail)}</span>"


def _link(figure_dir, name):
    """Thumbnail linking to the full PNG; ``figure_dir/name`` as a relative URL."""
    if name is None:
        return ""
    url = _e(quote(str(PurePosixPath(figure_dir) / name)))
    return f"<a href='{url}'><img class='thumb' loading='lazy' alt='{_e(name)}' src='{url}'></a>"


def _key(value, scale=1.0):
    """A cell's numeric sort key (``data-key``): the value in the shown unit, empty if none."""
    return f"{value * scale:.6g}" if value is not None and np.isfinite(value) else ""


def _row(row, result, figure_dir, name):
    res = shown_result(row, result)
    index = "map" if row.whole_map else row.curve_index
    cells = [_e(row.name), _e(index), _e(row.cell_id), _e(row.target), _status(res),
             _e(_pm(res.k, res.k_err, 1e3)), _e(_pm(res.depth, res.depth_err, 1e9)),
             _e(_pm(res.contact_height, res.contact_err, 1e9)), _link(figure_dir, name)]
    # numeric columns sort by value, not by their text ("10.2 ± 0.3" after "9.8 ± 0.4")
    keys = {1: "" if row.whole_map else _key(row.curve_index), 5: _key(res.k, 1e3),
            6: _key(res.depth, 1e9), 7: _key(res.contact_height, 1e9)}
    kind = "accepted" if res.accepted else "rejected"
    tds = "".join(f"<td data-key='{keys[i]}'>{c}</td>" if i in keys else f"<td>{c}</td>"
                  for i, c in enumerate(cells))
    return f"<tr class='{kind}' data-status='{_e(res.status)}'>{tds}</tr>"


def _filter(result):
    """The status filter above the table: every curve, accepted, rejected, or one status."""
    shown = [r.status for r in result.results]
    n_ok = sum(r.accepted for r in result.results)
    options = [("", f"every curve ({len(shown)})"), ("kind:accepted", f"accepted ({n_ok})"),
               ("kind:rejected", f"rejected ({len(shown) - n_ok})")]
    options += [(f"status:{s}", f"{s} ({c})") for s, c in sorted(Counter(shown).items())]
    body = "".join(f"<option value='{_e(v)}'>{_e(t)}</option>" for v, t in options)
    return (f"<p><label>Show <select id='status-filter'>{body}</select></label> "
            f"<span id='shown'>{len(shown)} of {len(shown)} curves shown</span>; click a column "
            "heading to sort by it (again to reverse).</p>")


#: Sorting by a column heading and filtering by status, in the page itself (no other file).
_SCRIPT = """<script>
(function () {
  var table = document.getElementById('curves'), body = table.tBodies[0];
  var heads = table.tHead.rows[0].cells, filter = document.getElementById('status-filter');
  var rows = Array.prototype.slice.call(body.rows);
  function key(row, i) {
    var k = row.cells[i].getAttribute('data-key');
    if (k === null) return row.cells[i].textContent.trim().toLowerCase();
    return k === '' ? Infinity : parseFloat(k);
  }
  Array.prototype.forEach.call(heads, function (th, i) {
    th.addEventListener('click', function () {
      var up = th.getAttribute('aria-sort') !== 'ascending';
      Array.prototype.forEach.call(heads, function (h) { h.removeAttribute('aria-sort'); });
      th.setAttribute('aria-sort', up ? 'ascending' : 'descending');
      var order = rows.map(function (r, n) { return [key(r, i), n, r]; });
      order.sort(function (a, b) {
        var c = a[0] < b[0] ? -1 : a[0] > b[0] ? 1 : 0;
        return (up ? c : -c) || a[1] - b[1];
      });
      order.forEach(function (o) { body.appendChild(o[2]); });
    });
  });
  filter.addEventListener('change', function () {
    var v = filter.value, n = 0;
    rows.forEach(function (r) {
      var show = v === '' || v === 'kind:' + r.className || v === 'status:' + r.getAttribute('data-status');
      r.hidden = !show;
      n += show ? 1 : 0;
    });
    document.getElementById('shown').textContent = n + ' of ' + rows.length + ' curves shown';
  });
})();
</script>"""


def _summary(result):
    n_ok, n = sum(r.accepted for r in result.results), len(result.results)
    rejected = Counter(r.status for r in result.results if not r.accepted)
    text = f"{n_ok} of {n} curves accepted"
    if rejected:
        text += "; rejected: " + ", ".join(f"{c} {s}" for s, c in sorted(rejected.items()))
    parts = [f"<p class='{'ok' if not rejected else 'note'}' id='summary'>{_e(text)}.</p>"]
    if result.left_out:
        parts.append("<p class='note'>Cells left out of the cell table: "
                     + "; ".join(f"{_e(c)} ({_e(w)})" for c, w in result.left_out.items()) + "</p>")
    return "".join(parts)


def _provenance(result, table_name):
    m = result.manifest
    rows = [("manifest", f"{m.path.name} (sha256 {m.sha256})"),
            ("settings", ", ".join(f"{k} = {v}" for k, v in result.settings.as_dict().items())
             + " (SI units)"),
            ("written by", f"turgorbayes {__version__}")]
    rows += [("manifest comment", c.lstrip("#").strip()) for c in m.comments]
    body = "".join(f"<tr><th>{_e(k)}</th><td>{_e(v)}</td></tr>" for k, v in rows)
    table = f" (<a href='{_e(quote(table_name))}'>{_e(table_name)}</a>)" if table_name else ""
    return f"<h2>Provenance</h2><p>Per-curve numbers{table}.</p><table>{body}</table>"


def render_curves_html(result, figure_names=None, figure_dir=FIGURE_DIR, table_name="curves.csv"):
    """The overview page of a manifest's curves (an HTML string).

    Parameters
    ----------
    result : turgorbayes.curves.pipeline.ManifestResult
    figure_names : sequence of str, optional
        Each curve's PNG inside ``figure_dir`` (:func:`turgorbayes.plots.curves.write_curve_figures`),
        in manifest order; None for no thumbnails.
    figure_dir : str
        Folder of the PNGs, relative to the page.
    table_name : str or None
        The per-curve table's file name beside the page (linked).

    Returns
    -------
    str
    """
    if PurePosixPath(figure_dir).is_absolute() or ".." in PurePosixPath(figure_dir).parts:
        raise ValueError(f"figure_dir must be a folder beside the page, got {figure_dir!r}")
    names = list(figure_names) if figure_names is not None else [None] * len(result.results)
    rows = "\n".join(_row(row, res, figure_dir, name) for row, res, name in
                   zip(result.manifest.rows, result.results, names, strict=True))
    head = "".join(f"<th>{_e(h)}</th>" for h in HEADER)
    title = f"turgorbayes curves: {result.manifest.path.name}"
    return ("<!DOCTYPE html><html><head><meta charset='utf-8'>"
            f"<title>{_e(title)}</title><style>{_PAGE_CSS}</style></head><body>"
            f"<h1>{_e(title)}</h1>{_summary(result)}"
            "<p>Each figure: the recorded approach with its baseline and contact point (left), "
            "force against indentation with the fit window and the secant F = k h (right); "
            "click a thumbnail for the full figure. Rejected curves are red.</p>"
            f"{_filter(result)}"
            f"<table id='curves'><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table>"
            f"{_provenance(result, table_name)}{_SCRIPT}</body></html>\n")


def write_curves_html(path, result, figure_names=None, figure_dir=FIGURE_DIR, table_name="curves.csv"):
    """Write :func:`render_curves_html` to ``path`` (UTF-8).

    Parameters
    ----------
    path : path-like
        The page; ``figure_dir`` and ``table_name`` are relative to its folder.
    result, figure_names, figure_dir, table_name
        As in :func:`render_curves_html`.
    """
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(render_curves_html(result, figure_names, figure_dir, table_name))
