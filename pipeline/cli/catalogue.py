"""The method catalogue as data: what ``pipeline methods`` prints, read without importing
the methods themselves (scipy, numpy ... cost about a second of start-up).

The one source of each method's metadata is its ``@register(...)`` in
:mod:`pipeline.methods`; ``pipeline/data/methods.json`` is generated from that registry
(``python -m pipeline.cli.catalogue > pipeline/data/methods.json``) and a test checks
that the shipped file is the generated one, as for the results schema.
"""

from __future__ import annotations

import json
from importlib.resources import files

#: The fields of a catalogue entry, in display order.
FIELDS = ("id", "kind", "event", "structures", "title", "citation")


def catalogue() -> list[dict]:
    """The shipped catalogue: one dict of :data:`FIELDS` per method, in catalogue order."""
    text = files("pipeline").joinpath("data", "methods.json").read_text(encoding="utf-8")
    return json.loads(text)


def rows_of(infos) -> list[dict]:
    """Catalogue entries of registry entries (:class:`pipeline.methods.MethodInfo`)."""
    return [{"id": m.id, "kind": m.kind, "event": m.event, "structures": list(m.structures),
             "title": m.title, "citation": m.citation} for m in infos]


def generated_text() -> str:
    """The catalogue of the live registry, as shipped in ``pipeline/data/methods.json``."""
    from ..methods import REGISTRY

    return json.dumps(rows_of(REGISTRY.values()), indent=1, ensure_ascii=False) + "\n"


if __name__ == "__main__":
    print(generated_text(), end="")
