"""Help texts that list the registered effects, read from the registry when help is shown.

The effect names are never typed into a help text: :class:`EffectHelpOption` fills
``{effects}`` (every registered effect) and ``{sizes}`` (each effect's size parameter and its
unit on the command line) at ``--help`` time, so that ``turgorbayes --help`` stays fast.
"""

import click

__all__ = ["EffectHelpOption", "effect_help"]


def effect_help(template):
    """``template`` with ``{effects}`` and ``{sizes}`` filled from the effect registry."""
    from turgorbayes import effects

    names = effects.effect_names()
    sizes = []
    for n in names:
        e = effects.get_effect(n)
        unit = e.size_unit[0]
        sizes.append(f"{n}: {e.size_parameter}" + (f" [{unit}]" if unit else ""))
    return template.format(effects=", ".join(names), sizes="; ".join(sizes))


class EffectHelpOption(click.Option):
    """A click option whose help template is filled by :func:`effect_help` when shown."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._template = self.help

    def get_help_record(self, ctx):
        # filled anew each time from the kept template: an effect registered later (a
        # plug-in, a notebook) appears in the next help
        if self._template and "{" in self._template:
            self.help = effect_help(self._template)
        return super().get_help_record(ctx)
