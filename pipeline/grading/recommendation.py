"""The recommended model of a record: the lowest held-out error, the simpler structure when
the difference is within its uncertainty (DESIGN.md "Validation and grading").

:func:`recommend` is a pure function of a :class:`~pipeline.results.RecordResult` (or
anything with its ``record``, ``events``, ``fits``, ``validation_events`` and
``identification_events``) and returns a :class:`~pipeline.results.Recommendation`:

1. The criterion: the validation MSE when the record has validation events; else, with
   several identification events, the held-out MSE (``mse_cross_validation``:
   leave-one-event-out for a model of all events, the other events for a model of one;
   beyond ten events, ten folds and ten other events, :mod:`pipeline.refine.joint`);
   else (one event, nothing held out) Akaike's information criterion on the
   identification fit (``aic``).
2. Each structure is represented by its least-squares refinement (fitted to all the
   identification data, with intervals), unless a graphical model of that structure is
   better by more than the uncertainty (Bonferroni-corrected for their number,
   :data:`LEVEL`) and fits their event closer (:func:`missed`: the refinement missed).
   Where no refinement is left a reading can be the answer; else it never is
   (:func:`candidates`). Across structures the lowest wins, unless a
   simpler structure (fewer parameters in the structure table) is not worse by more than
   :data:`Z_STRUCTURE` standard errors, or predicts the same within a quarter of the noise
   (:func:`equivalent`: a more complex structure that nests it wins such ties only by
   fitting noise). For a held-out MSE the uncertainty is a paired
   test on the squared errors of the same samples: a candidate is as good as the best
   when the mean of ``e_c^2 - e_best^2`` is within ``z`` standard errors of zero, the
   standard error the one fresh noise would give
   (:func:`paired_difference`; cf. the Diebold-Mariano test, F. X. Diebold, R. S.
   Mariano, "Comparing predictive accuracy", J. Business & Economic Statistics
   13(3):253-263, 1995). For the AIC, a difference of at most 2 (K. P. Burnham, D. R.
   Anderson, Model Selection and Multimodel Inference, 2nd ed., 2002, sec. 2.6). So fresh
   noise does not flip the choice night to night between models the data cannot tell
   apart, and a far worse model is never "as good" because its errors are one long
   correlated pattern.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

from ..events import Event
from ..fit import VERDICTS, Fit
from ..memory import CHUNK
from ..models import ProcessModel
from ..record import Record
from ..refine import fold_models, held_out_events
from ..results import Recommendation
from ..uncertainty import variance_factor
from ..validate import heldout_residuals, run_errors, validation_simulation

#: Standard errors within which a simpler structure counts as good as the best (95 %).
Z_STRUCTURE = 1.96
#: Models whose held-out predictions differ by less than this share of the noise standard
#: deviation (RMS) are equivalent: the simpler structure is kept.
EQUIVALENT = 0.25
#: Family-wise level at which a graphical model must beat the refinement of its own
#: structure (Bonferroni over the graphical models of the structure): the best of several
#: readings on the same validation noise wins by chance often.
LEVEL = 0.05
#: AIC difference within which a simpler model counts as good as the best.
AIC_MARGIN = 2.0


def information_criteria(errors: Sequence[tuple[float, int, float]], n_params: Sequence[int]
                         ) -> list[float]:
    """AIC ``n_eff ln(SSE / n) + 2 k`` of fits to the same samples (``errors``: SSE, n,
    variance factor), with one effective sample size for all: ``n / f`` of the fit with
    the smallest SSE (Akaike's criterion for Gaussian errors, Ljung, System
    Identification, 2nd ed., eq. 16.33; ``n_eff`` for coloured residuals)."""
    if not errors:
        return []
    best = min(errors, key=lambda e: e[0])
    n_eff = best[1] / max(best[2], 1.0)
    return [n_eff * math.log(max(sse, 1e-300) / n) + 2 * k
            for (sse, n, _), k in zip(errors, n_params, strict=True)]


def complexity(fit: Fit) -> int:
    """Parameters of the fit's structure (the structure table): the simpler, the fewer."""
    return len(fit.model.spec.params)


@dataclass(frozen=True)
class Candidate:
    """A fit, its criterion value and its held-out errors at sample indices ``idx`` (None
    until :func:`loaded`: a record's held-out errors are as long as the record, so only
    the few candidates being compared hold theirs, not every fit at once)."""

    fit: Fit
    error: float
    idx: np.ndarray | None = None
    e: np.ndarray | None = None


def loaded(c: Candidate, result) -> Candidate:
    """``c`` with its held-out errors (:func:`held_out`)."""
    return c if c.idx is not None else Candidate(c.fit, c.error, *held_out(c.fit, result))


#: Each criterion in words (the reasons, the report's headings) and as a column's name.
CRITERION_NAMES = {"mse_validation": "validation MSE", "mse_cross_validation": "held-out MSE",
                   "aic": "AIC on the identification event"}
CRITERION_COLUMNS = {"mse_validation": "validation MSE", "mse_cross_validation":
                     "held-out MSE", "aic": "AIC"}


def criterion(result) -> str:
    """Which error decides for this record (see the module docstring)."""
    if result.validation_events:
        return "mse_validation"
    if len(result.identification_events) > 1:
        return "mse_cross_validation"
    return "aic"


def ranked(result, event: int | None = None) -> list[Fit]:
    """The ok fits (of the identification ``event``; None: all) in the order of the
    criterion the recommendation decides by (:func:`criterion`), ISE on the
    identification event breaking ties; a fit without the criterion last. The per-method
    table beside the recommendation, not a second answer: the recommended fit need not
    be first (a simpler structure within the uncertainty wins)."""
    crit = criterion(result)

    def key(f: Fit) -> tuple[float, float]:
        v, i = f.metrics.get(crit, math.nan), f.metrics.get("ise", math.nan)
        return (v if math.isfinite(v) else math.inf, i if math.isfinite(i) else math.inf)

    return sorted((f for f in result.fits if f.ok and (event is None or f.event == event)),
                  key=key)


def held_out(fit: Fit, result) -> tuple[np.ndarray, np.ndarray]:
    """``(sample indices, errors)`` of a fit on the data held out from it."""
    rec, events, u0 = result.record, list(result.events), fit.balance_point
    if result.validation_events:
        return heldout_residuals(fit.model, rec, events, result.validation_events, u0)
    if fit.is_refined and fit.refinement.folds:
        return in_time_order([_fold_errors(m, rec, events, held, b) for held, m, b in
                              fold_models(fit.model.structure, fit.refinement.folds)])
    others = held_out_events(result.identification_events, fit.event)
    return heldout_residuals(fit.model, rec, events, others, u0)


def _fold_errors(model: ProcessModel, record: Record, events: list[Event], held: list[int],
                 balance: float | None
                 ) -> tuple[np.ndarray, np.ndarray, list[tuple[int, int]]]:
    """A fold's held-out ``(sample indices, errors)`` and the ``(start, stop)`` samples of
    each of its runs, in their order (:func:`pipeline.validate.heldout_residuals`)."""
    sims = validation_simulation(model, record, events, held, balance)
    runs = [(s.start, s.stop) for s, _ in sims]
    return (*run_errors(sims, record), runs)


def in_time_order(parts: list[tuple[np.ndarray, np.ndarray, list[tuple[int, int]]] | None]
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The folds' errors ``parts`` (:func:`_fold_errors`) as one series in time order:
    the folds' runs copied one after another in the order they start, where no two runs
    share a sample (disjoint events); else, as for any overlap, the concatenated samples
    sorted stably. The same arrays either way, without the argsort of record-long
    indices and its reordered copies (interleaved folds over a long record). Empties
    ``parts`` as it goes (a fold set to None once its runs are copied)."""
    runs = sorted((a, b, f, k) for f, (_, _, rs) in enumerate(parts)
                  for k, (a, b) in enumerate(rs))
    if any(r[1] > q[0] for r, q in itertools.pairwise(runs)):
        idx = np.concatenate([p[0] for p in parts])
        order = np.argsort(idx, kind="stable")
        return idx[order], np.concatenate([p[1] for p in parts])[order]
    n = sum(p[0].size for p in parts)
    idx = np.empty(n, np.result_type(*(p[0] for p in parts)))  # the concatenation's
    e = np.empty(n)
    # where each run goes (the runs in time order, one after another), then fold by fold,
    # each fold's arrays dropped once its runs are copied: the output's pages are touched
    # as the folds' are freed, so the two are not both resident
    dest = np.cumsum([0] + [b - a for a, b, _, _ in runs])
    moves: list[list[tuple[int, int, int]]] = [[] for _ in parts]
    for (a, b, f, j), k in zip(runs, dest[:-1], strict=True):
        moves[f].append((j, int(k), b - a))
    for f, fold in enumerate(moves):
        starts = np.cumsum([0] + [b - a for a, b in parts[f][2]])
        for j, k, m in fold:
            o = starts[j]
            idx[k: k + m] = parts[f][0][o: o + m]
            e[k: k + m] = parts[f][1][o: o + m]
        parts[f] = None
    return idx, e


def candidates(result, crit: str) -> list[Fit]:
    """The fits the recommendation chooses from: ok, with a finite criterion; once graded,
    not unreliable while any other is not; not undetermined (:func:`undetermined`) while a
    determined refinement fits within the noise (:func:`fits_within_noise`, and no richer
    refinement earns its parameters over it, :func:`outfitted`; a reading, without
    intervals, is not known to be determined and sets nothing aside): the more complex
    model must earn its parameters, and a model that cannot be trusted is never the answer
    while another can; no integrating model of a record whose responses settle while a
    self-regulating one is left (``no_integrating_evidence``). A graphical reading (no
    intervals) is a candidate only while no refinement is, where its structure was not
    refined at all (not asked for, or the refinement failed), or where the refinement of
    its structure missed on their event (:func:`missed`): the recommended model carries
    intervals wherever a refinement of its structure is left (issue 27 item 1); a reading
    of a structure whose refinement was set aside (undetermined, unreliable) does not
    stand in for it."""
    fits = [f for f in result.fits if f.ok and f.model is not None
            and math.isfinite(f.metrics.get(crit, math.nan))]
    usable = [f for f in fits if f.verdict != "unreliable"]
    fits = usable or fits
    evident = [f for f in fits if not _flagged(f, "no_integrating_evidence")]
    fits = evident or fits
    if any(f.is_refined and not undetermined(f) and fits_within_noise(f)
           and not outfitted(f, fits) for f in fits):
        fits = [f for f in fits if not undetermined(f)]
    refined = [f for f in fits if f.is_refined]
    if not refined:
        return fits
    ran = {f.model.structure for f in result.fits if f.is_refined and f.ok and f.model}
    return refined + [g for g in fits if not g.is_refined and (
        g.model.structure not in ran or any(missed(f, g) for f in refined
                                            if f.model.structure == g.model.structure))]


def earns_parameters(complex_: Fit, simple: Fit, level: float = LEVEL) -> bool:
    """Whether ``complex_`` fits its identification event significantly better than the
    simpler ``simple`` on the same event: the likelihood-ratio statistic ``n_eff ln(SSE_s
    / SSE_c)`` beyond the chi-square quantile at ``level`` with their difference in
    parameters (Ljung, System Identification, 2nd ed., sec. 16.4; ``n_eff`` for coloured
    residuals, as in their AIC). Read from their AIC: ``aic = n_eff ln(SSE/n) + 2 k``.
    False unless both are one-event fits of the same event with an AIC and ``complex_``
    has more parameters: held-out data that cannot tell two models apart then leave the
    choice to the identification data, which can (a second lag shows in the rise)."""
    if complex_.events or simple.events or complex_.event != simple.event:
        return False
    a_c, a_s = complex_.metrics.get("aic", math.nan), simple.metrics.get("aic", math.nan)
    dk = complex_.n_params - simple.n_params
    if not (math.isfinite(a_c) and math.isfinite(a_s)) or dk <= 0:
        return False
    lr = (a_s - 2 * simple.n_params) - (a_c - 2 * complex_.n_params)
    return lr > float(stats.chi2.ppf(1.0 - level, dk))


#: The flags that say a model misses the data beyond the noise (on its own event, on the
#: events it did not see, or worse than a constant there).
MISFIT_FLAGS = ("residuals_not_white", "validation_misfit", "poor_fit", "negative_fit",
                "gain_sign_wrong")


def fits_within_noise(fit: Fit) -> bool:
    """Whether no flag above information says the model misses the data beyond the noise
    (:data:`MISFIT_FLAGS`)."""
    return not any(_flagged(fit, code) for code in MISFIT_FLAGS)


def outfitted(fit: Fit, fits: Sequence[Fit], level: float = LEVEL) -> bool:
    """Whether a richer refinement among ``fits`` fits ``fit``'s own event significantly
    better (:func:`earns_parameters`): then ``fit`` does not fit within the noise, whatever
    its flags say, and an undetermined refinement that earns its parameters is not set
    aside for it (issue 27 item 1, the likelihood-ratio half). On an inverse response
    logged with AR(1) noise, ``lsq_first_order`` 6 % off the truth with clean flags was kept
    over the right ``lsq_zero_two_lags`` (a wide zero interval, its AIC 17 lower on the
    same event). The level is Bonferroni-corrected for the richer refinements tried (the
    best of five fits the noise better by chance more often than one), and a refinement
    with a part faster than the sample time does not count: it gains on the sampling's
    own detail (a dead time between samples), not on dynamics the record resolves (on a
    first-order plant with white noise, ``lsq_zero_two_lags`` with a 0.12 s zero and a
    0.009 s lag, both within one 0.2 s sample, earned its two parameters over the right
    first-order fit; its step response was 1.1 % off, the first order's 0.2 %)."""
    richer = [g for g in fits if g.is_refined and g is not fit and not g.events
              and g.event == fit.event and g.n_params > fit.n_params
              and not _flagged(g, "dynamics_below_sample_time")]
    return any(earns_parameters(g, fit, level / len(richer)) for g in richer)


def undetermined(fit: Fit) -> bool:
    """Whether a parameter of the fit that matters is not determined by the data: a
    ``wide_ci`` flag above information (its interval is wide, and the response or the
    gain moves with it), or a time constant below the sample time (the data only say that
    part is fast)."""
    return _flagged(fit, "wide_ci") or _flagged(fit, "dynamics_below_sample_time")


def _flagged(fit: Fit, code: str) -> bool:
    return any(f.code == code and f.severity != "info" for f in fit.flags)


def preference(fit: Fit) -> tuple:
    """How the recommendation orders models it cannot tell apart by their error: the
    better verdict, determined parameters, a refinement (fitted to all the identification
    data, with intervals) over a reading, then the simpler structure."""
    return (_rank(fit), undetermined(fit), not fit.is_refined, complexity(fit))


def _rank(fit: Fit) -> int:
    """The verdict's place in :data:`pipeline.fit.VERDICTS` (ok first; ungraded as ok)."""
    return VERDICTS.index(fit.verdict) if fit.verdict in VERDICTS else 0


def noise_floor(result) -> float:
    """The smallest fit error (a variance) of a refinement on its own identification
    data: :func:`recommend` takes the noise as this or segmentation's estimate of the
    measurement noise, whichever is larger (slow noise, AR(1) or 1/f, is read too small
    from the differences; a right model's own residuals are that noise, colour and all,
    and they do not hold the held-out misfit a wrong model adds)."""
    own = [f.refinement.mse_fit for f in result.fits
           if f.ok and f.is_refined and math.isfinite(f.refinement.mse_fit)]
    return min(own) if own else 0.0


def recommend(result, *, level: float = LEVEL, aic_margin: float = AIC_MARGIN
              ) -> Recommendation | None:
    """The recommended model of ``result`` (see the module docstring); None without an ok
    fit that has a finite criterion."""
    crit = criterion(result)
    fits = candidates(result, crit)
    if not fits:
        return None
    if crit == "aic":
        return _by_aic(fits, aic_margin)
    cands = [Candidate(f, float(f.metrics[crit])) for f in fits]
    lowest = min(cands, key=lambda c: c.error)
    noise = max(measurement_noise(result, loaded(lowest, result).idx), noise_floor(result))
    # the lowest's errors are made again where they are needed (below): only two
    # candidates' record-long errors are alive at once, the best's and the one compared
    # with it, not three; at the cost of simulating its held-out events once or twice
    # more (for a joint fit, its folds' models over their events)
    reps = [_representative(group, noise, level, result) for group in _by_structure(cands)]
    best = loaded(min(reps, key=lambda c: (c.error, complexity(c.fit))), result)
    tied = []
    for c in reps:
        if c.fit is best.fit:
            tied.append((best, ""))
            continue
        if earns_parameters(best.fit, c.fit, level):
            continue  # its own event already tells the simpler model is worse
        c = loaded(c, result)  # one at a time: released after its comparison
        diff, se = paired_difference(c, best, noise)
        if diff <= Z_STRUCTURE * se:
            tied.append((Candidate(c.fit, c.error), f"difference {diff:.3g} +- {se:.2g}, "
                         f"within {Z_STRUCTURE:g} standard errors"))
        elif equivalent(c, best, noise):
            tied.append((Candidate(c.fit, c.error), "their held-out predictions agree "
                         f"within {EQUIVALENT:g} of the noise"))
    chosen, margin = min(tied, key=lambda t: (*preference(t[0].fit), t[0].error))
    name = CRITERION_NAMES[crit]
    if chosen.fit is not best.fit or lowest.fit is chosen.fit:
        return _recommendation(chosen.fit, best.fit, name, chosen.error, best.error,
                               len(cands), margin)
    diff, se = paired_difference(loaded(chosen, result), loaded(lowest, result), noise)
    kind = lowest.fit.model.structure
    own = [c.fit for c in cands if c.fit.is_refined and c.fit.model.structure == kind]
    graded_worse = bool(own) and _rank(lowest.fit) > min(_rank(f) for f in own)
    why = (f"but its verdict is {lowest.fit.verdict} (" + ", ".join(dict.fromkeys(
        f.code for f in lowest.fit.flags if f.severity != "info")) + ")" if graded_worse
        else f"within the uncertainty (difference {diff:.3g} +- {se:.2g})")
    kind = kind.replace("_", " ")
    reason = (f"{name} {chosen.error:.4g} ({_where(chosen.fit)}); {lowest.fit.method}, a "
              f"reading of {'an' if kind[0] in 'aeiou' else 'a'} {kind} model, scored "
              f"{lowest.error:.4g}, {why}, and its structure is represented by its "
              "refinement, fitted to all the identification data, with intervals")
    return Recommendation(chosen.fit.method, chosen.fit.event, reason,
                          events=tuple(chosen.fit.events))


def equivalent(c: Candidate, best: Candidate, noise: float) -> bool:
    """Whether two models predict the held-out samples within :data:`EQUIVALENT` of the
    noise standard deviation (RMS): then they are the same model for any use, and a win
    of the more complex one is its extra parameters fitting the identification noise."""
    ec, eb = common_errors(c, best)
    if ec.size == 0:
        return False
    return math.sqrt(_paired_sums(ec, eb)[1] / ec.size) <= EQUIVALENT * math.sqrt(noise)


def _by_structure(cands: list[Candidate]) -> list[list[Candidate]]:
    groups: dict[str, list[Candidate]] = {}
    for c in cands:
        groups.setdefault(c.fit.model.structure, []).append(c)
    return list(groups.values())


def _representative(group: list[Candidate], noise: float, level: float, result
                    ) -> Candidate:
    """The model that stands for a structure: its best refinement, unless a graphical
    model of the structure with a verdict no worse is better by more than the uncertainty
    (Bonferroni over them: the best of several readings on the same validation noise wins
    by chance often). A reading graded worse than the refinement never stands for it."""
    lsq = [c for c in group if c.fit.is_refined]
    graph = sorted((c for c in group if not c.fit.is_refined), key=lambda c: c.error)
    if not lsq:
        return graph[0]
    rep = min(lsq, key=lambda c: c.error)
    graph = [c for c in graph if _rank(c.fit) <= _rank(rep.fit) and missed(rep.fit, c.fit)]
    if graph and graph[0].error < rep.error:
        diff, se = paired_difference(loaded(rep, result), loaded(graph[0], result), noise)
        if diff > float(stats.norm.ppf(1 - level / (2 * len(graph)))) * se:
            return graph[0]
    return rep


def missed(refined: Fit, reading: Fit) -> bool:
    """Whether the refinement ``refined`` missed on its own data: a graphical ``reading``
    of its structure and event simulates that event closer to the measurement
    (``mse_identification``). Only then can the reading stand for the structure: a
    refinement is the least-squares optimum from starts that include the reading, so
    where the reading validates better while fitting its own event worse, that is the
    luck of the held-out noise (or a bias the reading shares with no other data), and the
    answer keeps the refinement's intervals (issue 27 item 1)."""
    a = refined.metrics.get("mse_identification", math.nan)
    b = reading.metrics.get("mse_identification", math.nan)
    return refined.event == reading.event and math.isfinite(a) and math.isfinite(b) \
        and b < a


def measurement_noise(result, idx: np.ndarray) -> float:
    """Variance of the measurement noise on the samples ``idx``: the mean of the squared
    noise estimates of the events they belong to (segmentation's estimate from fourth
    differences, which a smooth misfit does not enter). One binary search per event in
    the sorted samples instead of a mask per event: linear in the record, not
    O(events x samples)."""
    s = np.asarray(idx)
    s = s if increasing(s) else np.sort(s)  # held-out samples come in time order
    first = np.searchsorted(s, [e.i_start for e in result.events])
    evs = [e for e, k in zip(result.events, first, strict=True)
           if k < s.size and s[k] < e.i_end]
    return float(np.mean([e.noise**2 for e in evs])) if evs else 0.0


def common_errors(c: Candidate, best: Candidate) -> tuple[np.ndarray, np.ndarray]:
    """The two candidates' errors on the samples both were scored on, in time order
    (``numpy.intersect1d``; for the same samples, the usual case, the arrays themselves:
    no sort of both index arrays, no copies of record-long errors)."""
    if c.idx.shape == best.idx.shape and np.array_equal(c.idx, best.idx) \
            and increasing(c.idx):
        return c.e, best.e
    _, ic, ib = np.intersect1d(c.idx, best.idx, return_indices=True)
    return c.e[ic], best.e[ib]


def paired_difference(c: Candidate, best: Candidate, noise: float) -> tuple[float, float]:
    """Mean of ``d = e_c^2 - e_best^2`` over the samples both were scored on, and its
    standard error under fresh noise.

    Both errors share the measured noise ``n``: ``e = m + n`` with each model's own misfit
    ``m``, so ``delta = e_c - e_best = m_c - m_best`` holds no noise and ``d = 2 delta
    e_best + delta^2``. Fresh noise moves the mean of ``d`` through ``2 delta n`` only:
    ``Var = 4 sigma^2 f mean(delta^2) / N`` with ``sigma^2`` the measurement noise
    variance (``noise``, :func:`measurement_noise`) and ``f`` the colour of the best
    model's errors (:func:`pipeline.uncertainty.variance_factor`). The sample variance of
    ``d``, or the best model's error as the noise, would count a systematic misfit (one
    long correlated error pattern) as uncertainty and call a far worse model "as good"."""
    ec, eb = common_errors(c, best)
    if ec.size < 2:
        return math.inf, 0.0
    sum_d, sum_delta2 = _paired_sums(ec, eb)
    var = 4 * noise * variance_factor(eb) * sum_delta2 / ec.size
    return sum_d / ec.size, math.sqrt(var / ec.size)


def increasing(idx: np.ndarray) -> bool:
    """Whether ``idx`` is strictly increasing, compared a chunk at a time (no
    record-long ``np.diff`` of the index, nor its comparison)."""
    for k in range(0, idx.size - 1, CHUNK):
        e = min(k + CHUNK, idx.size - 1)
        if not bool(np.all(idx[k + 1 : e + 1] > idx[k:e])):
            return False
    return True


def _paired_sums(ec: np.ndarray, eb: np.ndarray) -> tuple[float, float]:
    """``(sum of e_c^2 - e_best^2, sum of (e_c - e_best)^2)``, as ``delta (e_c + e_best)``
    and ``delta^2`` (``delta = e_c - e_best``: no cancellation when the two are close),
    chunk by chunk, so no temporary is as long as the errors (the same sums, to
    rounding)."""
    s_d = s_2 = 0.0
    for k in range(0, ec.size, CHUNK):
        a, b = ec[k: k + CHUNK], eb[k: k + CHUNK]
        delta = a - b
        s_2 += float(delta @ delta)
        s_d += float(delta @ (a + b))
    return s_d, s_2


def _by_aic(fits: list[Fit], margin: float) -> Recommendation:
    best = min(fits, key=lambda f: (f.metrics["aic"], complexity(f)))
    tied = [f for f in fits if f.metrics["aic"] <= best.metrics["aic"] + margin]
    chosen = min(tied, key=lambda f: (*preference(f), f.metrics["aic"]))
    return _recommendation(chosen, best, CRITERION_NAMES["aic"],
                           chosen.metrics["aic"], best.metrics["aic"], len(fits),
                           f"within {margin:g} of it", note="one identification event and no "
                           "validation event, so nothing was held out: ")


def _recommendation(chosen: Fit, best: Fit, name: str, err: float, best_err: float, n: int,
                    margin: str, note: str = "") -> Recommendation:
    where = _where(chosen)
    if chosen is best:
        return Recommendation(chosen.method, chosen.event, f"{note}lowest {name} ({err:.4g}) "
                              f"of {n} models ({where})", events=tuple(chosen.events))
    reason = (f"{note}{name} {err:.4g}, as good as the lowest ({best.method}: {best_err:.4g}; "
              f"{margin}), and {why_preferred(chosen, best)} ({where})")
    return Recommendation(chosen.method, chosen.event, reason, events=tuple(chosen.events))


def why_preferred(chosen: Fit, best: Fit) -> str:
    """The first of :func:`preference`'s reasons that sets ``chosen`` before ``best``."""
    a, b = preference(chosen), preference(best)
    if a[0] != b[0]:
        return f"a better verdict ({chosen.verdict} against {best.verdict})"
    if a[1] != b[1]:
        return "parameters the data determine (the lowest has one they do not)"
    if a[2] != b[2]:
        return ("a refinement, fitted to all the identification data, with intervals (the "
                "lowest is a graphical reading)")
    return (f"a simpler structure ({chosen.model.structure}, {complexity(chosen)} parameters "
            f"against {complexity(best)})")


def _where(fit: Fit) -> str:
    return f"events {', '.join(map(str, fit.events))}" if fit.events else f"event {fit.event}"
