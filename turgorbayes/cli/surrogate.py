"""``turgorbayes surrogate build|check|info``: the finite-element k_c/(P R_c) table."""

import dataclasses
import json
import shlex
import sys
import textwrap

import click
import numpy as np

from turgorbayes.cli.progress import PROGRESS
from turgorbayes.errors import TurgorBayesError
from turgorbayes.surrogate.build import DEFAULT_GRID_SPEC

__all__ = ["axes_lines", "build", "check", "check_lines", "convergence_lines", "fe_axes", "info",
           "info_lines", "parse_setting", "surrogate"]

#: Longest line of ``surrogate info`` (longer ones are wrapped).
INFO_WIDTH = 110

_GRID_HELP = f"""Grid of the sweep. Syntax: AXIS=ITEMS[,AXIS=ITEMS] for the axes x (target
inflation number P R_c/(E_perp t)) and ratio (E_par/E_perp), both required. ITEMS is a
comma-separated list of numbers and ranges START:STOP:Nlog (N log-spaced values, ends
included) or START:STOP:N[lin] (N evenly spaced); at least 4 distinct values per axis.
Default: {DEFAULT_GRID_SPEC}"""


@click.group()
def surrogate():
    """Build, check and inspect the finite-element k_c/(P R_c) surrogate table."""


def _fe_config(mesh_scale, settings):
    """The table settings (``fem.TABLE_SETTINGS``) with the --mesh-scale and --set overrides."""
    from turgorbayes import fem

    overrides = dict(parse_setting(s) for s in settings)
    if mesh_scale is not None:
        overrides["mesh_scale"] = mesh_scale
    try:
        return fem.table_config(**overrides)
    except TypeError as err:
        names = ", ".join(f.name for f in dataclasses.fields(fem.CapsuleConfig))
        raise TurgorBayesError(f"bad FE setting ({err}); allowed: {names}") from None


def parse_setting(text):
    key, sep, value = text.partition("=")
    if not sep or not key.strip():
        raise TurgorBayesError(f"--set expects KEY=VALUE, got {text!r}")
    try:
        return key.strip(), json.loads(value)
    except json.JSONDecodeError:
        return key.strip(), value


@surrogate.command()
@click.option("--out", required=True, type=click.Path(dir_okay=False),
              help="netCDF table to write (the shipped one is turgorbayes/data/k_over_PR.nc).")
@click.option("--workers", default=1, show_default=True, type=click.IntRange(min=1),
              help="Local worker processes (each FE point runs in one).")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Dask scheduler address (e.g. tcp://host:8786); overrides --workers.")
@click.option("--grid", "grid_spec", default=DEFAULT_GRID_SPEC, metavar="SPEC", help=_GRID_HELP)
@click.option("--resume", is_flag=True,
              help="Reuse the finished points in the points folder; redo failed/missing ones.")
@click.option("--mesh-scale", type=float, default=None, metavar="S",
              help="FE element-size factor (CapsuleConfig.mesh_scale; > 1 coarser) "
                   "[default: the table settings', turgorbayes.fem.TABLE_SETTINGS].")
@click.option("--set", "settings", multiple=True, metavar="KEY=VALUE",
              help="Any other CapsuleConfig setting (repeatable), e.g. --set thickness=4.5e-9. "
                   "Unset ones are the table settings (turgorbayes.fem.TABLE_SETTINGS; "
                   "`turgorbayes surrogate info` prints a table's), then CapsuleConfig's "
                   "defaults.")
@click.option("--points-dir", default=None, type=click.Path(file_okay=False),
              help="Folder of per-point records [default: OUT.points].")
@PROGRESS
def build(out, workers, scheduler, grid_spec, resume, mesh_scale, settings, points_dir, progress):
    """Run the FE sweep and write the surrogate table OUT.

    Each finished point is saved at once in the points folder; an interrupted build continues
    with --resume. Failed points are listed at the end and the command exits with status 2
    without writing OUT.
    """
    from turgorbayes.surrogate.build import build_surrogate, parse_grid

    grid = parse_grid(grid_spec)
    cfg = _fe_config(mesh_scale, settings)
    click.echo(f"sweep: {len(grid.points())} points ({len(grid.ratio)} ratios x {len(grid.x)} "
               f"x values), workers={workers}, scheduler={scheduler}", err=True)
    report = build_surrogate(out, grid, cfg, workers=workers, scheduler=scheduler, resume=resume,
                             points_dir=points_dir, progress=progress,
                             command_line=shlex.join(["turgorbayes", *sys.argv[1:]]))
    click.echo(f"wrote {report.path}: {report.n_run} points run, {report.n_skipped} reused, "
               f"{report.elapsed_s:.1f} s")


@surrogate.command(short_help="Re-run FE points and print the table's interpolation error.")
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--n", "n_points", default=3, show_default=True, type=click.IntRange(min=1),
              help="Random points to re-run.")
@click.option("--seed", default=0, show_default=True, type=int, help="Seed of the random points.")
@click.option("--at", "at", multiple=True, metavar="X,RATIO",
              help="Run this held-out point instead of random ones (repeatable).")
@click.option("--workers", default=1, show_default=True, type=click.IntRange(min=1))
@click.option("--tol", default=0.005, show_default=True, type=float,
              help="Exit with status 1 if any |relative error| exceeds this.")
@click.option("--save", default=None, type=click.Path(dir_okay=False),
              help="Also write the compared records as JSON.")
def check(file, n_points, seed, at, workers, tol, save):
    """Re-run FE points inside FILE's grid (random, or --at) and print the interpolation error.

    Random points avoid the buckled region, where the table gives no value; a --at point
    there is listed as such. The FE runs with the settings recorded in FILE; the error is
    s(x_FE, ratio)/k_FE - 1 at the FE's own inflation number.
    """
    from turgorbayes.surrogate import load
    from turgorbayes.surrogate.build import check_surrogate, write_check_records

    points = [_parse_point(a) for a in at] or None
    s = load(file)
    records = check_surrogate(s, n_points, seed, points=points, workers=workers)
    for line in check_lines(records):
        click.echo(line)
    if save:
        write_check_records(save, records)
    failed = [r for r in records if r["status"] != "ok"]
    if failed:
        raise TurgorBayesError(f"{len(failed)} FE point(s) failed: "
                               + "; ".join(r["error"] for r in failed))
    worst = max(_compared_errors(records), default=0.0)
    if worst > tol:
        raise click.ClickException(f"largest interpolation error {worst:.3%} exceeds --tol {tol}")


def _parse_point(text):
    """``"X,RATIO"`` -> (x, ratio); a usage error naming the value otherwise."""
    parts = text.split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        return float(parts[0]), float(parts[1])
    except ValueError:
        raise click.BadParameter(f"expected X,RATIO (two numbers), got {text!r}",
                                 param_hint="--at") from None


def check_lines(records):
    """Table of :func:`turgorbayes.surrogate.build.check_surrogate` records."""
    lines = [f"{'ratio':>6} {'x_FE':>9} {'k/PR FE':>9} {'interp':>9} {'error':>8} "
             f"{'klin FE':>9} {'interp':>9} {'error':>8} {'time':>7}"]
    for r in records:
        if r["status"] != "ok":
            lines.append(f"{r['ratio']:6.3f} {r['x_target']:9.4g}  FAILED: {r['error']}")
            continue
        if r.get("in_buckled_region"):
            lines.append(f"{r['ratio']:6.3f} {r['x']:9.4g} {r['k_over_PR']:9.5g}  in the buckled "
                         f"region: the table gives no value (FE buckled: {bool(r.get('buckled'))})")
            continue
        lines.append(
            f"{r['ratio']:6.3f} {r['x']:9.4g} {r['k_over_PR']:9.5g} {r['k_interp']:9.5g} "
            f"{r['err']:8.3%} {r['k_linear_over_PR']:9.5g} {r['k_linear_interp']:9.5g} "
            f"{r['err_linear']:8.3%} {r['wall_time_s']:6.1f}s"
        )
    errs = np.array(_compared_errors(records))
    if errs.size:
        lines.append(f"max |error| of k/PR at h = R/20: {errs.max():.3%} over {errs.size} points")
    return lines


def _compared_errors(records):
    """|relative error| of k/PR of the records with a table value (FE run ok, outside the
    buckled region)."""
    return [abs(r["err"]) for r in records
            if r["status"] == "ok" and not r.get("in_buckled_region")]


@surrogate.command()
@click.argument("file", required=False, type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True,
              help="Print the table's full provenance record as JSON instead.")
def info(file, as_json):
    """Print the provenance of a surrogate table FILE (default: the shipped one) and its axes,
    the FE settings included (one screen)."""
    from turgorbayes.surrogate.table import load

    s = load(file)
    if as_json:
        click.echo(json.dumps({"file": str(s.path), "sha256": s.sha256, **s.metadata,
                               "fe_setting_axes": fe_axes(s)}, indent=1, default=str))
        return
    for line in info_lines(s):
        click.echo(line)


def fe_axes(s):
    """The FE settings that ``turgorbayes.surrogate.load`` can change for the table ``s``:
    axis name -> its value here, the tabulated values and domain, or why none applies."""
    from turgorbayes.surrogate import SurrogateError
    from turgorbayes.surrogate.axes import AXES, axis_value, shipped_correction

    out = {}
    for name in AXES:
        try:
            corr = shipped_correction(name, s)
        except SurrogateError as err:
            out[name] = {"value_nm": None, "unavailable": str(err)}
            continue
        out[name] = {"value_nm": axis_value(s, name) * 1e9,
                     "tabulated_nm": [v * 1e9 for v in corr.nodes],
                     "x": list(corr.domain["x"]), "ratio": list(corr.domain["ratio"]),
                     "tables": {f"{v * 1e9:g} nm": {"file": c.path.name, "sha256": c.sha256}
                                for v, c in corr.corrections.items()}}
    return out


def axes_lines(s):
    """Lines naming every axis of the table ``s``: its own two and the FE settings."""
    lines = ["FE axes     by correction tables (surrogate.load; --tip-radius-nm, --wall-thickness-nm)"]
    for name, a in fe_axes(s).items():
        if a["value_nm"] is None:
            lines.append(f"  {name:<12}{a['unavailable']}")
            continue
        lines.append(f"  {name:<12}{a['value_nm']:g} nm here; tabulated "
                     f"{', '.join(f'{v:g}' for v in a['tabulated_nm'])} nm over x "
                     f"{a['x'][0]:.3g}-{a['x'][1]:.3g}, ratio {a['ratio'][0]:g}-{a['ratio'][1]:g}")
    return lines


def _stopped_points(t, h_over_R):
    """``(x, ratio, depth reached / (h_over_R R_c))`` of the points whose run ended early."""
    if "h_m" not in t or "R_c_m" not in t:
        return []
    t = t.transpose("ratio", "x", ...)
    reached = np.nanmax(t["h_m"].values, axis=-1) / (h_over_R * t["R_c_m"].values)
    return [(float(t["x_actual"].values[j, i]), float(t["ratio"].values[j]), float(reached[j, i]))
            for j, i in np.argwhere(reached < 1 - 1e-6)]


def _pct(value):
    """``0.003`` -> ``"0.3 %"``; ``"?"`` when not recorded."""
    return "?" if value is None else f"{100 * value:.2g} %"


#: What a correction table's mesh error means for the stiffness a fit uses (docs/fem.md).
_MESH_NOTES = {
    "thickness": "the thickness tables enter only as ratios to a 6 nm table on this same mesh, "
                 "where most of this error cancels (docs/fem.md, Wall thickness)",
    "tip radius": "the tip tables enter only as ratios to a 7.5 nm sweep on the same mesh "
                  "(docs/fem.md, Indenter tip radius)",
}


def _mesh_check_line(label, m):
    """Lines on a coarser mesh's check against a refined one (``mesh_convergence`` entry): the
    largest difference of k and where, and for a correction table what the error means."""
    points = [p for p in m.get("points", []) if "rel_diff_k" in p]
    worst = ""
    if points:
        top = max(points, key=lambda p: abs(p["rel_diff_k"]))
        where = f" (at x {top['x']:g})" if "x" in top else ""
        worst = (f"largest |k difference| {_pct(abs(top['rel_diff_k']))}{where} over "
                 f"{len(points)} points")
    line = (f"  {label:<10}mesh_scale {m.get('mesh_scale')} ({m.get('dofs')} DOF) against a finer "
            f"mesh: {worst}" + (f", error estimate {_pct(m['estimate_rel_error_k'])}"
                                if "estimate_rel_error_k" in m else ""))
    return [line] + ([f"            {_MESH_NOTES[label]}"] if label in _MESH_NOTES else [])


def convergence_lines(conv, dofs=None):
    """Human-readable lines of a table's ``mesh_convergence`` record (a few lines, not JSON).

    Parameters
    ----------
    conv : dict, str or None
        The record (``benchmark``, ``date``, ``production``, ``points``, ``table_mesh``,
        ``surrogate_mesh``, ``thickness_tables_mesh``, ``tip_tables_mesh`` and
        ``estimate_rel_error_k*``, as far as
        present), or the sentence a table stores when there is none.
    dofs : int, optional
        The table's mesh size: the mesh check with this many DOFs comes first, as "this mesh".

    Returns
    -------
    list of str
    """
    if not conv:
        return ["convergence not recorded"]
    if not isinstance(conv, dict):
        return [f"convergence {conv}"]
    earlier = "earlier" if "table_mesh" in conv else "table"  # the table mesh until 2026-11-26
    checks = [(key, label) for key, label in (("table_mesh", "table"), ("surrogate_mesh", earlier),
                                              ("thickness_tables_mesh", "thickness"),
                                              ("tip_tables_mesh", "tip radius"))
              if isinstance(conv.get(key), dict)]
    own = [c for c in checks if conv[c[0]].get("dofs") == dofs]
    if own:
        checks = own + [c for c in checks if c not in own]
        checks[0] = (checks[0][0], "this")
        lines = ["convergence against a finer mesh (k at h = R/20; tip radius: the elements "
                 "under the tip halved, others: every size halved)"]
    else:
        prod = conv.get("production") or {}
        lines = [f"convergence error of k about {_pct(conv.get('estimate_rel_error_k'))}, of "
                 f"k_linear about {_pct(conv.get('estimate_rel_error_k_linear'))} "
                 f"({prod.get('dofs', '?')} DOF; {conv.get('benchmark', '?')}, "
                 f"{conv.get('date', '?')})"]
        variants = [p for p in conv.get("points", []) if "variant" in p and "rel_diff_k" in p]
        if variants:
            lines.append("  variants  " + ", ".join(f"{p['variant']} {100 * p['rel_diff_k']:+.2f} %"
                                                     for p in variants))
    return lines + [line for key, label in checks for line in _mesh_check_line(label, conv[key])]


def info_lines(s):
    """One screen describing a :class:`turgorbayes.surrogate.Surrogate`'s table."""
    from turgorbayes.surrogate import force_drops

    m, t = s.metadata, s.table
    x, ratio = s.grid["x"], s.grid["ratio"]
    per = m.get("per_point_wall_time_s", {})
    sessions = m.get("build_sessions", [])
    lines = [
        f"file        {s.path}",
        f"sha256      {s.sha256}",
        f"format      {m.get('file_format')} v{m.get('format_version')}",
        f"created     {m.get('created_utc')} on {m.get('host')} ({m.get('host_cores')} cores)",
        f"software    turgorbayes {m.get('turgorbayes_version')}, git {m.get('git_commit')}"
        f"{' + uncommitted changes' if m.get('git_dirty') == 'yes' else ''}",
        f"command     {m.get('command_line')}",
        f"FE code     {m.get('point_function')}, sources sha256 {m.get('fe_source_sha256')}"
        f"{'' if m.get('fe_source_consistent', 'yes') == 'yes' else ' (MIXED VERSIONS)'}",
        f"grid        {m.get('grid_spec')}",
        f"  x         {x.size} values {x.min():.4g} .. {x.max():.4g}",
        f"  ratio     {ratio.size} values {', '.join(f'{r:g}' for r in ratio)}",
        f"domain      x in [{s.domain['x'][0]:.5g}, {s.domain['x'][1]:.5g}] (FE x_actual), "
        f"ratio in [{s.domain['ratio'][0]:g}, {s.domain['ratio'][1]:g}]",
        *axes_lines(s),
        f"k/PR        {float(t['k_over_PR'].min()):.4g} .. {float(t['k_over_PR'].max()):.4g}",
        f"mesh        {int(t['mesh_dofs'].min())} .. {int(t['mesh_dofs'].max())} DOF",
        *convergence_lines(m.get("mesh_convergence"), int(t["mesh_dofs"].max())),
        f"newton      {int(t['newton_iterations'].min())} .. "
        f"{int(t['newton_iterations'].max())} iterations per point",
        f"wall time   {m.get('total_point_wall_time_s', float('nan')):.0f} s in all points; per "
        f"point min {per.get('min', np.nan):.1f} / median {per.get('median', np.nan):.1f} / "
        f"max {per.get('max', np.nan):.1f} s",
    ]
    if "schedule" in t:
        used = [str(v).split(":")[0] for v in np.ravel(t["schedule"].values)]
        lines.append("schedule    depth steps per point: " + ", ".join(
            f"{kind} {used.count(kind)}" for kind in sorted(set(used))))
    if s.linear_excluded:
        lines.append(f"linear      {len(s.linear_excluded)} FE point(s) with a linear slope <= 0 left "
                     "out of Surrogate.linear: " + "; ".join(
                         f"x={p['x']:.4g} ratio={p['ratio']:g} ({p['k_linear_over_PR']:.3g})"
                         for p in s.linear_excluded))
    drops = force_drops(t)
    lines.append(f"force drops {len(drops)} FE point(s) whose force falls before h = R/20"
                 + (" (a snap; x/ratio: from that share of the depth, largest fall): " if drops
                    else "") + "; ".join(f"{d['x']:.3g}/{d['ratio']:g}: {d['depth']:.2f}, "
                                          f"{d['drop']:.1%}" for d in drops))
    stopped = _stopped_points(t, (m.get("fe_config") or {}).get("h_over_R", 1 / 20))
    if stopped:
        lines.append(f"stopped     {len(stopped)} FE point(s) whose run lost the loading path before "
                     "h = R/20 (buckled; x/ratio: at that share of the depth): "
                     + "; ".join(f"{x:.3g}/{r:g}: {f:.2f}" for x, r, f in stopped))
    if s.buckled_boxes:
        lines.append("buckled     grid cells next to buckled points (Surrogate.buckled; s(x, ratio) "
                     "is NaN there, fits report cells that reach them): "
                     + "; ".join(f"x {b['x'][0]:.4g}-{b['x'][1]:.4g} ratio {b['ratio'][0]:g}-"
                                 f"{b['ratio'][1]:g}" for b in s.buckled_boxes))
    for ses in sessions:
        lines.append(f"  session   {ses.get('started_utc')}: {ses.get('points_to_run')} points, "
                     f"workers={ses.get('workers')}, scheduler={ses.get('scheduler')}, "
                     f"{ses.get('elapsed_s', np.nan):.0f} s")
    cfg = ", ".join(f"{k}={v}" for k, v in (m.get("fe_config") or {}).items())
    lines.append("FE settings")
    lines.extend(textwrap.wrap(cfg, INFO_WIDTH - 4, initial_indent="  ", subsequent_indent="  "))
    lines.append("(every recorded number: turgorbayes surrogate info --json FILE)")
    return [w for line in lines for w in textwrap.wrap(line, INFO_WIDTH, subsequent_indent=" " * 12,
                                                      break_on_hyphens=False)
            or [line]]
