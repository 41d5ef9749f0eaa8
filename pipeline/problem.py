"""The data of one least-squares refinement (:mod:`pipeline.refine`): the span, the fit
samples and their criterion rows, and the design columns of the separable problem at a
parameter set (the forced response, the offset, the free response of an estimated initial
state, an integrating structure's input balance)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from . import basis
from .lstsq import block_bounds, blocks
from .models import STRUCTURES


@dataclass(frozen=True)
class Problem:
    """The data of a fit. The criterion rows are the fit samples, or on a long window the
    means of blocks of consecutive fit samples times sqrt(block size) (the model is still
    simulated at every sample; averaging only drops within-block noise)."""

    structure: str
    t_rel: np.ndarray  # time since the span start
    du: np.ndarray  # u - u_ref over the span
    y: np.ndarray  # measured output at the criterion rows
    mask: np.ndarray  # fit samples of the span
    starts: np.ndarray  # first fit sample (index into the masked samples) of each row
    counts: np.ndarray  # fit samples per row
    dt: float | None
    horizon: float
    state: str  # "rest", "estimated" or "steady" (see refine)
    free_lags: int
    full: bool = False  # every sample of the span is a fit sample
    linear: tuple[str, ...] = ()  # LINEAR_PARAMS solved inside the residual (the search)
    bounds: np.ndarray | None = None  # reduceat boundaries in the span (None: no blocks)
    keep: np.ndarray | None = None  # which of the reduced blocks are rows

    @classmethod
    def of(cls, t, u, y, structure: str, *, u_ref: float, mask: np.ndarray,
           initial_state: str, free_lags: int, max_rows: int) -> Problem:
        """The problem of fitting ``structure`` to ``y`` over the span ``t, u`` (the model
        starting at the first sample) on the samples of ``mask``, in at most ``max_rows``
        criterion rows."""
        t = np.asarray(t, np.float64)
        base = cls(structure, t - t[0], np.asarray(u, np.float64) - u_ref, np.empty(0),
                   np.ones(t.size, bool), np.zeros(0, int), np.zeros(0), basis.uniform_step(t),
                   float(t[-1] - t[0]), initial_state, free_lags)
        return base.with_mask(mask, y, max_rows)

    def with_mask(self, mask: np.ndarray, y: np.ndarray, max_rows: int) -> Problem:
        """The same span and model with the criterion over ``mask``'s samples of the span
        output ``y`` (the span's arrays shared, not copied: one problem per
        cross-validation fold costs its rows only)."""
        mask = np.asarray(mask, bool)
        starts, counts = blocks(mask, max_rows)
        bounds, keep = ((None, None) if starts.size == np.count_nonzero(mask)
                        else block_bounds(mask, starts))
        prob = replace(self, mask=mask, starts=starts, counts=counts, full=bool(mask.all()),
                       bounds=bounds, keep=keep)
        return replace(prob, y=prob.rows(np.asarray(y, np.float64)))

    @property
    def estimate_state(self) -> bool:
        return self.state == "estimated"

    @property
    def balance(self) -> bool:
        """Whether the input balance point of an integrating structure is estimated: with
        the state or on a steady ramp, not at rest (at rest the model is in equilibrium
        at ``u_ref``; a free balance point would let a ramp before the step pass for
        rest, and a lag's settling for an integrator whose input came to balance)."""
        return STRUCTURES[self.structure].integrating and self.state != "rest"

    def rows(self, a: np.ndarray) -> np.ndarray:
        """Criterion rows of span columns ``a`` (or of a span vector). Blocks never
        straddle a gap of the mask (:func:`pipeline.lstsq.blocks`), so they are summed in
        place, the gaps as blocks of their own that are dropped (the same sums as of the
        masked copy, without copying the span's columns on every evaluation)."""
        if self.bounds is None:  # a row per fit sample
            return a if self.full else a[self.mask]
        w = np.sqrt(self.counts) if a.ndim == 1 else np.sqrt(self.counts)[:, None]
        return np.add.reduceat(a, self.bounds, axis=0)[self.keep] / w

    @cached_property
    def offset_rows(self) -> np.ndarray:
        """The rows of the offset column (all ones), which no parameter changes."""
        return self.rows(np.ones(self.t_rel.size))

    def design_rows(self, p: Mapping[str, float]) -> np.ndarray:
        """``rows(design(p))``; at rest the offset is the only nuisance column and its
        rows are computed once (:attr:`offset_rows`)."""
        return self.reduce(self.span_design(p))

    def span_design(self, p: Mapping[str, float]) -> np.ndarray | list[np.ndarray]:
        """The span columns :meth:`reduce` makes the design rows of: :meth:`design`, or at
        rest the forced responses alone (the offset's rows are :attr:`offset_rows`). They
        do not depend on the mask, so problems that differ only in it share them."""
        if self.estimate_state or self.balance:
            return self.design(p)
        base = {**p, **dict.fromkeys(self.linear, 0.0)}
        x0 = self.forced(base)
        return [x0, *(self.forced({**base, n: 1.0}) - x0 for n in self.linear)]

    def reduce(self, d: np.ndarray | list[np.ndarray]) -> np.ndarray:
        """The design rows of :meth:`span_design`'s columns ``d``."""
        if isinstance(d, np.ndarray):
            return self.rows(d)
        return np.column_stack([*(self.rows(x) for x in d), self.offset_rows])

    def forced(self, p: Mapping[str, float]) -> np.ndarray:
        """The unit-gain forced response over the span."""
        return basis.forced_response(self.structure, dict(p), self.t_rel, self.du, self.dt)

    def design(self, p: Mapping[str, float]) -> np.ndarray:
        """The span columns of the linear solve: the forced response (with ``linear``: at
        0 and the change per unit of each), then :meth:`columns`' nuisance columns."""
        if not self.linear:
            x, nuis = self.columns(p)
            return np.column_stack([x, nuis])
        x0, nuis = self.columns({**p, **dict.fromkeys(self.linear, 0.0)})
        xs = [self.forced({**p, **dict.fromkeys(self.linear, 0.0), n: 1.0}) - x0
              for n in self.linear]  # the forced response alone: columns()' first
        return np.column_stack([x0, *xs, nuis])

    def columns(self, p: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
        """``(x, nuisance columns)`` over the whole span."""
        x = self.forced(p)
        cols = [np.ones_like(x)]
        if self.balance:  # an input offset from the start: lagged, or a ramp already steady
            cols.append(basis.offset_response(self.structure, dict(p), self.t_rel)
                        if self.estimate_state else self.t_rel)
        if self.estimate_state:
            b = basis.free_basis(self.structure, dict(p), self.t_rel, self.horizon,
                                 self.free_lags)
            cols.extend(b.T)
        return x, np.column_stack(cols)
