"""Folders of synthetic CSV logs with known truth: batch tests, examples and benchmarks.

Each log is one first-order-plus-dead-time plant ``K e^{-delay s}/(T s + 1)`` (nominal
K = 2, T = 5 s, delay = 0.5 s; K and T vary mildly from file to file) driven by a
staircase input from a nonzero operating point, sampled at ``dt``, with white output
noise of standard deviation ``noise_rel`` times the typical output change. Columns
``time, u, y`` (seconds, input, output).

Everything is deterministic for a ``seed``. Three independent random streams keep the
knobs independent of each other:

* the plant and the experiment of file ``i`` come from ``(seed, i)``: the same seed gives
  the same plants and step schedules whatever ``n``, ``corrupt`` or ``noise_seed``;
* the noise of file ``i`` comes from ``(noise_seed, i)`` (``noise_seed`` defaults to
  ``seed``): a new ``noise_seed`` is "the same plants, logged again with fresh noise";
* which files are corrupted comes from ``seed`` alone.

:func:`plan_logs` is the pure part (what each file will contain, including its truth);
:func:`write_synthetic_logs` and :func:`write_nights` write files.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import polars as pl

from ..errors import UserError
from ..files import write_atomic
from ..models import ProcessModel
from ..record import Record, make_record
from .plants import response, staircase

#: The ways a log can be bad, assigned in this order to the corrupted files.
CORRUPTIONS: tuple[str, ...] = ("truncated", "non_numeric", "missing_output", "empty", "binary")

NOMINAL = {"K": 2.0, "T": 5.0, "delay": 0.5}


@dataclass(frozen=True)
class LogPlan:
    """What one synthetic log contains: its true plant, its input and its noise.

    ``changes`` are the ``(time, level)`` input steps (see :func:`pipeline.synth.staircase`);
    ``corruption`` is one of :data:`CORRUPTIONS` or ``None`` for a good file.
    """

    name: str
    K: float
    T: float
    delay: float
    u0: float
    y0: float
    changes: tuple[tuple[float, float], ...]
    t_end: float
    dt: float
    noise: float
    noise_seed: int
    corruption: str | None = None

    @property
    def model(self) -> ProcessModel:
        return ProcessModel("first_order", {"K": self.K, "T": self.T, "delay": self.delay})


def plan_logs(n: int, *, seed: int = 0, noise_seed: int | None = None,
              gain_drift: float = 0.0, corrupt: int = 0, noise_rel: float = 0.01,
              n_steps: int = 4, K: float = NOMINAL["K"], T: float = NOMINAL["T"],
              delay: float = NOMINAL["delay"], spread: float = 0.05, dt: float = 0.1,
              hold: tuple[float, float] = (6.0, 10.0), prefix: str = "log") -> list[LogPlan]:
    """Plans of ``n`` logs named ``{prefix}_000`` ... (pure; see the module docstring).

    ``spread``: K and T of each file are uniform within +-spread (relative) of the nominal
    values. ``gain_drift``: every K is multiplied by ``1 + gain_drift``. ``hold``: the
    time between steps, in nominal time constants (uniform in the range). ``corrupt``:
    how many of the files are made bad (which ones depends on ``seed`` only). A count out
    of range is a one-line :class:`~pipeline.errors.UserError`.
    """
    if n < 0:
        raise UserError(f"n must be at least 0, got {n}")
    if not 0 <= corrupt <= n:
        raise UserError(f"corrupt must be between 0 and n={n}, got {corrupt}")
    if n_steps < 1:
        raise UserError(f"n_steps must be at least 1, got {n_steps}")
    ns = seed if noise_seed is None else noise_seed
    bad = _corrupted_indices(n, corrupt, seed)
    plans = []
    for i in range(n):
        plan = _plan_one(np.random.default_rng([seed, i]), f"{prefix}_{i:03d}", K=K, T=T,
                         delay=delay, spread=spread, dt=dt, n_steps=n_steps, hold=hold,
                         noise_rel=noise_rel, noise_seed=ns)
        plans.append(replace(plan, K=plan.K * (1.0 + gain_drift), corruption=bad.get(i)))
    return plans


def _corrupted_indices(n: int, corrupt: int, seed: int) -> dict[int, str]:
    """``{file index: corruption kind}``, kinds cycling through :data:`CORRUPTIONS`."""
    if corrupt == 0:
        return {}
    idx = sorted(int(i) for i in np.random.default_rng([seed, 1_000_003]).choice(
        n, size=corrupt, replace=False))
    return {i: CORRUPTIONS[k % len(CORRUPTIONS)] for k, i in enumerate(idx)}


def _plan_one(rng: np.random.Generator, name: str, *, K: float, T: float, delay: float,
              spread: float, dt: float, n_steps: int, hold: tuple[float, float],
              noise_rel: float, noise_seed: int) -> LogPlan:
    k_i = K * (1.0 + rng.uniform(-spread, spread))
    t_i = T * (1.0 + rng.uniform(-spread, spread))
    u0 = round(float(rng.uniform(40.0, 60.0)), 2)
    y0 = round(float(rng.uniform(20.0, 80.0)), 2)
    level, t_c, changes = u0, _on_grid(rng.uniform(1.0, 2.0) * T, dt), []
    for _ in range(n_steps):
        du = float(rng.uniform(7.0, 13.0)) * (1 if rng.random() < 0.5 else -1)
        if not 10.0 <= level + du <= 90.0:  # keep the actuator inside its range
            du = -du
        level = round(level + du, 2)
        changes.append((t_c, level))
        t_c = _on_grid(t_c + rng.uniform(*hold) * T, dt)
    noise = noise_rel * abs(K) * 10.0  # 10 = the mean |du|: about noise_rel of each step
    return LogPlan(name=name, K=float(k_i), T=float(t_i), delay=float(delay), u0=u0, y0=y0,
                   changes=tuple(changes), t_end=t_c, dt=dt, noise=noise,
                   noise_seed=int(noise_seed))


def _on_grid(t: float, dt: float) -> float:
    """``t`` rounded to the sample grid (steps on samples keep the ZOH response exact)."""
    return round(round(t / dt) * dt, 10)


def log_frame(plan: LogPlan) -> pl.DataFrame:
    """The clean ``time, u, y`` table of a plan (corruption is applied when writing)."""
    t = np.arange(int(round(plan.t_end / plan.dt)) + 1) * plan.dt
    u = staircase(t, plan.u0, plan.changes)
    seed = int(np.random.default_rng([plan.noise_seed, _name_key(plan.name)]).integers(2**31))
    y = response(plan.model, t, u, plan.u0, plan.y0, plan.noise, seed)
    return pl.DataFrame({"time": t, "u": u, "y": y})


def log_record(plan: LogPlan) -> Record:
    """The clean log of a plan as a :class:`~pipeline.record.Record` (no file involved)."""
    f = log_frame(plan)
    return make_record(f.get_column("time").to_numpy(), f.get_column("u").to_numpy(),
                       f.get_column("y").to_numpy(), name=plan.name,
                       source=f"<synthetic {plan.name}>")


def _name_key(name: str) -> int:
    """A stable integer for a file name (Python's ``hash`` is salted per process)."""
    return int.from_bytes(name.encode()[-16:].rjust(16, b"\0"), "big") % (2**63)


def log_bytes(plan: LogPlan) -> bytes:
    """The file content of a plan: CSV text, or bad bytes when it is corrupted."""
    frame = log_frame(plan)
    rng = np.random.default_rng([plan.noise_seed, _name_key(plan.name), 7])
    match plan.corruption:
        case None:
            return frame.write_csv().encode()
        case "missing_output":
            return frame.drop("y").write_csv().encode()
        case "empty":
            return b""
        case "binary":
            return rng.integers(0, 256, size=4096, dtype=np.uint8).tobytes()
        case "truncated":
            lines = frame.write_csv().splitlines()
            cut = len(lines) // 2  # a logger that died while writing the time stamp's row
            return ("\n".join(lines[:cut]) + "\n" + lines[cut].split(",")[0] + ",").encode()
        case "non_numeric":
            lines = frame.write_csv().splitlines()
            row = int(rng.integers(2, len(lines) - 1))
            lines[row] = ",".join(lines[row].split(",")[:2] + ["ERR"])
            return ("\n".join(lines) + "\n").encode()
    raise ValueError(f"unknown corruption {plan.corruption!r}")


def write_synthetic_logs(folder: str | os.PathLike, n: int, *, seed: int = 0,
                         gain_drift: float = 0.0, corrupt: int = 0, noise_rel: float = 0.01,
                         n_steps: int = 4, **plan_options) -> list[Path]:
    """Write ``n`` CSV logs into ``folder`` (created) and return their paths in order.

    ``gain_drift`` multiplies every K by ``1 + gain_drift``; ``corrupt`` of the files are
    made bad in varied ways (:data:`CORRUPTIONS`). Further keywords go to
    :func:`plan_logs` (``noise_seed``, ``K``, ``T``, ``delay``, ``spread``, ``dt``,
    ``hold``, ``prefix``); call it with the same arguments to get each file's truth.
    """
    plans = plan_logs(n, seed=seed, gain_drift=gain_drift, corrupt=corrupt,
                      noise_rel=noise_rel, n_steps=n_steps, **plan_options)
    out = Path(folder)
    if out.exists() and not out.is_dir():
        raise UserError(f"{out}: exists and is not a folder; expected a folder for the logs")
    paths = []
    for plan in plans:
        path = out / f"{plan.name}.csv"
        write_atomic(path, log_bytes(plan), "synthetic log")
        paths.append(path)
    return paths


def night_drift(night: int, drift_per_night: float) -> float:
    """Gain drift of night ``night`` (0-based): linear, ``K_k = K (1 + k d)``."""
    return night * drift_per_night


def write_nights(folder: str | os.PathLike, nights: int = 5, drift_per_night: float = 0.02,
                 *, n: int = 3, seed: int = 0, noise_rel: float = 0.01,
                 **plan_options) -> list[Path]:
    """One sub-folder ``night_01`` ... per night with ``n`` logs each; return the folders.

    The same plants every night (same ``seed``) with fresh noise (``noise_seed`` differs
    per night) and the gain drifting by ``drift_per_night`` per night (linear, see
    :func:`night_drift`): the history example's trend.
    """
    out = Path(folder)
    dirs = []
    for k in range(nights):
        night_dir = out / f"night_{k + 1:02d}"
        write_synthetic_logs(night_dir, n, seed=seed, noise_seed=seed * 1000 + k + 1,
                             gain_drift=night_drift(k, drift_per_night),
                             noise_rel=noise_rel, **plan_options)
        dirs.append(night_dir)
    return dirs
