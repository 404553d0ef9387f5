"""The registry of effects: name -> :class:`turgorbayes.effects.base.Effect` instance, and
model names built from effect names (``"radius_spread+bad_curves"``)."""

from turgorbayes.effects.base import Effect

__all__ = ["EFFECTS", "FAULTY_READINGS", "OWN_STIFFNESS_FACTOR", "changes_wall", "effect_names",
           "effects_table",
           "get_effect", "model_name", "parse_model_name", "register_effect"]

#: Families of effects that describe the same data near-equally (measured with one of them left
#: out of the candidates: docs/validation.md, "When the cause is not in the library"); an
#: effect names its family in :attr:`Effect.family`.
FAULTY_READINGS = "faulty readings"
OWN_STIFFNESS_FACTOR = ("a stiffness factor of each intact cell's own: its turgor, or its "
                        "session's calibration")

#: Effect name -> :class:`Effect` instance (filled by the effect modules on import).
EFFECTS = {}


def register_effect(effect):
    """Add an :class:`Effect` instance to :data:`EFFECTS` under its ``name``."""
    if not isinstance(effect, Effect):
        raise TypeError(f"register_effect needs an Effect instance, got {type(effect).__name__}")
    EFFECTS[effect.name] = effect
    return effect


def effect_names():
    """Names of the registered effects, in registration order."""
    return list(EFFECTS)


def get_effect(name):
    """The registered :class:`Effect` called ``name``."""
    try:
        return EFFECTS[name]
    except KeyError:
        raise ValueError(f"unknown effect {name!r}; known effects: {', '.join(EFFECTS)}") from None


def changes_wall(model):
    """True when a model name (``"baseline"``, ``"radius_spread+bad_curves"``) holds an effect
    that changes the wall (:attr:`turgorbayes.effects.base.Effect.changes_wall`)."""
    return any(get_effect(n).changes_wall for n in parse_model_name(model))


def model_name(effects):
    """Name of the model with these effects: ``"baseline"`` or ``"radius_spread+bad_curves"``."""
    names = [e if isinstance(e, str) else e.name for e in effects]
    return "+".join(names) if names else "baseline"


def parse_model_name(name):
    """Effect names of a model name (inverse of :func:`model_name`)."""
    if name == "baseline":
        return []
    names = name.split("+")
    for n in names:
        get_effect(n)
    return names


def effects_table():
    """The table of docs/effects.md ("The effects"), one row per registered effect, from what
    each effect declares: its size parameter (symbol, prior, null value, realistic size in
    its command-line unit), how many parameters it has, and whether it names a cause.

    Returns
    -------
    list of str
        Markdown lines: header, rule, rows in registry order.
    """
    lines = ["| effect | size parameter | prior | null | realistic size | parameters | names a cause |",
             "|---|---|---|---|---|---|---|"]
    for name in effect_names():
        e = get_effect(name)
        p = next(p for p in e.parameters if p.name == e.size_parameter)
        unit, factor = e.size_unit
        prior = p.prior.describe(unit, factor) if unit else p.prior.describe()
        u = f" {unit}" if unit else ""
        lines.append(f"| `{name}` | {p.label} | {prior} | {e.null_value / factor:.3g}{u} | "
                     f"{e.realistic_size / factor:.3g}{u} | {len(e.parameters)} | "
                     f"{'yes' if e.names_cause else 'no (generic)'} |")
    return lines
