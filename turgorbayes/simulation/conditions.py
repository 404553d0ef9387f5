"""Simulated experiments with several conditions sharing one wall (``simulate --conditions``).

Each condition is simulated by :func:`turgorbayes.simulation.cells.simulate_cells` with the shared
wall (``gamma``, ``E0t``, ``R0``) and its own physiological turgor; its cells are renamed
``<condition>-<id>`` and labelled in the ``condition`` column. Bulged cells (whose pressures
come from the design's range, not from P_phys) are drawn in the conditions that have any.
"""

import numpy as np

from turgorbayes.cells.table import CellData
from turgorbayes.simulation import cells as synthetic

__all__ = ["WALL_SPEC", "parse_bulged_counts", "parse_conditions", "parse_walls",
           "simulate_conditions"]

#: ``--condition-wall NAME:Q=V,...``: each quantity, how its value reads and its SI factor
#: (``E0t`` a factor of the shared ``E0t``, ``gamma`` a value, ``R0`` in nm).
WALL_SPEC = {"E0t": ("a factor of the shared E0t", None), "gamma": ("a value", 1.0),
             "R0": ("nm", 1e-9)}


def parse_conditions(text):
    """``"wt:29,treated:22"`` -> ``{"wt": 29e3, "treated": 22e3}`` [Pa] (values in kPa).

    Raises
    ------
    ValueError
        Malformed entry, empty or repeated name, or a turgor that is not a positive number.
    """
    out = {}
    for item in str(text).split(","):
        name, sep, value = item.partition(":")
        name = name.strip()
        try:
            kPa = float(value)
        except ValueError:
            kPa = float("nan")
        if not sep or not name or name in out or not np.isfinite(kPa) or kPa <= 0:
            raise ValueError(f"--conditions needs NAME:TURGOR_kPa pairs joined by commas with "
                             f"distinct names and turgors > 0 (e.g. wt:29,treated:22), got "
                             f"{item!r} in {text!r}")
        out[name] = kPa * 1e3
    return out


def parse_walls(specs, names, truth):
    """``--condition-wall`` specs -> ``{name: {"gamma"|"E0t"|"R0": value [SI]}}``.

    Each spec is ``NAME:Q=V[,Q=V...]`` (:data:`WALL_SPEC`): ``E0t=0.7`` is 0.7 times the
    shared ``truth.E0t``, ``gamma=1.4`` the exponent itself, ``R0=480`` a rest radius of
    480 nm. A condition may appear in several specs, a quantity only once per condition.

    Raises
    ------
    ValueError
        Malformed spec, unknown condition or quantity, a repeated quantity, or a value that
        is not a positive finite number; the message names the spec and the value.
    """
    allowed = ", ".join(f"{q}=<{how}>" for q, (how, _) in WALL_SPEC.items())
    out = {}
    for spec in specs:
        name, sep, body = str(spec).partition(":")
        name = name.strip()
        if not sep or not body.strip():
            raise ValueError(f"--condition-wall needs NAME:QUANTITY=VALUE[,...] (quantities "
                             f"{allowed}; e.g. treated:E0t=0.7), got {spec!r}")
        if name not in names:
            raise ValueError(f"--condition-wall {spec!r}: no condition {name!r} in --conditions "
                             f"({', '.join(names)})")
        wall = out.setdefault(name, {})
        for item in body.split(","):
            q, eq, value = (t.strip() for t in item.partition("="))
            if q not in WALL_SPEC or not eq:
                raise ValueError(f"--condition-wall {spec!r}: {item.strip()!r} is not "
                                 f"QUANTITY=VALUE with a quantity of {allowed}")
            if q in wall:
                raise ValueError(f"--condition-wall {spec!r}: {q} of {name} given twice")
            try:
                x = float(value)
            except ValueError:
                x = float("nan")
            if not np.isfinite(x) or x <= 0:
                raise ValueError(f"--condition-wall {spec!r}: {q} must be a positive number "
                                 f"({WALL_SPEC[q][0]}), got {value!r}")
            wall[q] = x * truth.E0t if q == "E0t" else x * WALL_SPEC[q][1]
    return out


def parse_bulged_counts(text, names):
    """``--n-bulged-per-condition``: ``"36"`` (every condition) or ``"wt:72,treated:36"`` ->
    ``{name: count}`` (conditions not named get none).

    Raises
    ------
    ValueError
        Malformed entry, unknown or repeated condition, a count that is not an integer >= 0,
        or no bulged cell at all.
    """
    text = str(text).strip()
    usage = ("--n-bulged-per-condition needs N (bulged cells in every condition) or NAME:N "
             "pairs joined by commas (e.g. wt:72,treated:36)")
    if ":" not in text:
        items = [(n, text) for n in names]
    else:
        items = [tuple(t.strip() for t in item.partition(":")[::2]) for item in text.split(",")]
    out = {}
    for name, value in items:
        if name not in names or name in out:
            raise ValueError(f"{usage}; {name!r} is {'repeated' if name in out else 'not a condition'}"
                             f" (conditions: {', '.join(names)}), in {text!r}")
        if not value.isdigit():
            raise ValueError(f"{usage}; the count of {name!r} must be an integer >= 0, got "
                             f"{value!r}")
        out[name] = int(value)
    if not any(out.values()):
        raise ValueError(f"{usage}; at least one bulged cell is needed, got {text!r}")
    return out


def _one(name, P_phys, n_bulged, n_intact, truth, seed, surrogate, wall=None, series=None,
         **kwargs):
    """Cells of one condition (bulged ones only if ``n_bulged``) and its truths; ``wall``
    overrides the shared wall's ``gamma``, ``E0t``, ``R0``; ``series`` (keyword arguments of
    :class:`~turgorbayes.simulation.osmotic.OsmoticSeries` but the truth) puts its intact cells
    in an osmotic series at its own wall and turgor."""
    w = {"gamma": truth.gamma, "E0t": truth.E0t, "R0": truth.R0, **(wall or {})}
    t = synthetic.Truth(P_phys=P_phys, P0=truth.P0, **w)
    injection = None
    if series is not None:
        from turgorbayes.simulation import osmotic

        injection = osmotic.OsmoticSeries(truth=t, **{"growth": osmotic.DEFAULT_GROWTH_MEDIUM,
                                                       "b": osmotic.DEFAULT_B, **series})
        kwargs["effects"] = (injection, *kwargs.get("effects", ()))
    cells, truths = synthetic.simulate_cells(max(n_bulged, 1), n_intact, t, seed,
                                             surrogate=surrogate, **kwargs)
    if injection is not None:
        truths["osmotic"] = injection.truths()
    if not n_bulged:
        cells = cells.intact()
    keep = [cid in set(cells.cell_id) for cid in truths["cells"]["cell_id"]]
    truths["cells"] = {key: [v for v, k in zip(values, keep, strict=True) if k]
                       for key, values in truths["cells"].items()}
    truths["cells"]["cell_id"] = [f"{name}-{cid}" for cid in truths["cells"]["cell_id"]]
    return cells, truths


def simulate_conditions(conditions, n_intact=42, n_bulged=None, truth=synthetic.PAPER_TRUTH,
                        seed=0, surrogate=None, walls=None, series=None, **kwargs):
    """Simulate one experiment with several conditions and a shared wall.

    Parameters
    ----------
    conditions : dict
        Condition name -> its physiological turgor P_phys [Pa], in file order.
    n_intact : int
        Intact cells per condition.
    n_bulged : dict, optional
        Condition name -> bulged cells; default 72 in the first condition, none elsewhere.
    truth : turgorbayes.simulation.cells.Truth
        The shared wall (its ``P_phys`` is ignored).
    seed : int
        Condition ``j`` is simulated with the seed ``[seed, j]`` (independent streams).
    surrogate : Surrogate, optional
    walls : dict, optional
        Condition name -> ``{"gamma"|"E0t"|"R0": value}`` (SI): that condition's wall differs
        from the shared one (a wall the baseline with conditions does not allow: what the
        criticism's ``conditions`` check is for). Default: every condition has the shared
        wall.
    series : dict, optional
        Every condition an osmotic series: ``added`` (mOsm added to the growth medium at each
        level, 0 included), optionally ``growth`` [mOsm], ``b``, ``temperature`` [K],
        ``length_model`` (:class:`~turgorbayes.simulation.osmotic.OsmoticSeries`); each
        condition's intact cells split evenly over the levels at the turgors its own wall and
        P_phys give (its truths then hold ``osmotic``). Bulged cells stay in the growth
        medium.
    **kwargs
        Passed to :func:`turgorbayes.simulation.cells.simulate_cells` (``errors``, ``noise`` ...).

    Returns
    -------
    cells : turgorbayes.cells.table.CellData
        The conditions' cells in order, with a ``condition`` column.
    truths : dict
        ``conditions`` (per condition: the simulate_cells truths), ``parameters`` (the
        shared wall and each condition's P_phys_kPa), ``walls`` (the overrides, SI; empty
        for a shared wall).
    """
    from turgorbayes import surrogate as surrogate_module

    surrogate = surrogate_module.load() if surrogate is None else surrogate
    names = list(conditions)
    n_bulged = {names[0]: 72} if n_bulged is None else dict(n_bulged)
    walls = {n: dict(w) for n, w in (walls or {}).items()}
    unknown = sorted(set(walls) - set(names)) + sorted(
        {q for w in walls.values() for q in w} - {"gamma", "E0t", "R0"})
    if unknown:
        raise ValueError(f"walls: unknown condition or quantity {unknown} (conditions "
                         f"{names}; quantities gamma, E0t, R0)")
    parts, truths = [], {}
    for j, name in enumerate(names):
        seed_j = int(np.random.SeedSequence([int(seed), j]).generate_state(1)[0])
        cells, tr = _one(name, conditions[name], n_bulged.get(name, 0), n_intact, truth,
                         seed_j, surrogate, wall=walls.get(name), series=series, **kwargs)
        parts.append((name, cells))
        truths[name] = tr
    cells = _concatenate(parts, _comments(parts, conditions, truth, seed, walls))
    return cells, {"simulated": True, "seed": seed, "conditions": truths,
                   "parameters": {"gamma": truth.gamma, "E0t_N_per_m": truth.E0t,
                                  "R0_nm": truth.R0 * 1e9,
                                  "P_phys_kPa": {n: conditions[n] / 1e3 for n in names}},
            "walls": walls}


def _comments(parts, conditions, truth, seed, walls=None):
    """Provenance lines: simulated, the seed, the shared wall (and any condition's own),
    each condition's turgor and cells, then the first condition's error and table lines."""
    first = parts[0][1].comments
    head = (first[0].split(", seed ")[0] + f" --conditions, seed {seed}"
            + (", noise-free" if first[0].endswith("noise-free") else ""))
    return [head, f"# truth: gamma = {truth.gamma:g}, E0t = {truth.E0t:g} N/m, R0 = "
            f"{truth.R0 * 1e9:g} nm (shared), P0 = {truth.P0 / 1e3:g} kPa; P_phys: "
            + ", ".join(f"{n} = {conditions[n] / 1e3:g} kPa" for n, _ in parts)
            + "".join(f"; wall of {n}: " + ", ".join(f"{q} = {x:g}" for q, x in w.items())
                      for n, w in (walls or {}).items() if w),
            "# conditions: " + ", ".join(f"{n} {len(c)} cells ({c.n_bulged} bulged)"
                                         for n, c in parts)] + [
        c for c in first[1:] if not c.startswith("# truth:")]


def _concatenate(parts, comments):
    """One :class:`CellData` of the conditions' cells, ids prefixed by the condition."""
    fields = ("R_c", "R_c_err", "k_c", "k_c_err", "R_b", "R_b_err", "k_b", "k_b_err", "h_b")
    first = parts[0][1]
    extra = {name: tuple(v for _, c in parts for v in c.extra[name]) for name in first.extra}
    extra["condition"] = tuple(name for name, c in parts for _ in range(len(c)))
    return CellData(
        cell_id=[f"{name}-{cid}" for name, c in parts for cid in c.cell_id],
        group=[g for _, c in parts for g in c.group], extra=extra, comments=comments,
        **{f: np.concatenate([getattr(c, f) for _, c in parts]) for f in fields})
