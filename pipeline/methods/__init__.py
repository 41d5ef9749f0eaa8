"""Transient-analysis methods, one module per family, all behind one registry.

Importing this package imports every method module (they register themselves), so the
registry is complete without a hand-kept list.
"""

import importlib
import pkgutil

from .registry import REGISTRY, MethodInfo, MethodResult, identify, register

for _m in pkgutil.iter_modules(__path__):
    if _m.name not in {"registry", "base", "references"}:
        importlib.import_module(f"{__name__}.{_m.name}")

from .base import moving_the_other_way, undershoot  # noqa: E402 (after the registrations)
from .lsq import event_fit, span_refinement  # noqa: E402
from .second_order import light_ring  # noqa: E402

#: Display order: DESIGN.md's catalogue (registration order is the file listing).
CATALOGUE = ["first_order", "first_order_two_point", "first_order_impulse",
             "second_order_overshoot", "second_order_pov", "second_order_impulse",
             "viteckova1", "viteckova2", "latzel", "harriott", "smith", "strejc", "sundaresan"]
_order = {mid: k for k, mid in enumerate(CATALOGUE)}
for _mid in sorted(REGISTRY, key=lambda m: _order.get(m, len(_order))):
    REGISTRY[_mid] = REGISTRY.pop(_mid)


def method_ids(event: str | None = None) -> list[str]:
    """Registered ids in catalogue order, optionally only those for one event kind."""
    return [m.id for m in REGISTRY.values() if event is None or m.accepts(event)]


def select_methods(requested: list[str] | str | None, event_kind: str) -> list[str]:
    """The methods to run on an event of ``event_kind``: the one place this is decided.

    ``"all"`` (or None) means every registered method for that kind of event; an explicit
    list is run as given, so a method for another kind of event is listed as not
    applicable with its reason (the user asked for it by name).
    """
    if requested is None or requested == "all":
        return method_ids(event_kind)
    return list(requested)


__all__ = ["REGISTRY", "MethodInfo", "MethodResult", "event_fit", "identify", "light_ring",
           "method_ids", "moving_the_other_way", "register", "select_methods",
           "span_refinement", "undershoot"]
