"""Reports rendered from finished outputs: ``report.html`` (:mod:`.html`), a fit's ``report.md``
(:mod:`.fit`), the criticism's outputs (:mod:`.criticism`) and the table of numbers to quote
(:mod:`.table`)."""

from turgorbayes.report import criticism, fit, table, text
from turgorbayes.report.html import (
    criticism_dir_of,
    diagnostic_warnings,
    load_outputs,
    render_html,
    write_report,
)

__all__ = ["criticism", "criticism_dir_of", "diagnostic_warnings", "fit", "load_outputs", "table", "text",
           "render_html", "write_report"]
