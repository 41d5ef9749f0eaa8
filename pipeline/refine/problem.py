"""The data of one least-squares refinement (:mod:`pipeline.refine`): the span, the fit
samples and their criterion rows, and the design columns of the separable problem at a
parameter set (the forced response, the offset, the free response of an estimated initial
state, an integrating structure's input balance).

A span can be a whole long record, so nothing span-long is copied that need not be: the
span's times and input are the caller's arrays (the input's deviation from ``u_ref`` is
taken a chunk at a time in the simulation, :func:`pipeline.simulation.forced_response`), the
time since the span start is made only for a fit whose columns need it, and the design is
kept as its columns (:class:`Columns`), reduced to criterion rows one at a time and
multiplied out a chunk of samples at a time, never stacked into one span-long matrix."""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..fit import InitialState
from ..memory import CHUNK
from ..models import STRUCTURES
from ..record import uniform_step
from ..simulation import UNIFORM_REL_TOL, each_free_column, forced_response, offset_response
from .lstsq import block_bounds, blocks


@dataclass(frozen=True)
class Columns:
    """The span columns of a linear solve, in the order of its coefficients: ``forced``
    (the forced response), the offset (all ones: not stored, its rows are
    :attr:`Problem.offset_rows`), then ``nuisance`` (an integrating structure's input
    balance, the free response of an estimated state). With linear parameters
    ``forced`` holds the forced response at them all 0, then its change per unit of
    each."""

    forced: list[np.ndarray]
    nuisance: list[np.ndarray]

    def product(self, c: np.ndarray, mask: np.ndarray | None = None,
                chunk: int = CHUNK) -> np.ndarray:
        """``design @ c`` at the samples of ``mask`` (all: None), the design's rows
        stacked ``chunk`` samples at a time (:data:`pipeline.memory.CHUNK`): each sample's
        product is the same row by the same coefficients as in the whole stacked
        design's. A chunk is never one row (numpy takes a dot product there, not the
        matrix-vector product, and rounds differently): a last single row joins the
        chunk before it. The chunks' products are written into the one output array (not
        a list of pieces and then their concatenation: one array of its length less)."""
        n = self.forced[0].size
        out = np.empty(n if mask is None else int(np.count_nonzero(mask)))
        s = k = 0
        while s < n:
            e = min(s + chunk, n)
            e = n if n - e == 1 else e
            a = np.column_stack([*(x[s:e] for x in self.forced), np.ones(e - s),
                                 *(x[s:e] for x in self.nuisance)])
            v = a @ c
            if mask is not None:
                v = v[mask[s:e]]
            out[k: k + v.size] = v
            k += v.size
            s = e
        return out


@dataclass(frozen=True)
class Problem:
    """The data of a fit. The criterion rows are the fit samples, or on a long window the
    means of blocks of consecutive fit samples times sqrt(block size) (the model is still
    simulated at every sample; averaging only drops within-block noise)."""

    structure: str
    t: np.ndarray  # the span's times, as given (not copied)
    t_rel: np.ndarray | None  # time since the span start, where a column needs it
    u: np.ndarray  # the span's input, as given (not copied)
    u_ref: float  # the input level the model starts at rest at
    y: np.ndarray  # measured output at the criterion rows
    mask: np.ndarray | None  # fit samples of the span (None: not kept, see with_mask)
    counts: np.ndarray  # fit samples per row
    dt: float | None
    horizon: float
    state: InitialState  # how the span starts (see pipeline.refine.refine)
    free_lags: int
    full: bool = False  # every sample of the span is a fit sample
    linear: tuple[str, ...] = ()  # LINEAR_PARAMS solved inside the residual (the search)
    bounds: np.ndarray | None = None  # reduceat boundaries in the span (None: no blocks)
    keep: np.ndarray | None = None  # which of the reduced blocks are rows
    offset: np.ndarray | None = None  # offset_rows, kept (None: made when asked)

    @classmethod
    def of(cls, t, u, y, structure: str, *, u_ref: float, mask: np.ndarray,
           initial_state: InitialState, free_lags: int, max_rows: int) -> Problem:
        """The problem of fitting ``structure`` to ``y`` over the span ``t, u`` (the model
        starting at the first sample) on the samples of ``mask``, in at most ``max_rows``
        criterion rows."""
        t = np.asarray(t, np.float64)
        dt = uniform_step(t, UNIFORM_REL_TOL)
        # the time since the span start is made once, for the problem and the copies it
        # shares its arrays with (folds), and only where a column needs it: the free
        # response and the input balance (a state not at rest), an irregular grid
        t_rel = t - t[0] if initial_state != "rest" or dt is None else None
        base = cls(structure, t, t_rel, np.asarray(u, np.float64), float(u_ref), np.empty(0),
                   None, np.zeros(0), dt, float(t[-1] - t[0]), initial_state, free_lags)
        return base.with_mask(mask, y, max_rows)

    def with_mask(self, mask: np.ndarray, y: np.ndarray, max_rows: int,
                  keep_mask: bool = True) -> Problem:
        """The same span and model with the criterion over ``mask``'s samples of the span
        output ``y`` (the span's arrays shared, not copied: one problem per
        cross-validation fold costs its rows only). Without ``keep_mask`` the mask is
        not kept where the rows are blocks (they are summed by their boundaries): a
        problem that only evaluates its criterion needs no span-long mask of its own."""
        mask = np.asarray(mask, bool)
        starts, counts = blocks(mask, max_rows)
        bounds, keep = ((None, None) if starts.size == np.count_nonzero(mask)
                        else block_bounds(mask, starts))
        if bounds is not None and mask.size < 2**31:  # half the index arrays a fold
            bounds, keep = bounds.astype(np.int32), keep.astype(np.int32)  # keeps: the
            # same sums (numpy.add.reduceat takes the indices as positions either way)
        prob = replace(self, mask=mask if keep_mask or bounds is None else None,
                       counts=counts, full=bool(mask.all()), bounds=bounds, keep=keep,
                       offset=None)
        return replace(prob, y=prob.rows(np.asarray(y, np.float64)),
                       offset=prob.offset_rows if keep_mask else None)

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
        straddle a gap of the mask (:func:`pipeline.refine.lstsq.blocks`), so they are summed in
        place, the gaps as blocks of their own that are dropped (the same sums as of the
        masked copy, without copying the span's columns on every evaluation)."""
        if self.bounds is None:  # a row per fit sample
            return a if self.full else a[self.mask]
        w = np.sqrt(self.counts) if a.ndim == 1 else np.sqrt(self.counts)[:, None]
        return np.add.reduceat(a, self.bounds, axis=0)[self.keep] / w

    @property
    def offset_rows(self) -> np.ndarray:
        """The rows of the offset column (all ones), which no parameter changes:
        :meth:`rows` of it without a span-long column of ones (a block's sum of ones is
        its length, exactly). Kept by a problem that keeps its mask (a search evaluates
        it thousands of times), made when asked by one that does not: a cross-validation
        fold's rows are a tenth of a long span's samples, and ten folds are held at once."""
        if self.offset is not None:
            return self.offset
        if self.bounds is None:
            return np.ones(self.t.size if self.full else int(np.count_nonzero(self.mask)))
        lengths = np.diff(np.append(self.bounds, self.t.size)).astype(np.float64)
        return lengths[self.keep] / np.sqrt(self.counts)

    def design_rows(self, p: Mapping[str, float]) -> np.ndarray:
        """The criterion rows of the design at ``p``: :meth:`reduce` of :meth:`columns`,
        the columns made and reduced one at a time (:meth:`rows_of`)."""
        return self.rows_of(p, [self])[0]

    def rows_of(self, p: Mapping[str, float], problems: Sequence[Problem]
                ) -> list[np.ndarray]:
        """The design rows at ``p`` of each of ``problems`` (this span and model with other
        masks: cross-validation folds). The span columns are made one at a time
        (:meth:`each_column`) and each is reduced for every problem before the next is
        made, where :meth:`columns` holds the design's two to six, each as long as the
        span: on a long span with blocks of rows, one column at a time beside the
        free responses' common term of an estimated state (a problem whose every sample
        is a row keeps a copy of each column: a short span); the same rows as
        :meth:`reduce` of :meth:`columns`."""
        n_forced = 1 + len(self.linear)
        rows: list[list[np.ndarray]] = [[] for _ in problems]
        for x in self.each_column(p):
            for f, r in zip(problems, rows, strict=True):
                v = f.rows(x)  # (every sample a row: the column itself, which the next
                r.append(v.copy() if v is x else v)  # may be made in)
            x = v = None  # not alive while the next column is made
        return [np.column_stack([*r[:n_forced], f.offset_rows, *r[n_forced:]])
                for f, r in zip(problems, rows, strict=True)]

    def reduce(self, cols: Columns) -> np.ndarray:
        """The design rows of the span columns ``cols``, reduced a column at a time (the
        same sums as of the stacked design's rows; the columns do not depend on the mask,
        so problems that differ only in it share them)."""
        return np.column_stack([*(self.rows(x) for x in cols.forced), self.offset_rows,
                                *(self.rows(x) for x in cols.nuisance)])

    def columns(self, p: Mapping[str, float]) -> Columns:
        """The span columns of the linear solve at ``p``: the forced response (with
        ``linear``: at 0 and the change per unit of each, the nuisance columns at 0
        too), then :meth:`each_nuisance`'s; all held at once (:meth:`each_column`'s, each
        in an array of its own)."""
        cols = list(self.each_column(p, in_place=False))
        return Columns(cols[: 1 + len(self.linear)], cols[1 + len(self.linear):])

    def each_column(self, p: Mapping[str, float], in_place: bool = True
                    ) -> Iterator[np.ndarray]:
        """:meth:`columns`' columns in their order (forced, then nuisance), made one at a
        time. With ``in_place`` a column is not to be used once the next is asked for:
        the change per unit of the last linear parameter is made in the array of the
        forced response at 0 (:func:`pipeline.simulation.forced_response`'s ``minus``)."""
        if not self.linear:
            yield self.forced(p)
            yield from self.each_nuisance(p)
            return
        base = {**p, **dict.fromkeys(self.linear, 0.0)}
        x0 = self.forced(base)
        yield x0
        for k, n in enumerate(self.linear):
            if in_place and k == len(self.linear) - 1:
                yield self.forced({**base, n: 1.0}, minus=x0)
            else:  # the change per unit, made in the response's own array
                x = self.forced({**base, n: 1.0})
                yield np.subtract(x, x0, out=x)
                del x
        del x0
        yield from self.each_nuisance(base)

    def forced(self, p: Mapping[str, float], minus: np.ndarray | None = None
               ) -> np.ndarray:
        """The unit-gain forced response over the span (less ``minus``, in its array)."""
        return forced_response(self.structure, dict(p),
                                     self.t_rel if self.dt is None else self.t, self.u,
                                     self.dt, u0=self.u_ref, minus=minus)

    def each_nuisance(self, p: Mapping[str, float]) -> Iterator[np.ndarray]:
        """The span's nuisance columns other than the offset, one at a time: an
        integrating structure's input balance (lagged with an estimated state, a ramp on
        a steady one), and the free-response columns of an estimated state."""
        if self.balance:
            yield (offset_response(self.structure, dict(p), self.t_rel)
                   if self.estimate_state else self.t_rel)
        if self.estimate_state:
            yield from each_free_column(self.structure, dict(p), self.t_rel,
                                              self.horizon, self.free_lags)
